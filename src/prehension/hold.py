"""Physics in the loop (``solve --hold``): the first candidate grasp that holds.

:func:`hold_first` runs the candidates of a result (the ranked solutions of
:func:`~prehension.best.solve_best`), best first, through the physics test
(:func:`~prehension.sim.simulate_grasp`, the ``"push"`` squeeze by default) until one holds
against all six pushes, or the candidates run out (each tried candidate's push margin,
:func:`~prehension.sim.push.push_margin`, is recorded beside its verdict; it does not
reorder them: docs/quality.md, "Physics in the loop"):

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

**When no candidate holds**, force closure is looked for within ``closure_time_s``
seconds (:data:`CLOSURE_TIME_S` by default; 0: not looked for), with the physics test's
own contact model (friction ``SimOptions.friction``, soft fingers of torsion
``SimOptions.torsion_mm``), in three steps:

1. **without the hand** (:func:`prehension.region_closure.regions_closure`, at most
   :data:`REGIONS_SHARE` of the time): a branch-and-prune over the object regions'
   parameters alone.  When it proves that no choice of one point in each object region is
   force closure, no grasp of the task is, and the complete solver is not asked: the
   proof is stored (``stats["hold"]["closure"]``, status ``"infeasible"``, ``"method":
   "regions"``) and ``prehension check`` re-derives it (a few seconds at most);
2. otherwise the local iterations start from random hand configurations **aimed** at
   force-closure points of the regions (:func:`prehension.region_closure.aimed_grasps`,
   a few seconds); the force-closure grasps they reach (at most eight, each moved up by
   the quality ascent) are further candidates, tried in the physics test like the
   others (``stats["hold"]["closure"]``: status ``"solved"``, ``"method": "aimed"``), and
   the complete solver is not asked.  While none holds and the budget lasts (its wall
   clock from the start of step 1, the physics tests of these grasps included), further
   rounds of starts (seeds ``seed + 1``, ``seed + 2``, ...; plain random ones over the
   whole regions, no points sampled) add the force-closure grasps they reach
   that are distinct from every candidate so far, tried the same way (``"rounds"``,
   ``"grasps"``: how many rounds, how many grasps in all);
3. when they reach none, the **complete solver** is asked, for the time left, for a
   force-closure grasp of the same task (``require="force-closure"``,
   :mod:`prehension.solvers.complete.closure`):

* it finds one: that grasp (moved up by the quality ascent) is a further candidate,
  tried in the physics test like the others (its source says where it came from);
* it proves that none exists: the answer says "no grasp in these regions is force
  closure" with the proof, and ``stats["hold"]["closure"]`` stores it (status
  ``"infeasible"``, the search's options and counts), which ``prehension check``
  re-proves.  Without force closure some wrench is resisted by no contact forces; the
  six pushes of the test are pure forces, so such a grasp can still pass them (the
  candidates were all tried first);
* its time runs out: the answer says so (``"gave_up"``): nothing proven;
  ``stats["hold"]["closure"]["regions"]`` says what step 1 found (a force-closure choice
  of points in the regions -- ``"witness"`` -- or nothing in its time);
* it cannot take the task (a :class:`~prehension.errors.PrehensionError`, e.g. a region
  it does not handle): ``"unavailable"`` with the reason; the candidates' verdicts stand.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

from .ascent import improve_grasp
from .best import distinct
from .errors import PrehensionError
from .quality import QualityOptions, grasp_quality
from .region_closure import AIMED_STARTS, aimed_grasps, regions_closure
from .results import SolveResult, Status
from .sim.push import push_margin, squeeze_for
from .solve import SolveOptions, solve

__all__ = ["HoldOutcome", "hold_first", "margin_of", "CLOSURE_TIME_S", "REGIONS_SHARE", "closure_model"]

COMPLETE_SOURCE = "complete solver (force closure required, --hold)"
AIMED_SOURCE = "local iterations aimed at force-closure points of the regions (--hold)"
CLOSURE_TIME_S = 30.0  # the force-closure search's budget [s] when no candidate holds (module docstring)
REGIONS_SHARE = 1.0 / 3.0  # of it, what the search without the hand may take at most (step 1)

_PER_SOLUTION = ("sources", "epsilon", "force_closure", "ascent")  # solve_best's stats, one entry per solution


@dataclass(frozen=True, eq=False)
class HoldOutcome:
    """What :func:`hold_first` answers.

    Attributes:
        result: the result with the returned solutions (see the module docstring).
        held: some candidate held against all six pushes.
        physics: per returned solution, its :class:`~prehension.sim.PhysicsReport` as a
            dict (``None``: not judged, interrupted before any verdict).
        closure: what the complete solver answered when no candidate was force closure
            (``stats["hold"]["closure"]``: ``"status"`` ``"solved"``, ``"infeasible"`` --
            proven: no grasp in the regions is force closure -- or ``"gave_up"``), or
            ``None`` when it was not asked.
    """

    result: SolveResult
    held: bool
    physics: tuple[dict, ...]
    closure: dict | None = None

    @property
    def proven_none(self) -> bool:
        """No candidate held and the complete solver proved that no grasp in the task's regions is force closure."""
        return not self.held and (self.closure or {}).get("status") == Status.INFEASIBLE


