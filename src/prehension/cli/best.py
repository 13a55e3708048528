"""``prehension solve --best N [--rank q1]`` and the friction model of the stored quality.

The options are added to ``solve`` (and ``batch``) by :func:`add_quality_arguments` and
:func:`add_best_arguments`; :func:`quality_options` and :func:`best_options` turn them into
:class:`~prehension.quality.QualityOptions` and :class:`~prehension.best.BestOptions`.
"""

from __future__ import annotations

from rich.table import Table

from ..errors import PrehensionError
from . import args as types

__all__ = [
    "add_quality_arguments", "add_best_arguments", "add_require_argument", "add_batch_arguments", "quality_options", "best_options", "batch_extras",
    "quality_lines", "best_table", "HOLD_CANDIDATES",
]  # fmt: skip

HOLD_CANDIDATES = 5  # --hold without --best: the candidates of --best 5 (solve and batch)


def add_quality_arguments(p) -> None:
    """The friction model of the quality stored with each solution (and of ``--rank``)."""
    g = p.add_argument_group("grasp quality (stored with each solution; docs/quality.md)")
    g.add_argument("--friction", type=types.finite, default=None, metavar="MU",
                   help="Coulomb friction coefficient of the contacts (default 0.6)")  # fmt: skip
    g.add_argument("--cone-edges", type=int, default=None, metavar="M", help="edges of each linearised friction cone (default 8)")
    g.add_argument("--torsion", type=types.finite, default=None, metavar="MM",
                   help="soft fingers: torsional friction [mm] (default 0: hard fingers; a two-finger pinch needs it)")  # fmt: skip


def add_require_argument(p) -> None:
    """``solve --require force-closure``: only a force-closure grasp is an answer."""
    p.add_argument("--require", choices=("force-closure",), default=None,
                   help="force-closure: answer only with a force-closure grasp (with --friction/--cone-edges/--torsion), "
                        "or prove with the complete solver that the regions admit none (docs/quality.md)")  # fmt: skip


def add_best_arguments(p) -> None:
    """``--best N`` and how solutions are ranked and told apart."""
    g = p.add_argument_group("the best of many (solve --best N)")
    g.add_argument("--best", type=types.positive_int, default=None, metavar="N",
                   help="collect up to N distinct verified solutions and rank them (local solver from many starts; "
                        "the complete solver's solution set with --method complete)")  # fmt: skip
    g.add_argument("--rank", choices=("q1", "volume", "found"), default=None,
                   help="order of --best: q1 (Ferrari-Canny epsilon, default), volume, or found (the order found)")  # fmt: skip
    g.add_argument("--starts", type=int, default=None, metavar="S", help="--best: random starts of the local solver (default 100)")
    g.add_argument("--distinct-deg", type=types.finite, default=None, metavar="DEG",
                   help="--best: solutions are distinct when some joint angle, or the object's orientation, differs by this much (default 5)")  # fmt: skip
    g.add_argument("--distinct-mm", type=types.finite, default=None, metavar="MM",
                   help="--best: ... or the object's position by this much (default 5)")  # fmt: skip
    g.add_argument("--ascent-steps", type=int, default=None, metavar="K",
                   help="--best: steps of the quality ascent that moves each grasp along its solution set to a "
                        "higher epsilon, every step re-verified (default 20; 0: the grasps as found; docs/quality.md)")  # fmt: skip
    types.add_option_rule(p, _needs_best)


_BEST_DEFAULTS = {"rank": "q1", "starts": 100, "distinct_deg": 5.0, "distinct_mm": 5.0, "ascent_steps": 20}


def _needs_best(args) -> str | None:
    """``--rank``, ``--starts``, ``--distinct-*``, ``--ascent-steps`` only tell ``--best`` how to work
    (``--hold`` implies ``--best 5``)."""
    if args.best is not None or getattr(args, "hold", False):
        return None
    given = [f"--{k.replace('_', '-')}" for k in _BEST_DEFAULTS if getattr(args, k) is not None]
    if given:
        return f"{given[0]} needs --best N (it says how --best collects and ranks its solutions); add --best N or drop {given[0]}"
    return None


def _closure_seconds(text: str) -> float:
    """``--hold-closure-time``: seconds >= 0 (0: no force-closure search)."""
    return types.seconds(text, zero="not asked")


def add_hold_closure_argument(p) -> None:
    """``--hold-closure-time`` (``solve`` and ``batch``): the budget of ``--hold``'s force-closure search."""
    p.add_argument("--hold-closure-time", type=_closure_seconds, default=None, metavar="SECONDS",
                   help="--hold, when no candidate holds: look for a force-closure grasp (the physics test's friction "
                        "and torsion) -- over the object regions alone, from starts aimed at their force-closure points, "
                        "then with the complete solver -- or prove that the regions admit none, for at most this long "
                        "(default 30 s: prehension.hold.CLOSURE_TIME_S; 0: not asked)")  # fmt: skip


