"""The SA hand's two collision geometries on the nine built-in tasks (issue 26 item 2).

    python benchmarks/sa_enclosing.py                    # local solver, both hands
    python benchmarks/sa_enclosing.py --complete 300     # also the complete solver, 300 s per task

``paper``: the built-in ``schunk-sa`` (capsules inside the published link meshes);
``enclosing``: ``schunk-sa-enclosing`` (capsules enclosing them, the pad spheres standing
for the links' surface near the pads; :mod:`prehension.hands.sa_enclosing`).  Both solve
with the same initial-pose sequence (the SA hand's shipped one), so only the geometry
differs.  Per task and hand:

* the local (and complete) solver's status and time, and whether ``check`` holds
  (:func:`prehension.verification.verify_result` on the result dict);
* **pads rule**: an independent re-measure of the solution (capsule axes sampled every
  0.5 mm, signed distance to the object's mesh; on a contact's link a capsule ball is
  excused only inside that pad's sphere, ``|s - c| <= rho - r``; each pad itself
  ``rho - sd(c)``): the deepest link and how deep [mm];
* for the paper hand's solution: what the enclosing capsules say of that same
  configuration (the residual function's deepest link, and the pads-rule re-measure).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import numpy as np
from rich.console import Console
from rich.table import Table

from prehension.geometry.regions import SphereCap
from prehension.hands.kinematics import forward_kinematics
from prehension.hands.sa_enclosing import with_enclosing_capsules
from prehension.results import result_to_dict
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solve import SolveOptions, solve
from prehension.solvers.local.sequence import shipped_sequence
from prehension.tasks.library import builtin_task_names, load_builtin_task
from prehension.verification.residuals import evaluate
from prehension.verification import verify_result

STEP_MM = 0.5


def _pads(task) -> dict[str, list[tuple[np.ndarray, float]]]:
    """Per link, the pad spheres of the task's contacts on it: (centre in the link frame, radius)."""
    out: dict = {}
    for c in task.contacts:
        hr = task.hand.regions[c.hand_region]
        if isinstance(hr.region, SphereCap):
            out.setdefault(hr.link, []).append((np.asarray(hr.region.center, dtype=float), float(hr.region.radius)))
    return out


def pads_rule_depth(task, config) -> tuple[str, float]:
    """The deepest link under the pads rule and its depth [mm] (see the module docstring)."""
    T = forward_kinematics(task.hand, config.joint_angles).T_palm_link[0]
    T_po = np.asarray(config.T_palm_object)
    dist = task.object.distance
    pads = _pads(task)
    worst = ("-", -np.inf)
    for k, link in enumerate(task.hand.links):
        for cap in link.collision:
            n = max(2, int(np.linalg.norm(cap.b - cap.a) / STEP_MM) + 2)
            s_link = cap.a + np.linspace(0, 1, n)[:, None] * (cap.b - cap.a)
            excused = np.zeros(n, dtype=bool)
            for c, rho in pads.get(link.name, []):
                excused |= np.linalg.norm(s_link - c, axis=1) <= rho - cap.radius + 1e-9
            s = (s_link @ T[k][:3, :3].T + T[k][:3, 3] - T_po[:3, 3]) @ T_po[:3, :3]  # object frame
            depth = cap.radius - dist.signed_distance(s)
            depth[excused] = -np.inf
            if depth.max() > worst[1]:
                worst = (link.name, float(depth.max()))
        for c, rho in pads.get(link.name, []):
            p = (T[k][:3, :3] @ c + T[k][:3, 3] - T_po[:3, 3]) @ T_po[:3, :3]
            d = rho - float(dist.signed_distance(p[None])[0])
            if d > worst[1]:
                worst = (f"{link.name} pad", d)
    return worst


def _deepest_residual(task, config) -> str:
    report = evaluate(task, config)
    rows = [c for c in report.checks if c.kind in ("object_collision", "collision")]
    if not rows:
        return "-"
    c = max(rows, key=lambda c: c.value)
    return f"{c.name} {c.value:.1f}"


def run(task, method: str, sequence, time_limit: float):
    from prehension.solvers.complete.search import BranchAndPruneOptions

    t = time.perf_counter()
    if method == "local":
        result = solve(task, SolveOptions(method="local", sequence=sequence))
    else:
        result = solve(task, SolveOptions(method="complete", complete_options=BranchAndPruneOptions(time_limit_s=time_limit)))
    seconds = time.perf_counter() - t
    holds = verify_result(result_to_dict(result, quality_entries(result), approach_entries_of(result)), reprove=False).holds
    return result, seconds, holds


def _depth_text(where) -> str:
    return "-" if where is None else f"{where[0]} {where[1]:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--complete", type=float, metavar="SECONDS", help="also the complete solver with this time limit")
    parser.add_argument("--tasks", nargs="*", default=None, help="built-in task names (default: all nine)")
    parser.add_argument("--no-local", action="store_true", help="only the complete solver")
    args = parser.parse_args()
    paper_seq = shipped_sequence(load_builtin_task(builtin_task_names()[0]).hand)
    seqs = {"paper": paper_seq, "enclosing": replace(paper_seq, hand="schunk-sa-enclosing")}
    methods = ([] if args.no_local else ["local"]) + (["complete"] if args.complete else [])
    table = Table(title="SA hand: paper capsules against enclosing capsules (depths in mm, pads rule re-measured)")
    for col in ("task", "hand", "method", "status", "s", "check", "pads rule: deepest", "paper solution on enclosing: residual / pads rule"):
        table.add_column(col)
    for name in args.tasks or builtin_task_names():
        paper = load_builtin_task(name)
        tasks = {"paper": paper, "enclosing": replace(paper, hand=with_enclosing_capsules(paper.hand))}
        for method in methods:
            for label, task in tasks.items():
                result, seconds, holds = run(task, method, seqs[label], args.complete or 0.0)
                config = result.solutions[0].configuration() if result.solutions else None
                deep = pads_rule_depth(task, config) if config is not None else None
                cross = ""
                if label == "paper" and config is not None:
                    cross = f"{_deepest_residual(tasks['enclosing'], config)} / {_depth_text(pads_rule_depth(tasks['enclosing'], config))}"
                row = (name, label, method, result.status, f"{seconds:.2f}", "holds" if holds else "FAILS", _depth_text(deep), cross)
                table.add_row(*row)
                print(" | ".join(row), file=sys.stderr, flush=True)  # as it goes: a long run can be cut short
    Console(width=200).print(table)


if __name__ == "__main__":
    main()