def _why(report) -> str:
    if report.rejected:
        return report.describe()
    dropped = [p.describe() for p in report.pushes if not p.held]
    return "held in all six pushes" if not dropped else "dropped " + ", ".join(dropped)


def closure_model(options):
    """The :class:`~prehension.quality.QualityOptions` of the physics test's contacts
    (``options``: a :class:`~prehension.sim.SimOptions`): its friction, soft fingers of its
    torsional friction; what "force closure" means for ``--hold``."""
    return QualityOptions(friction=options.friction, torsion_mm=options.torsion_mm)


def margin_of(task, solution, options) -> float | None:
    """The candidate's push margin (:func:`~prehension.sim.push.push_margin` with the test's
    ``options``, 4 decimals), recorded beside its verdict; ``None`` when it cannot be computed."""
    return _margin_and_squeeze(task, solution, options)[0]


def _margin_and_squeeze(task, solution, options) -> tuple[float | None, object]:
    """``(margin_of's margin, the squeeze's targets)``: the squeeze is computed once, for the
    margin and the physics test both; ``(None, None)`` when it cannot be (the test then
    computes it, and says why it cannot)."""
    try:
        q_squeeze = squeeze_for(task, solution.q, solution.T_palm_object, solution.contacts, options)[0]
        return round(push_margin(task, solution, options, q_squeeze).margin, 4), q_squeeze
    except PrehensionError:  # e.g. an object with no size to take torques about: the test itself says why
        return None, None


def _trials(task, solutions, first: int, options, seed: int, progress, total: int) -> tuple[list, list, bool]:
    """The physics test of ``solutions`` (ranks from ``first``), in rank order, until one
    holds: ``(reports [(rank, report)], tried [dict], interrupted)``."""
    from .sim import simulate_grasp

    reports, tried = [], []
    try:
        for rank, solution in enumerate(solutions, start=first):
            margin, q_squeeze = _margin_and_squeeze(task, solution, options)
            if progress is not None:
                progress(f"physics test of candidate {rank + 1} of {total} (push margin {margin})")
            report = simulate_grasp(task, solution, options, seed, q_squeeze=q_squeeze)
            reports.append((rank, report))
            tried.append({"candidate": rank, "success": report.success, "rejected": report.rejected,
                          "pushes_held": report.held, "push_margin": margin, "why": _why(report)})  # fmt: skip
            if report.success:
                break
    except KeyboardInterrupt:  # SIGTERM and SIGHUP arrive as KeyboardInterrupt too (cli.terminate)
        return reports, tried, True
    return reports, tried, False


def _closure_search(result: SolveResult, options, seed: int, time_s: float, progress) -> tuple[dict, list, object]:
    """Force closure looked for within ``time_s`` (the physics test's contact model): first
    without the hand, then by the aimed starts, then by the complete solver (module
    docstring): ``(record for stats["hold"]["closure"], [(further grasp, source)], the
    regions' force-closure witness or None)``."""
    quality, started = closure_model(options), time.perf_counter()
    if progress is not None:
        progress(f"no candidate holds: can any points of the object regions be force closure? (at most {REGIONS_SHARE * time_s:g} s)")
    regions = regions_closure(result.task, quality, REGIONS_SHARE * time_s)
    if regions.status == Status.INFEASIBLE:
        return {"status": str(Status.INFEASIBLE), "method": "regions", "message": regions.message,
                "seconds": round(regions.seconds, 3), "time_limit_s": time_s, "quality": quality.to_dict(),
                "boxes": regions.boxes, "closure_pruned": regions.pruned}, [], None  # fmt: skip
    if progress is not None:
        progress("no candidate holds: local iterations aimed at force-closure points of the regions")
    aimed = aimed_grasps(result.task, quality, seed, regions.witness)
    spent = time.perf_counter() - started
    if aimed:
        return {"status": str(Status.SOLVED), "method": "aimed", "message": f"{len(aimed)} force-closure grasp(s) from "
                "starts aimed at force-closure points of the regions", "seconds": round(spent, 3), "time_limit_s": time_s,
                "quality": quality.to_dict(), "regions": regions.to_dict(), "rounds": 1, "grasps": len(aimed)}, [(s, AIMED_SOURCE) for s in aimed], regions.witness  # fmt: skip
    left = max(time_s - spent, 1e-3)
    if progress is not None:
        progress(f"no candidate holds: the complete solver looks for a force-closure grasp (at most {left:.3g} s)")
    found = solve(result.task, SolveOptions(method="complete", require="force-closure", quality=quality,
                                            time_limit_s=left, seed=seed))  # fmt: skip
    record = {"status": str(found.status), "message": found.message, "seconds": round(spent + found.seconds, 3),
              "time_limit_s": time_s, "quality": quality.to_dict(),
              **{k: found.stats.get(k) for k in ("boxes", "lps", "closure_pruned")}, "options": found.stats.get("options"),
              "regions": regions.to_dict()}  # fmt: skip
    if not found.solutions:
        return record, [], None
    return record, [(improve_grasp(result.task, found.solutions[0], quality).solution, COMPLETE_SOURCE)], None


