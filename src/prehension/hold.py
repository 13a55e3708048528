"""Physics in the loop (``solve --hold``): the first candidate grasp that holds.

:func:`hold_first` runs the candidates of a result (the ranked solutions of
:func:`~prehension.best.solve_best`), best first, through the physics test
(:func:`~prehension.sim.simulate_grasp`, the balanced squeeze by default) until one holds
against all six pushes, or the candidates run out:

* one holds: the answer is that grasp alone (``held`` true), with its physics verdict;
* none holds: the answer keeps every candidate, ordered by how many pushes it held (then
  by rank), so the first is the best candidate, each with its verdict (why it dropped:
  rejected for its start, or which pushes moved or turned the object too far).  The
  status stays ``"solved"`` -- every constraint does hold -- but the message says that
  none holds and ``prehension solve`` exits with 7, as ``prehension simulate`` does.

``stats["hold"]`` records every candidate tried (its rank, pushes held, verdict), and
each returned solution's verdict is stored with it in the result file (``"physics"``),
which ``prehension check`` re-runs when MuJoCo is installed.  Interrupted (Ctrl-C,
SIGTERM, SIGHUP) the candidates tried so far are kept and ``stats["hold"]["interrupted"]``
says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from .results import SolveResult

__all__ = ["HoldOutcome", "hold_first"]

_PER_SOLUTION = ("sources", "epsilon", "force_closure", "ascent")  # solve_best's stats, one entry per solution


@dataclass(frozen=True, eq=False)
class HoldOutcome:
    """What :func:`hold_first` answers.

    Attributes:
        result: the result with the returned solutions (see the module docstring).
        held: some candidate held against all six pushes.
        physics: per returned solution, its :class:`~prehension.sim.PhysicsReport` as a
            dict (``None``: not judged, interrupted before any verdict).
    """

    result: SolveResult
    held: bool
    physics: tuple[dict, ...]


def _why(report) -> str:
    if report.rejected:
        return report.describe()
    dropped = [f"{p.direction} (moved {p.shift_mm:.0f} mm, turned {p.turn_deg:.0f} deg)" for p in report.pushes if not p.held]
    return "held in all six pushes" if not dropped else "dropped " + ", ".join(dropped)


def hold_first(result: SolveResult, options=None, seed: int = 0, progress=None) -> HoldOutcome:
    """The first of ``result.solutions`` that holds in the physics test (module docstring).

    Args:
        result: a result whose solutions are the ranked candidates.
        options: :class:`~prehension.sim.SimOptions` (default: the protocol's).
        seed: seed of the physics test's jitter.
        progress: called with a one-line string before each candidate, or ``None``.
    """
    from .sim import SimOptions, simulate_grasp

    options = options or SimOptions()
    tried, reports, interrupted = [], [], False
    try:
        for rank, solution in enumerate(result.solutions):
            if progress is not None:
                progress(f"physics test of candidate {rank + 1} of {len(result.solutions)}")
            report = simulate_grasp(result.task, solution, options, seed)
            reports.append((rank, report))
            tried.append({"candidate": rank, "success": report.success, "rejected": report.rejected,
                          "pushes_held": report.held, "why": _why(report)})  # fmt: skip
            if report.success:
                break
    except KeyboardInterrupt:  # SIGTERM and SIGHUP arrive as KeyboardInterrupt too (cli.terminate)
        interrupted = True
    held = bool(reports) and reports[-1][1].success
    if held:
        keep = [reports[-1]]
        message = (f"{result.message}; candidate {keep[0][0] + 1} of {len(result.solutions)} holds in the physics "
                   f"test (all six pushes, {options.squeeze} squeeze)")  # fmt: skip
    else:
        keep = sorted(reports, key=lambda r: (-r[1].held, r[0]))
        why = "interrupted" if interrupted else "no candidate holds"
        message = (f"{result.message}; but {why} in the physics test ({len(reports)} of {len(result.solutions)} "
                   f"tried; the best held {keep[0][1].held if keep else 0} of 6 pushes)")  # fmt: skip
    stats = dict(result.stats)
    stats["hold"] = {"held": held, "interrupted": interrupted, "candidates": len(result.solutions), "tried": tried,
                     "kept": [rank for rank, _ in keep], "squeeze": options.squeeze}  # fmt: skip
    ranks = [rank for rank, _ in keep] if reports else list(range(len(result.solutions)))  # none judged: all, as ranked
    solutions = tuple(result.solutions[rank] for rank in ranks)
    if isinstance(stats.get("best"), dict):  # solve --best's per-solution lists follow the solutions kept
        stats["best"] = {k: [v[r] for r in ranks] if k in _PER_SOLUTION and v is not None else v for k, v in stats["best"].items()}
    out = replace(result, solutions=solutions, stats=stats, message=message)
    physics = tuple(r.to_dict() for _, r in keep) if reports else (None,) * len(solutions)
    return HoldOutcome(out, held, physics)
