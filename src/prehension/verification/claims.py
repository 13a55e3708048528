"""Re-derive everything a result file claims (what ``prehension check`` runs).

A result file (:mod:`prehension.results`) makes claims; :func:`verify_result` re-derives
each of them from the task the file embeds, and reports one :class:`Finding` per claim:

* the header: a known ``status`` and ``method``, ``success`` equal to ``status == "solved"``,
  solutions present exactly when the status says so (``solved`` and ``approximate``: at
  least one; ``infeasible`` and ``gave_up``: none);
* per solution: the joint angles in radians and in degrees name every dof of the hand and
  agree; the configuration passes the residual function (:func:`~prehension.verification.residuals.evaluate`)
  with the **strict** default tolerances for a ``solved`` result (whatever the file says)
  and with the file's stated tolerances for an ``approximate`` one; every dof of a finger
  that does not take part is at the task's idle value unless the solution lists it under
  ``idle_moved``; every link pose equals forward kinematics; each contact's stored points,
  normals, distance and angle, and the ``worst`` summary, equal the recomputed ones; the
  grasp quality (force closure, epsilon, volume) equals the one recomputed from those
  contacts with the friction model the file states (:mod:`prehension.quality.stored`);
* the ``collision_geometry`` entry (which capsules, fits, exclusions and object solid
  judged collisions; :mod:`prehension.tasks.geometry_record`) equals the one derived from
  the embedded task (a file written before the entry existed is noted, not failed);
  the pre-grasp's angles judged again (backed-off distances; joint limits, couplings,
  self- and hand-object collision by the residual function) and the squeeze targets
  recomputed (:mod:`prehension.pregrasp`);
  a physics verdict (``"physics"``, written by ``solve --hold``) is re-run -- the same
  protocol, options and seed -- and must agree push by push on held or not, when MuJoCo
  is installed; without it the finding says the verdict was not re-run (and holds);
  ``solve --hold``'s proof that no grasp in the regions is force closure
  (``stats.hold.closure``, status ``infeasible``) is run again by the complete solver
  with the stored search options, as an ``infeasible`` status is -- or, a proof without
  the hand (``"method": "regions"``: no choice of points in the object regions is force
  closure, :mod:`prehension.region_closure`), derived again every time (seconds);
* ``infeasible``: the proof is run again by the complete solver on the embedded task (so
  it cannot have been computed for another task); without ``reprove`` the claim is only
  restated, never called verified.  A *span proof* (``method: "span"``, an assignment the
  hand's span rules out: :mod:`prehension.assignment.span`) is derived again from the
  embedded task every time (it takes milliseconds).

Stored values are compared with the recomputed ones to ``1e-9`` (mm, deg, and unitless for
rotations and normals): JSON keeps a float exactly, and recomputing uses the same code.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..atomic import read_json
from ..errors import InvalidTask, PrehensionError
from ..hands.kinematics import forward_kinematics
from ..results import SolveResult, Status, result_task
from ..tasks.geometry_record import check_collision_geometry
from ..tasks.model import Configuration, Task
from .residuals import ResidualReport, Tolerances, evaluate

__all__ = ["Finding", "Verification", "verify_result", "verify_result_file", "STORED_TOLERANCE"]

SPAN_REPROVED = "infeasibility re-proved by the hand's span"
STORED_TOLERANCE = 1e-9  # largest gap between a stored value and the recomputed one (mm, deg, unitless)
METHODS = ("local", "complete", "imported", "span")  # "imported": prehension import-grasps (docs/interop.md);
# "span": an assignment the hand's span rules out (prehension.assignment.span, docs/assignment.md)


@dataclass(frozen=True)
class Finding:
    """One claim of a result file and whether it holds."""

    what: str
    ok: bool
    detail: str = ""


@dataclass(frozen=True, eq=False)
class Verification:
    """Everything :func:`verify_result` re-derived.

    Attributes:
        task: the embedded task.
        status: the status the file claims.
        findings: one per claim checked.
        reports: per stored solution, the residual report (``None`` when malformed).
        reproof: for a claimed ``infeasible``: the complete solver's new answer
            (``None`` when not re-proved).
    """

    task: Task
    status: str
    findings: tuple[Finding, ...]
    reports: tuple[ResidualReport | None, ...] = ()
    reproof: SolveResult | None = None

    @property
    def holds(self) -> bool:
        """Every claim checked holds."""
        return all(f.ok for f in self.findings)

    @property
    def failures(self) -> tuple[Finding, ...]:
        return tuple(f for f in self.findings if not f.ok)

    @property
    def infeasibility_reproved(self) -> bool:
        """Re-proved by the complete solver, or a span proof derived again."""
        if self.reproof is not None and self.reproof.status == Status.INFEASIBLE:
            return True
        return any(f.ok and f.what == SPAN_REPROVED for f in self.findings)


def verify_result_file(path, *, reprove: bool = True, time_limit_s: float | None = 300.0, physics: bool = True) -> Verification:
    """:func:`verify_result` on a result file (``.json``)."""
    path = Path(path)
    return verify_result(read_json(path, "result file"), source=str(path), base_dir=path.parent,
                         reprove=reprove, time_limit_s=time_limit_s, physics=physics)  # fmt: skip


def verify_result(
    data: Any, *, source: str = "<result>", base_dir: Path | None = None, reprove: bool = True,
    time_limit_s: float | None = 300.0, physics: bool = True,
) -> Verification:  # fmt: skip
    """Re-derive every claim of a result dict (see the module docstring).

    Args:
        data: the parsed result file.
        source: where it was read from (for messages).
        base_dir: folder that relative paths of the embedded task are relative to.
        reprove: re-run the proof of a claimed ``infeasible``.
        time_limit_s: limit of that proof (``None``: none).
        physics: re-run stored physics verdicts (``False``: say they were not re-run).

    Raises:
        InvalidTask: not a result file, or its embedded task cannot be read: nothing can
            be checked then.
    """
    task = _embedded_task(data, source, base_dir)
    findings = _header(data) + _geometry(task, data)
    status = data.get("status")
    tol = _tolerances_claimed(data, status, findings)
    reports = []
    solutions = data.get("solutions") if isinstance(data.get("solutions"), list) else []
    for i, sol in enumerate(solutions):
        report, found = _solution(task, sol, i, tol)
        reports.append(report)
        findings += found
        if isinstance(sol, dict) and "physics" in sol and report is not None:
            findings += _physics(task, sol, report, f"solution {i}", physics)
    findings += _requirement(task, data, reports) + _hold_closure(task, data, reprove, time_limit_s)
    reproof = None
    if status == Status.INFEASIBLE and not solutions:
        reproof, found = _reprove(task, data, reprove, time_limit_s)
        findings += found
    return Verification(task, str(status), tuple(findings), tuple(reports), reproof)


# -- header ---------------------------------------------------------------------------------
def _embedded_task(data, source: str, base_dir) -> Task:
    return result_task(data, source, Path(base_dir or "."))[0]


def _header(data: dict) -> list[Finding]:
    status, method = data.get("status"), data.get("method")
    solutions = data.get("solutions")
    n = len(solutions) if isinstance(solutions, list) else None
    out = [
        Finding("status", status in Status.ALL, f"{status!r}" + ("" if status in Status.ALL else f"; known: {', '.join(Status.ALL)}")),
        Finding("method", method in METHODS, f"{method!r}" + ("" if method in METHODS else f"; known: {', '.join(METHODS)}")),
        Finding("success flag", data.get("success") is (status == Status.SOLVED),
                f"success: {data.get('success')!r} with status {status!r} (true exactly when solved)"),
        Finding("solutions", n is not None, "a list" if n is not None else f"expected a list, got {type(solutions).__name__}"),
    ]  # fmt: skip
    if n is not None and status in Status.ALL:
        needs = status in (Status.SOLVED, Status.APPROXIMATE)
        ok = (n >= 1) if needs else (n == 0)
        why = "needs at least one solution" if needs else "cannot hold a solution"
        out.append(Finding("status against solutions", ok, f"{status} with {n} solution(s)" + ("" if ok else f": {status} {why}")))
    return out


def _geometry(task: Task, data: dict) -> list[Finding]:
    if "collision_geometry" not in data:
        return [Finding("collision geometry", True, "not stated (a file written before it was recorded)")]
    ok, detail = check_collision_geometry(task, data["collision_geometry"])
    return [Finding("collision geometry (which capsules and solid judged it)", ok, detail)]


def _tolerances_claimed(data: dict, status, findings: list[Finding]) -> Tolerances:
    """The tolerances the solutions must meet: strict for ``solved``, the stated ones for
    ``approximate`` (each solution states them)."""
    if status != Status.APPROXIMATE:
        return Tolerances()
    stated = [s.get("tolerances") for s in data.get("solutions") or [] if isinstance(s, dict)]
    try:
        return Tolerances(**stated[0])
    except (IndexError, TypeError):
        findings.append(Finding("approximate tolerances", False, "an approximate result must state its tolerances"))
        return Tolerances()


# -- one solution ---------------------------------------------------------------------------
def _solution(task: Task, sol, i: int, tol: Tolerances) -> tuple[ResidualReport | None, list[Finding]]:
    label = f"solution {i}"
    try:
        q, found = _angles(task, sol, label)
        params = tuple((np.array(c["hand_params"], dtype=float), np.array(c["object_params"], dtype=float)) for c in sol["contacts"])
        config = Configuration(q, np.array(sol["T_palm_object"], dtype=float), params)
        report = evaluate(task, config, tol)
    except (KeyError, TypeError, ValueError, IndexError, InvalidTask) as exc:
        return None, [Finding(label, False, f"malformed or from another task ({type(exc).__name__}: {exc})")]
    verdict = "all constraints satisfied" if report.ok else report.summary()
    found.append(Finding(f"{label}: constraints ({_tol_name(tol)} tolerances)", report.ok, verdict))
    found += _stated_tolerances(sol, tol, label)
    found += _idle(task, q, sol, label)
    found += _link_poses(task, q, sol, label)
    found += _contacts(task, report, sol, label)
    found += _worst(report, sol, label)
    found += _object_depths(report, sol, label)
    found += _quality(task, config, report, sol, label)
    found += _approach(task, q, config, report, sol, label)
    return report, found


def _approach(task: Task, q, config: Configuration, report: ResidualReport, sol: dict, label: str) -> list[Finding]:
    """The stored pre-grasp and squeeze targets re-derived (:func:`prehension.pregrasp.check_approach`)."""
    from ..pregrasp import check_approach

    return [Finding(f"{label}: {what}", ok, detail) for what, ok, detail in check_approach(task, q, config.T_palm_object, report.contacts, sol)]


def _physics(task: Task, sol: dict, report: ResidualReport, label: str, rerun: bool) -> list[Finding]:
    """The stored physics verdict re-run (same options and seed); it must agree push by push."""
    what = f"{label}: physics verdict (held in all six pushes: {sol['physics'].get('success') if isinstance(sol['physics'], dict) else '?'})"
    try:
        stored = sol["physics"]
        pushes = [(p["direction"], bool(p["held"])) for p in stored["pushes"]]
        claim = (bool(stored["success"]), bool(stored["rejected"]), pushes)
        from ..sim import SimOptions

        options, seed = SimOptions(**stored["options"]), int(stored["seed"])
    except (KeyError, TypeError, ValueError, PrehensionError) as exc:
        return [Finding(what, False, f"malformed ({type(exc).__name__}: {exc})")]
    if not rerun:
        return [Finding(what, True, "not re-run (asked not to)")]
    try:
        from ..sim import require_mujoco, simulate_grasp

        require_mujoco()
    except PrehensionError:
        return [Finding(what, True, 'not re-run: MuJoCo is not installed (pip install "prehension[sim]")')]
    from types import SimpleNamespace

    grasp = SimpleNamespace(q=np.array([float(sol["joint_angles_rad"][d]) for d in task.hand.dof_names]),
                            T_palm_object=np.array(sol["T_palm_object"], dtype=float), contacts=report.contacts)  # fmt: skip
    again = simulate_grasp(task, grasp, options, seed)
    got = (again.success, again.rejected, [(p.direction, p.held) for p in again.pushes])
    if got == claim:
        return [Finding(what, True, f"re-run: {again.describe()}")]
    return [Finding(what, False, f"re-run disagrees: {again.describe()}; the file says "
                                 f"{'holds' if claim[0] else 'drops'} ({sum(h for _, h in pushes)} of {len(pushes)} pushes held)")]  # fmt: skip


def _tol_name(tol: Tolerances) -> str:
    return "strict" if tol == Tolerances() else "stated"


def _angles(task: Task, sol: dict, label: str) -> tuple[np.ndarray, list[Finding]]:
    names = list(task.hand.dof_names)
    rad, deg = sol["joint_angles_rad"], sol["joint_angles_deg"]
    found = []
    for unit, stored in (("rad", rad), ("deg", deg)):
        missing, extra = [d for d in names if d not in stored], [d for d in stored if d not in names]
        if missing or extra:
            raise ValueError(f"joint_angles_{unit} must name every dof of the hand; missing {missing}, unknown {extra}")
    q = np.array([float(rad[d]) for d in names])
    gap = max(abs(float(deg[d]) - float(np.degrees(rad[d]))) for d in names)
    worst = max(names, key=lambda d: abs(float(deg[d]) - float(np.degrees(rad[d]))))
    found.append(Finding(f"{label}: angles in deg and rad agree", gap <= STORED_TOLERANCE, f"largest gap {gap:.3g} deg ({worst})"))
    return q, found


def _stated_tolerances(sol: dict, tol: Tolerances, label: str) -> list[Finding]:
    stated = sol.get("tolerances")
    if stated is None:
        return []
    ok = stated == asdict(tol)
    return [Finding(f"{label}: stated tolerances", ok, "as checked" if ok else
                    f"the file states {stated}, but a result with this status is verified with {asdict(tol)}")]  # fmt: skip


def _idle(task: Task, q: np.ndarray, sol: dict, label: str) -> list[Finding]:
    moved = sol.get("idle_moved") or []
    active = task.active_mask
    names = task.hand.dof_names
    wrong = [d for d in moved if d not in names or active[names.index(d)]]
    off = [
        f"{d} at {np.degrees(q[k]):.6g} deg, held at {np.degrees(task.idle_vector[k]):.6g} deg"
        for k, d in enumerate(names) if not active[k] and d not in moved and abs(q[k] - task.idle_vector[k]) > 1e-12
    ]  # fmt: skip
    detail = "; ".join(off + [f"idle_moved names {d!r}, which is not an idle dof" for d in wrong])
    return [Finding(f"{label}: idle fingers at their held angles", not (off or wrong), detail or f"{len(moved)} declared moved")]


def _link_poses(task: Task, q: np.ndarray, sol: dict, label: str) -> list[Finding]:
    stored = sol.get("link_poses")
    names = task.hand.link_names
    if not isinstance(stored, dict) or sorted(stored) != sorted(names):
        got = sorted(stored) if isinstance(stored, dict) else type(stored).__name__
        return [Finding(f"{label}: link poses", False, f"must give every link of the hand ({len(names)}), got {got}")]
    T = forward_kinematics(task.hand, q).T_palm_link[0]
    gaps = {n: float(np.max(np.abs(np.array(stored[n], dtype=float) - T[k]))) for k, n in enumerate(names)}
    worst = max(gaps, key=gaps.get)
    return [Finding(f"{label}: link poses equal forward kinematics", gaps[worst] <= STORED_TOLERANCE,
                    f"largest gap {gaps[worst]:.3g} ({worst})")]  # fmt: skip


_CONTACT_FIELDS = ("hand_point", "hand_normal", "object_point", "object_normal", "distance_mm", "normal_angle_deg")


def _contacts(task: Task, report: ResidualReport, sol: dict, label: str) -> list[Finding]:
    stored = sol["contacts"]
    names = [c.name for c in task.contacts]
    if [c.get("name") for c in stored] != names:
        return [Finding(f"{label}: contacts", False, f"must be the task's contacts in order {names}, got {[c.get('name') for c in stored]}")]
    worst, where = 0.0, ""
    for state, c in zip(report.contacts, stored):
        for key in _CONTACT_FIELDS:
            gap = float(np.max(np.abs(np.array(c[key], dtype=float) - np.asarray(getattr(state, key), dtype=float))))
            if not gap <= worst:
                worst, where = gap, f"{c['name']} {key}"
    ok = worst <= STORED_TOLERANCE
    return [Finding(f"{label}: stored contact points, normals and residuals", ok, f"largest gap {worst:.3g}" + (f" ({where})" if where else ""))]


_LATER_KINDS = ("pad_collision",)  # kinds a file written before them does not state (issue 26)


def _worst(report: ResidualReport, sol: dict, label: str) -> list[Finding]:
    stored = sol.get("worst")
    kinds = sorted(report.kinds)
    if isinstance(stored, dict) and "object_depths_mm" not in sol:  # written before the pads were checked
        kinds = [k for k in kinds if k not in _LATER_KINDS]
    if not isinstance(stored, dict) or sorted(stored) != kinds:
        return [Finding(f"{label}: worst residuals", False, f"must give {kinds}")]
    gaps = {k: abs(float(stored[k]) - report.worst(k)) for k in kinds}
    k = max(gaps, key=gaps.get)
    return [Finding(f"{label}: worst residuals", gaps[k] <= STORED_TOLERANCE, f"largest gap {gaps[k]:.3g} ({k})")]


def _object_depths(report: ResidualReport, sol: dict, label: str) -> list[Finding]:
    """The stored depth of each link and each pad in the object, re-derived (issue 26)."""
    want = {kind: {c.name: c.value for c in report.checks if c.kind == kind} for kind in ("object_collision", "pad_collision")}
    if not any(want.values()):
        return []
    what = f"{label}: each link's and each pad's depth in the object"
    stored = sol.get("object_depths_mm")
    if stored is None:
        return [Finding(what, True, "not stated (a file written before they were stored); re-derived by the constraints above")]
    gaps = {}
    for key, kind in (("links", "object_collision"), ("pads", "pad_collision")):
        got = stored.get(key) if isinstance(stored, dict) else None
        if not isinstance(got, dict) or sorted(got) != sorted(want[kind]):
            return [Finding(what, False, f"{key} must give {sorted(want[kind])}")]
        gaps.update({f"{key} {n}": abs(float(got[n]) - v) for n, v in want[kind].items()})
    k = max(gaps, key=gaps.get)
    deepest = max(list(want["object_collision"].values()) + list(want["pad_collision"].values()))
    return [Finding(what, gaps[k] <= STORED_TOLERANCE, f"largest gap {gaps[k]:.3g} ({k}); deepest {deepest:.3g} mm")]


def _quality(task: Task, config: Configuration, report: ResidualReport, sol: dict, label: str) -> list[Finding]:
    """The stored quality (force closure, epsilon, volume) recomputed from the contacts with its stated options."""
    from ..quality import check_quality_entry

    if "quality" not in sol:
        return [Finding(f"{label}: quality", True, "not stated (a file written before quality was reported)")]
    ok, detail = check_quality_entry(task, config.T_palm_object, report.contacts, sol["quality"])
    return [Finding(f"{label}: quality (force closure, epsilon, volume)", ok, detail)]


def _requirement(task: Task, data: dict, reports: list) -> list[Finding]:
    """A search that required force closure (``stats.options.require``): every solution is
    force closure with the friction model the search states."""
    stats = data.get("stats") if isinstance(data.get("stats"), dict) else {}
    options = stats.get("options") if isinstance(stats.get("options"), dict) else {}
    if options.get("require") != "force-closure":
        return []
    from ..quality import QualityOptions, contacts_quality

    try:
        quality = QualityOptions.from_dict(options.get("quality", {}))
    except PrehensionError as exc:
        return [Finding("required force closure", False, f"the stated friction model is malformed: {exc}")]
    found = []
    for i, (report, sol) in enumerate(zip(reports, data.get("solutions") or [])):
        if report is not None:
            closed = contacts_quality(task, np.array(sol["T_palm_object"], dtype=float), report.contacts, quality).force_closure
            found.append(Finding(f"solution {i}: force closure (required)", closed, "" if closed else "FALSE: not force closure"))
    return found


# -- infeasible -----------------------------------------------------------------------------
def _reprove(task: Task, data: dict, reprove: bool, time_limit_s) -> tuple[SolveResult | None, list[Finding]]:
    stats = data.get("stats") if isinstance(data.get("stats"), dict) else {}
    if data.get("method") == "span":
        return None, [_span_proof(task, stats.get("proof"))]
    claimed = f"claimed proven by the complete solver: {stats.get('boxes', '?')} boxes, {stats.get('lps', '?')} linear programs"
    if data.get("method") != "complete":
        return None, [Finding("infeasibility", False, "only the complete solver proves infeasibility; method is "
                              f"{data.get('method')!r}")]  # fmt: skip
    claimed += _from_checkpoint(stats)
    if not reprove:
        return None, [Finding("infeasibility (not re-proved)", True, claimed + "; run check without --no-reprove to re-derive it")]
    again = _complete_again(task, stats.get("options"), time_limit_s)
    if again.status == Status.INFEASIBLE:
        return again, [Finding("infeasibility re-proved", True, _pruned_again(again, stats) + _from_checkpoint(stats))]
    if again.status == Status.SOLVED:
        return again, [Finding("infeasibility", False, "FALSE: the complete solver finds a verified solution of the embedded task")]
    return again, [Finding("infeasibility (could not re-prove)", True, f"{claimed}; re-running it: {again.message}")]


def _complete_again(task: Task, stored_options, time_limit_s) -> SolveResult:
    """The complete solver run again on ``task`` with the stored search options."""
    from ..solvers.complete.search import solve_complete
    from ..solvers.local.verifier import LocalVerifier

    return solve_complete(task, replace(_search_options(stored_options, time_limit_s), verifier=LocalVerifier()))


def _pruned_again(again: SolveResult, stored: dict) -> str:
    """How an infeasibility re-proved was proven (what pruned the boxes), against the stored count."""
    same = again.stats.get("boxes") == stored.get("boxes")
    note = "same count" if same else f"the file says {stored.get('boxes')}: other options or another version"
    by_collision = again.stats.get("collision_pruned", 0)
    by_self = again.stats.get("self_collision_pruned", 0)
    how = f", {by_collision} of them for hand-object collision: no penetration-free solution" if by_collision else ""
    how += f", {by_self} of them for self-collision: no self-collision-free solution" if by_self else ""
    by_closure = again.stats.get("closure_pruned", 0)
    how += f", {by_closure} of them by a certificate that none of their configurations is force closure" if by_closure else ""
    return f"all {again.stats['boxes']} boxes pruned again{how} ({note})"


def _hold_closure(task: Task, data: dict, reprove: bool, time_limit_s) -> list[Finding]:
    """``solve --hold``'s proof that no grasp in the regions is force closure
    (``stats.hold.closure`` with status ``infeasible``), run again by the complete solver."""
    stats = data.get("stats") if isinstance(data.get("stats"), dict) else {}
    hold = stats.get("hold") if isinstance(stats.get("hold"), dict) else {}
    closure = hold.get("closure") if isinstance(hold.get("closure"), dict) else {}
    if closure.get("status") != Status.INFEASIBLE:
        return []
    what = "--hold: no grasp in the regions is force closure"
    if closure.get("method") == "regions":
        return [_regions_again(task, closure, what, time_limit_s)]
    if not isinstance(closure.get("options"), dict) or closure["options"].get("require") != "force-closure":
        return [Finding(what, False, "FALSE: the stored search does not require force closure")]
    if not reprove:
        return [Finding(f"{what} (not re-proved)", True, f"claimed: {closure.get('message')}; run check without --no-reprove to re-derive it")]
    again = _complete_again(task, closure["options"], time_limit_s)
    if again.status == Status.INFEASIBLE:
        return [Finding(f"{what}: re-proved", True, _pruned_again(again, closure))]
    if again.status == Status.SOLVED:
        return [Finding(what, False, "FALSE: the complete solver finds a verified force-closure grasp of the embedded task")]
    return [Finding(f"{what} (could not re-prove)", True, f"claimed: {closure.get('message')}; re-running it: {again.message}")]


def _regions_again(task: Task, closure: dict, what: str, time_limit_s) -> Finding:
    """``solve --hold``'s proof without the hand (``"method": "regions"``: no choice of one
    point in each object region is force closure, :mod:`prehension.region_closure`),
    derived again from the embedded task with the stored friction model (cheap: always)."""
    from ..quality import QualityOptions
    from ..region_closure import regions_closure

    try:
        quality = QualityOptions.from_dict(closure.get("quality") or {})
    except (TypeError, ValueError, PrehensionError) as exc:
        return Finding(what, False, f"FALSE: the stored friction model is not valid ({exc})")
    again = regions_closure(task, quality, time_limit_s)
    if again.status == Status.INFEASIBLE:
        return Finding(f"{what}: re-proved", True, f"without the hand, {again.message} (friction {quality.friction:g}, "
                       f"torsion {quality.torsion_mm:g} mm)")  # fmt: skip
    if again.status == "witness":
        return Finding(what, False, "FALSE: some points of the object regions are force closure (" + again.message + ")")
    return Finding(f"{what} (could not re-prove)", True, f"claimed: {closure.get('message')}; re-deriving it: {again.message}")


def _span_proof(task: Task, proof) -> Finding:
    """A span proof (an assignment search's, :mod:`prehension.assignment.span`) derived
    again from the embedded task: cheap, so always re-derived (``reprove`` or not)."""
    from ..assignment.span import check_span_proof

    holds, detail = check_span_proof(task, proof if isinstance(proof, dict) else {})
    return Finding(SPAN_REPROVED if holds else "infeasibility (span proof)", holds, detail)


def _from_checkpoint(stats: dict) -> str:
    """A claim resumed from a checkpoint says so: part of its proof rests on the checkpoint's
    boxes, so it is re-proved from the initial box like any other (never trusted)."""
    resumed = stats.get("resumed")
    if not isinstance(resumed, dict):
        return ""
    return (f"; the claim was resumed from checkpoint {resumed.get('checkpoint')!r} ({resumed.get('boxes', '?')} boxes "
            "pruned before it): the re-proof starts from the initial box and does not read it")  # fmt: skip


def _search_options(stored, time_limit_s):
    """The stored search options that change the proof (sigma, order...), with the check's time limit."""
    from ..solvers.complete.search import BranchAndPruneOptions

    from ..quality import QualityOptions

    known = {f.name for f in fields(BranchAndPruneOptions)}
    simple = {k: v for k, v in (stored or {}).items() if k in known and isinstance(v, (int, float, str, bool))}
    simple.pop("max_boxes", None)
    simple["time_limit_s"] = time_limit_s
    try:
        if isinstance((stored or {}).get("quality"), dict):  # the friction model of require="force-closure"
            simple["quality"] = QualityOptions.from_dict(stored["quality"])
        return BranchAndPruneOptions(**simple)
    except (TypeError, ValueError, PrehensionError):
        return BranchAndPruneOptions(time_limit_s=time_limit_s)