def hold_first(result: SolveResult, options=None, seed: int = 0, progress=None,
               closure_time_s: float | None = None) -> HoldOutcome:  # fmt: skip
    """The first of ``result.solutions`` that holds in the physics test (module docstring).

    Args:
        result: a result whose solutions are the ranked candidates.
        options: :class:`~prehension.sim.SimOptions` (default: the protocol's).
        seed: seed of the physics test's jitter (and of the complete solver).
        progress: called with a one-line string before each candidate, or ``None``.
        closure_time_s: the force-closure search's budget [s] when no candidate holds
            (``None``: :data:`CLOSURE_TIME_S`; 0: no search).
    """
    from .sim import SimOptions

    options = options or SimOptions()
    closure_time_s = CLOSURE_TIME_S if closure_time_s is None else closure_time_s
    solutions = tuple(result.solutions)
    ranked = len(solutions)  # solve --best's; more when the force-closure search finds force-closure grasps
    reports, tried, interrupted = _trials(result.task, solutions, 0, options, seed, progress, len(solutions))
    closure = None
    if not interrupted and not any(r.success for _, r in reports) and closure_time_s > 0:
        started, witness = time.perf_counter(), None
        try:
            closure, extra, witness = _closure_search(result, options, seed, closure_time_s, progress)
        except KeyboardInterrupt:
            closure, extra, interrupted = None, [], True
        except PrehensionError as exc:  # a task the complete solver does not take: the candidates' verdicts stand
            closure, extra = {"status": "unavailable", "message": str(exc), "time_limit_s": closure_time_s}, []
        state = _Trying(result, solutions, reports, tried, interrupted)
        state.add(extra, options, seed, progress)
        if (closure or {}).get("method") == "aimed":
            _more_rounds(state, closure, witness, options, seed, started + closure_time_s, progress)
        result, solutions, reports, tried, interrupted = state.result, state.solutions, state.reports, state.tried, state.interrupted
    return _outcome(replace(result, solutions=solutions), options, reports, tried, interrupted, closure, ranked)


@dataclass
class _Trying:
    """The candidates so far and their verdicts, while the force-closure search adds more."""

    result: SolveResult
    solutions: tuple
    reports: list
    tried: list
    interrupted: bool

    @property
    def held(self) -> bool:
        return any(r.success for _, r in self.reports)

    def add(self, extra: list, options, seed: int, progress) -> None:
        """Further grasps ``[(solution, source)]``: appended and tried in order until one holds."""
        if not extra or self.interrupted or self.held:
            return
        first, self.solutions = len(self.solutions), self.solutions + tuple(s for s, _ in extra)
        self.result = replace(self.result, stats=_with_extra(self.result, extra))
        more, more_tried, self.interrupted = _trials(self.result.task, self.solutions[first:], first, options, seed, progress,
                                                     len(self.solutions))  # fmt: skip
        self.reports, self.tried = self.reports + more, self.tried + more_tried


def _more_rounds(state: _Trying, closure: dict, witness, options, seed: int, deadline: float, progress) -> None:
    """Further rounds of plain random starts over the whole regions (seeds ``seed + 1``,
    ``seed + 2``, ...; the first round showed the regions to have force-closure points) while no
    candidate holds and the search's budget lasts (``deadline``: its wall clock, the physics
    tests of its grasps included); each round's force-closure grasps that are distinct from
    every candidate so far are tried.  ``closure["rounds"]`` and its message say how many."""
    quality, task = closure_model(options), state.result.task
    try:
        while not state.held and not state.interrupted and time.perf_counter() < deadline:
            if progress is not None:
                progress(f"no candidate holds: random starts, round {closure['rounds'] + 1}")
            found = aimed_grasps(task, quality, seed + closure["rounds"], witness, aim=False)
            closure["rounds"] += 1
            new = [s for s in found if all(distinct(s, other, task) for other in state.solutions)]
            closure["grasps"] += len(new)
            state.add([(s, AIMED_SOURCE) for s in new], options, seed, progress)
    except KeyboardInterrupt:
        state.interrupted = True
    closure["message"] = (f"{closure['grasps']} force-closure grasp(s) from {closure['rounds']} round(s) of {AIMED_STARTS} "
                          "starts (the first aimed at force-closure points of the regions, the others random)")  # fmt: skip


