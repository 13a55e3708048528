"""``prehension simulate RESULT``: does the grasp hold in a physics engine?

Every solution of the result file (or the one ``--solution`` names) is first re-derived
as ``prehension check`` would (:func:`prehension.verification.claims.verify_result_file`): a file whose
claims do not hold is refused, never simulated.  Then the DexGraspBench protocol runs
(:mod:`prehension.sim`).  Exit code: 0 when every simulated grasp holds, 7 when one drops
or is rejected (too much penetration at the start), 2 on bad input -- including a
missing ``sim`` extra (the message says what to install).  Interrupted (Ctrl-C, SIGTERM
or SIGHUP), it writes (atomically) and prints the grasps it has finished, marked
``"interrupted": true``, and exits with 4.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..atomic import check_output_path, write_json_atomic
from ..errors import InvalidTask, PrehensionError, not_a_file
from . import args as types
from .codes import EXIT_DROPPED, EXIT_GAVE_UP, EXIT_OK

__all__ = ["add_parser", "cmd_simulate", "EXIT_DROPPED", "PHYSICS_TAG"]

PHYSICS_TAG = "physics/1"


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="push the grasped object in MuJoCo along six directions: does the grasp hold? "
                                        '(needs: pip install "prehension[sim]")')  # fmt: skip
    p.add_argument("result", type=Path, help="result file (.json) written by 'prehension solve'")
    p.add_argument("--solution", type=int, default=None, metavar="K", help="simulate only solution K (from 0; default: every one)")
    p.add_argument("-o", "--output", type=Path, help="write the outcome as JSON here")
    p.add_argument("--seed", type=types.seed, default=0, help="seed of --jitter (default 0)")
    p.add_argument("--jitter-mm", type=types.finite, default=0.0, metavar="MM",
                   help="start the object this far from its solved pose, in a seeded random direction (default 0)")  # fmt: skip
    p.add_argument("--jitter-deg", type=types.finite, default=0.0, metavar="DEG",
                   help="and turned by this angle about a seeded random axis (default 0)")  # fmt: skip
    p.add_argument("--squeeze", type=types.finite, default=None, metavar="MM", help="how far each contact is aimed into the object (default 10)")
    p.add_argument("--squeeze-kind", choices=("balanced", "uniform"), default=None,
                   help="balanced (default): each contact squeezed in proportion to its force in a set of contact forces "
                        "with zero net wrench; uniform: every contact --squeeze mm (DexGraspBench's)")  # fmt: skip
    p.add_argument("--mass", type=types.finite, default=None, metavar="KG", help="object mass (default 0.1)")
    p.add_argument("--friction", type=types.finite, default=None, metavar="MU", help="sliding friction (default 0.6)")
    p.add_argument("--from-pregrasp", action="store_true",
                   help="start from the solution's pre-grasp (fingers backed off along the contact normals) and close "
                        "the hand onto the object first: reports whether the grasp is reached (docs/quality.md)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the outcome as JSON on stdout")


class StoredGrasp(NamedTuple):
    """A solution of a result file, as the physics test needs it (re-derived by check)."""

    q: np.ndarray
    T_palm_object: np.ndarray
    contacts: tuple
    pregrasp_q: np.ndarray | None = None  # the stored pre-grasp's angles (None: the file has none)


def stored_grasps(path: Path, index: int | None):
    """``(task, [(k, StoredGrasp)])`` of a result file whose claims hold."""
    from ..verification.claims import verify_result_file

    if not path.is_file():
        raise InvalidTask(not_a_file("result file", path))
    checked = verify_result_file(path, reprove=False, physics=False)  # the physics test runs next anyway
    if not checked.holds:
        failures = "; ".join(f"{f.what}: {f.detail}" for f in checked.failures[:3])
        raise PrehensionError(f"{path} does not hold (see 'prehension check {path}'): {failures}")
    from ..atomic import read_json

    solutions = read_json(path, "result file").get("solutions") or []
    if not solutions:
        raise PrehensionError(f"{path} holds no solution to simulate (status {checked.status})")
    if index is not None and not 0 <= index < len(solutions):
        raise PrehensionError(f"--solution {index} is out of range: the result holds {len(solutions)} solution(s), numbered 0 to {len(solutions) - 1}")
    picked = range(len(solutions)) if index is None else [index]
    grasps = []
    for k in picked:
        names = checked.task.hand.dof_names
        q = np.array([float(solutions[k]["joint_angles_rad"][d]) for d in names])
        pre = solutions[k].get("pregrasp")  # re-derived by the check above when present
        q_pre = None if pre is None else np.array([float(pre["joint_angles_rad"][d]) for d in names])
        grasps.append((k, StoredGrasp(q, np.array(solutions[k]["T_palm_object"], float), checked.reports[k].contacts, q_pre)))
    return checked.task, grasps


_FLAGS = {"squeeze_mm": "--squeeze", "mass_kg": "--mass", "friction": "--friction", "jitter_mm": "--jitter-mm",
          "jitter_deg": "--jitter-deg"}  # fmt: skip


def sim_options(args):
    """The :class:`~prehension.sim.SimOptions` the arguments ask for; errors name the flag."""
    from ..sim import SimOptions

    given = {"squeeze_mm": args.squeeze, "squeeze": getattr(args, "squeeze_kind", None), "mass_kg": args.mass, "friction": args.friction,
             "jitter_mm": args.jitter_mm, "jitter_deg": args.jitter_deg}  # fmt: skip
    try:
        return SimOptions(**{k: v for k, v in given.items() if v is not None})
    except PrehensionError as exc:
        text = str(exc).replace("simulation options: ", "")
        for name, flag in _FLAGS.items():
            text = text.replace(name, flag)
        raise PrehensionError(text) from None


def cmd_simulate(args, console: Console) -> int:
    from ..sim import require_mujoco, simulate_grasp

    require_mujoco()  # before any work: say what to install (main() prints the message as text)
    options = sim_options(args)
    out = check_output_path(args.output, "output", inputs=[args.result], suffixes=(".json",)) if args.output else None
    task, grasps = stored_grasps(args.result, args.solution)
    reports = []
    try:
        for k, g in grasps:  # SIGTERM and SIGHUP arrive as KeyboardInterrupt too (cli.terminate)
            start = _start_angles(args, task, g)
            extra = () if start is None else (start,)
            reports.append((k, simulate_grasp(task, g, options, args.seed, *extra)))
    except KeyboardInterrupt:
        _report(args, console, out, task, reports, interrupted=True)
        Console(stderr=True, highlight=False).print(
            f"interrupted after {len(reports)} of {len(grasps)} grasp(s); "
            + (f"the finished ones are in {out}" if out is not None else "the finished ones are printed above"),
            soft_wrap=True)  # fmt: skip
        return EXIT_GAVE_UP
    _report(args, console, out, task, reports, interrupted=False)
    return EXIT_OK if all(r.success for _, r in reports) else EXIT_DROPPED


def _start_angles(args, task, grasp):
    """``--from-pregrasp``: the stored pre-grasp's angles (computed as ``solve`` would for
    a file written before pre-grasps were stored); otherwise ``None``."""
    if not getattr(args, "from_pregrasp", False):
        return None
    if grasp.pregrasp_q is not None:
        return grasp.pregrasp_q
    from ..pregrasp import pregrasp

    return pregrasp(task, grasp).q


def _report(args, console: Console, out, task, reports, interrupted: bool) -> None:
    """Write (atomically) and print the outcome of the grasps in ``reports``."""
    data = {"prehension": PHYSICS_TAG, "result": str(args.result), "task": task.name, "interrupted": interrupted,
            "grasps": [dict(solution=k, **r.to_dict()) for k, r in reports]}  # fmt: skip
    if out is not None:
        write_json_atomic(out, data)
    if args.json:
        import json

        print(json.dumps(data, indent=1, allow_nan=False))
        return
    for k, report in reports:
        console.print(_table(k, report))
    if out is not None:
        console.print(f"outcome written to {out}")


def _table(k: int, report) -> Table:
    style = "bold green" if report.success else "bold red"
    table = Table(title=f"Solution {k}: [{style}]{escape(report.describe())}[/]", title_justify="left")
    for col in ("push", "held", "moved [mm]", "turned [deg]", "initial penetration [mm]"):
        table.add_column(col)
    for p in report.pushes:
        table.add_row(p.direction, "yes" if p.held else "[bold red]no[/]", f"{p.shift_mm:.1f}", f"{p.turn_deg:.1f}",
                      f"{p.initial_penetration_mm:.2f}")  # fmt: skip
    o = report.options
    table.caption = (f"object {o.mass_kg:g} kg, friction {o.friction:g}, pushed with {o.push_accel * o.mass_kg:g} N for "
                     f"{o.hold_s:g} s after a {o.squeeze_mm:g} mm {o.squeeze} squeeze; held: moved < {o.max_shift_mm:g} mm and "
                     f"turned < {o.max_turn_deg:g} deg\n{_start(report)}")  # fmt: skip
    return table


def _start(report) -> str:
    """The initial penetration, split into the hand's own and the object's approximation."""
    hand = "no mesh to measure" if report.hand_penetration_mm is None else f"{report.hand_penetration_mm:.2f} mm"
    return (f"start: {report.initial_penetration_mm:.2f} mm of penetration in MuJoCo; the hand's own into the solver's "
            f"mesh: {hand}; the object's convex approximation ({report.object_pieces} pieces) off the mesh next to "
            f"the hand: {report.approximation_mm:.2f} mm")