def add_batch_arguments(p) -> None:
    """``batch``: the same quality and ``--best`` options, ``--simulate`` and ``--hold``."""
    add_quality_arguments(p)
    add_best_arguments(p)
    physics = p.add_mutually_exclusive_group()
    physics.add_argument("--simulate", action="store_true",
                         help='run the physics test (prehension simulate) on every solution, on the cluster; each '
                              'record gets "physics" (needs: pip install "prehension[sim]")')  # fmt: skip
    physics.add_argument("--hold", action="store_true",
                         help=f"physics in the loop, as solve --hold: each task keeps the first candidate of --best N "
                              f"(--best {HOLD_CANDIDATES} unless given) that holds in the physics test, its verdict "
                              f"stored; each record gets \"held\" (needs: pip install \"prehension[sim]\")")  # fmt: skip
    add_hold_closure_argument(p)


def hold_closure_time(args) -> float | None:
    """``--hold-closure-time`` (``None``: the default), refused without ``--hold``."""
    if args.hold_closure_time is not None and not args.hold:
        raise PrehensionError("--hold-closure-time is the budget of --hold's force-closure search: give --hold too, or drop it")
    return args.hold_closure_time


def batch_extras(args) -> dict:
    """``best``, ``quality``, ``simulate`` and ``hold`` of :class:`~prehension.batch.BatchOptions`;
    checks that MuJoCo is installed before a cluster starts when ``--simulate`` or ``--hold``
    asks for it (``--hold`` without ``--best``: ``--best 5``, as ``solve --hold``)."""
    physics = None
    if args.simulate or args.hold:
        from ..sim import SimOptions, require_mujoco

        require_mujoco()
        physics = SimOptions()
    implied = args.hold and args.best is None
    if implied:
        args.best = HOLD_CANDIDATES
    try:
        best = best_options(args, None)
    except PrehensionError as exc:
        raise PrehensionError(f"--hold runs the candidates of --best {HOLD_CANDIDATES}: {exc}" if implied else str(exc)) from None
    hold = physics if args.hold else None
    return {"best": best, "quality": quality_options(args), "simulate": None if args.hold else physics, "hold": hold,
            "hold_closure_time_s": hold_closure_time(args)}  # fmt: skip


def quality_options(args):
    """The :class:`~prehension.quality.QualityOptions` the arguments ask for."""
    from ..quality import QualityOptions

    given = {"friction": args.friction, "cone_edges": args.cone_edges, "torsion_mm": args.torsion}
    try:
        return QualityOptions(**{k: v for k, v in given.items() if v is not None})
    except PrehensionError as exc:
        raise PrehensionError(str(exc).replace("quality options: ", "").replace("friction", "--friction")
                              .replace("cone_edges", "--cone-edges").replace("torsion_mm", "--torsion")) from None  # fmt: skip


def best_options(args, time_limit_s):
    """The :class:`~prehension.best.BestOptions` of ``--best`` (``None`` without it)."""
    from ..ascent import AscentOptions
    from ..best import BestOptions

    if args.best is None:
        return None
    rank, starts, distinct_deg, distinct_mm, ascent_steps = (v if getattr(args, k) is None else getattr(args, k) for k, v in _BEST_DEFAULTS.items())
    for flag, given in (("--all", getattr(args, "all", False)), ("--checkpoint", getattr(args, "checkpoint", None)),
                        ("--approximate", getattr(args, "approximate", False)), ("--require", getattr(args, "require", None))):  # fmt: skip
        if given:
            raise PrehensionError(f"--best collects its own set of strictly verified solutions; it cannot be combined with {flag}")
    if starts < 0:
        raise PrehensionError(f"--starts must be an integer >= 0, got {starts}")
    if ascent_steps < 0:
        raise PrehensionError(f"--ascent-steps must be an integer >= 0 (0: no ascent), got {ascent_steps}")
    for flag, value in (("--distinct-deg", distinct_deg), ("--distinct-mm", distinct_mm)):
        if not value > 0:
            raise PrehensionError(f"{flag} must be a positive number, got {value}")
    return BestOptions(
        n=args.best, rank=rank, starts=starts, joint_deg=distinct_deg, position_mm=distinct_mm,
        rotation_deg=distinct_deg, quality=quality_options(args), time_limit_s=time_limit_s,
        ascent=AscentOptions(steps=ascent_steps) if ascent_steps else None,
    )  # fmt: skip


def quality_lines(result, options) -> list[str]:
    """One line per solution (at most 10): its grasp quality."""
    from ..quality import grasp_quality

    lines = []
    for i, solution in enumerate(result.solutions[:10]):
        try:
            lines.append(f"quality of solution {i}: {grasp_quality(result.task, solution, options).describe()}")
        except PrehensionError as exc:
            lines.append(f"quality of solution {i}: unavailable ({exc})")
    return lines


def best_table(result) -> Table:
    """The ranked solutions of ``solve --best``: epsilon, closure, where each came from."""
    best = result.stats["best"]
    table = Table(title=f"Best {len(result.solutions)} of {best['candidates']} found ({best['distinct']} distinct), "
                        f"ranked by {best['rank']}", title_justify="left")  # fmt: skip
    for col in ("#", "force closure", "epsilon", "as found", "ascent steps", "found by"):
        table.add_column(col)
    ascents = best.get("ascent") or [None] * len(best["sources"])
    for i, (closed, eps, source, up) in enumerate(zip(best["force_closure"], best["epsilon"], best["sources"], ascents)):
        before, steps = ("-", "-") if up is None else (f"{up['epsilon_before']:.4g}", f"{up['accepted']} of {up['tried']}")
        table.add_row(str(i), "yes" if closed else "no", f"{eps:.4g}", before, steps, source)
    return table