def _with_extra(result: SolveResult, extra: list) -> dict:
    """``result.stats`` with ``solve --best``'s per-solution lists extended by the further
    grasps ``extra [(solution, source)]`` (their source, and their quality with the
    ranking's friction model)."""
    stats = dict(result.stats)
    best = stats.get("best")
    if not isinstance(best, dict):
        return stats
    model = QualityOptions.from_dict(best.get("quality_options") or {})
    more = {"sources": [], "epsilon": [], "force_closure": [], "ascent": []}
    for solution, source in extra:
        q = grasp_quality(result.task, solution, model)
        for key, value in (("sources", source), ("epsilon", q.epsilon), ("force_closure", q.force_closure), ("ascent", None)):
            more[key].append(value)
    stats["best"] = {k: list(v) + more[k] if k in _PER_SOLUTION and v is not None else v for k, v in best.items()}
    return stats


def _outcome(result: SolveResult, options, reports, tried, interrupted: bool, closure, ranked: int) -> HoldOutcome:
    """The answer (module docstring) of the candidates ``result.solutions`` (the first
    ``ranked`` of them ``solve --best``'s, any later one the complete solver's) and their verdicts."""
    held = bool(reports) and reports[-1][1].success
    n = len(result.solutions)
    if held:
        keep = [reports[-1]]
        message = (f"{result.message}; candidate {keep[0][0] + 1} of {n} holds in the physics "
                   f"test (all six pushes, {options.squeeze} squeeze)")  # fmt: skip
    else:
        keep = sorted(reports, key=lambda r: (-r[1].held, r[0]))
        why = "interrupted" if interrupted else "no candidate holds"
        message = (f"{result.message}; but {why} in the physics test ({len(reports)} of {n} "
                   f"tried; the best held {keep[0][1].held if keep else 0} of 6 pushes)")  # fmt: skip
    message += _closure_note(closure, held, ranked < n)
    stats = dict(result.stats)
    stats["hold"] = {"held": held, "interrupted": interrupted, "candidates": n, "tried": tried,
                     "kept": [rank for rank, _ in keep], "squeeze": options.squeeze}  # fmt: skip
    if closure is not None:
        stats["hold"]["closure"] = closure
    ranks = [rank for rank, _ in keep] if reports else list(range(n))  # none judged: all, as ranked
    if isinstance(stats.get("best"), dict):  # solve --best's per-solution lists follow the solutions kept
        stats["best"] = {k: [v[r] for r in ranks] if k in _PER_SOLUTION and v is not None else v for k, v in stats["best"].items()}
    out = replace(result, solutions=tuple(result.solutions[r] for r in ranks), stats=stats, message=message)
    physics = tuple(r.to_dict() for _, r in keep) if reports else (None,) * len(ranks)
    return HoldOutcome(out, held, physics, closure)


def _closure_note(closure: dict | None, held: bool, found: bool) -> str:
    """What the message adds about the complete solver's search (module docstring)."""
    if closure is None:
        return ""
    if closure["status"] == Status.INFEASIBLE and closure.get("method") == "regions":
        return ("; no grasp in these regions is force closure (proven without the hand: no choice of one point in each "
                f"object region is, with the physics test's contact model; {closure['message']})")  # fmt: skip
    if closure["status"] == Status.INFEASIBLE:
        return ("; no grasp in these regions is force closure (proven by the complete solver with the physics "
                f"test's contact model: {closure['message']})")  # fmt: skip
    if closure["status"] == "unavailable":
        return f"; the complete solver could not look for a force-closure grasp: {closure['message']}"
    if found and closure.get("method") == "aimed":
        return ("; local iterations aimed at force-closure points of the regions found force-closure grasps"
                + (" and one holds" if held else ": they drop too"))  # fmt: skip
    if found:
        return "; the complete solver found a force-closure grasp" + (" and it holds" if held else ": it drops too")
    points = " (some points of the object regions are force closure)" if (closure.get("regions") or {}).get("status") == "witness" else ""
    return f"; the complete solver found no force-closure grasp within {closure['time_limit_s']:g} s{points} (nothing proven)"
