"""The assignment search (issue 30): every assignment of an open task decided, and how fast.

An open task with four object regions of a built-in object and six candidate hand regions
(``--hand svh``: the five fingertips of the Schunk SVH, read from
``../shared/hands/schunk_hand``, and a palm cap added on its palm; ``--hand sa``: the SA
hand's four fingertips, its palm and the index finger's middle phalanx) -- 6 x 5 x 4 x 3 =
360 ordered assignments -- is searched with :func:`prehension.assignment.search_assignments`:
span proofs first, then the local solver's batch path, then the complete solver for
``--assignment-time`` seconds on each assignment the local solver did not solve, under a
whole-search ``--time-limit``.  Per object and executor (``--workers 1``: in this process;
``N > 1``: a local Dask cluster of N processes, started before the clock): assignments,
feasible, proven impossible (by span, by the complete solver), undecided, wall time.
``--agree N`` also solves N of the assignments one by one
(:func:`prehension.assignment.solving.solve_alone`, same seeds and budget) and counts
disagreements with the search.  ``--round-poses B`` sets the rounds of initial poses
(default 8; 0: one round of every pose, the search before rounds).  ``--random N`` adds a
seeded random draw of N open tasks: a mesh of ``../shared/objects`` (bunny, random/*),
four regions grown on it at a force-closure point set drawn among the planner's proposals
(:mod:`prehension.planning`, ``--draw-seed``), the same six candidate hand regions.

    python benchmarks/assignment.py                        # the three objects, in-process and 2 workers
    python benchmarks/assignment.py --objects teapot --workers 2 --agree 40
    python benchmarks/assignment.py --workers 2 --assignment-time 0 --time-limit 30 --random 6
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from prehension.assignment import AssignmentOptions, OpenContact, OpenTask, concrete_task, search_assignments
from prehension.assignment import assignment_seed, enumerate_assignments
from prehension.assignment.solving import solve_alone
from prehension.geometry.regions import SphereCap
from prehension.hands.model import HandRegion
from prehension.objects.model import GraspObject
from prehension.solvers.local import LocalOptions
from prehension.tasks.library import load_builtin_task

SHARED = Path(__file__).resolve().parents[2] / "shared"
SVH = SHARED / "hands" / "schunk_hand" / "schunk_svh_hand_right.urdf"
#: the built-in tasks whose objects (four regions each) are searched
OBJECTS = {"teapot": "teapot-transportation", "guitar": "guitar-holding", "scalpel": "scalpel-incision"}


def svh_hand():
    """The SVH with its five fitted fingertips and a palm cap (on the palm's capsules, facing
    the fingers' pads: +y)."""
    from prehension.hands.files import load_hand_file

    hand = load_hand_file(SVH)
    palm = HandRegion(hand.links[0].name, SphereCap((-5.7, 3.5, 60.0), 24.68, (0.0, 1.0, 0.0), np.radians(45.0)))
    return replace(hand, regions={**hand.regions, "palm": palm})


def hand_and_candidates(name: str):
    if name == "svh":
        return svh_hand(), ("thumb_tip", "index_tip", "middle_tip", "ring_tip", "little_tip", "palm")
    hand = load_builtin_task("teapot-service").hand  # the SA hand with the index's middle phalanx
    return hand, ("thumb_tip", "index_tip", "middle_tip", "ring_tip", "palm", "index_middle_phalanx")


def open_task(object_name: str, hand, candidates) -> OpenTask:
    base = load_builtin_task(OBJECTS[object_name])
    regions = list(base.object.regions)[:4]
    contacts = tuple(OpenContact(r, candidates) for r in regions)
    return OpenTask(f"{object_name}-open", hand, base.object, contacts)


def random_tasks(n: int, seed: int, hand, candidates) -> list[tuple[str, OpenTask]]:
    """``n`` open tasks drawn with ``seed``: a mesh of ``../shared/objects`` each (in turn
    from a shuffled list), four regions grown at one of the planner's first 20 proposed
    four-point sets (drawn), every contact open to ``candidates``."""
    from prehension.objects.solid import MeshFileSolid
    from prehension.planning.grow import MeshSurface
    from prehension.planning.hand_side import hand_side
    from prehension.planning.propose import ProposalOptions, grow_set, propose_points

    meshes = [("bunny", SHARED / "objects" / "bunny.obj", 100.0)]
    meshes += [(p.stem, p, 10.0) for p in sorted((SHARED / "objects" / "random").glob("*.obj"))]
    rng = np.random.default_rng(seed)
    order = [meshes[i] for i in rng.permutation(len(meshes))]
    side = hand_side(hand, 4, palm=True, oppose=False)
    out = []
    for k in range(n):
        name, path, scale = order[k % len(order)]
        solid = MeshFileSolid(str(path), scale)
        surface = MeshSurface(solid.mesh())
        points = propose_points(surface, side, 4, ProposalOptions(seed=int(rng.integers(2**31))))
        for j in rng.permutation(min(20, len(points.sets))):
            grown = grow_set(surface, points, int(j))
            if grown is not None:
                break
        regions = {f"r{i}": r for i, r in enumerate(grown.regions)}
        obj = GraspObject(f"{name}-{k}", regions, solid=solid)
        out.append((f"{name}#{j}", OpenTask(f"{name}-{k}-open", hand, obj, tuple(OpenContact(r, candidates) for r in regions))))
    return out


def run(task: OpenTask, options: AssignmentOptions) -> tuple[dict, object]:
    started, cpu = time.perf_counter(), time.process_time()
    found = []  # when each feasible assignment was found [s]

    def note(verdict):
        if type(verdict).__name__ == "AssignmentOutcome":
            found.append(time.perf_counter() - started)

    report = search_assignments(task, options, on_decided=note)
    seconds, cpu = time.perf_counter() - started, time.process_time() - cpu
    span = sum(1 for _, p in report.infeasible if getattr(p, "kind", None) == "span")
    row = {"assignments": report.total, "feasible": len(report.feasible), "span": span,
           "complete": len(report.infeasible) - span, "undecided": len(report.undecided), "seconds": seconds,
           "cpu": cpu if options.executor is None else None, "last_feasible": max(found, default=None)}  # fmt: skip
    return row, report


def agreement(task: OpenTask, report, options: AssignmentOptions, n: int, rng) -> tuple[int, int]:
    """``(checked, disagreeing)``: ``n`` assignments (seeded draw, those the span did not
    rule out) solved alone against the search's verdict: any difference counts, but for
    undecided against decided when the complete solver ran (its time limit may fall on
    either side of a proof under load)."""
    verdict = {o.assignment.label: "solved" for o in report.feasible}
    verdict |= {a.label: "infeasible" for a, _ in report.infeasible}
    verdict |= {a.label: "undecided" for a, _ in report.undecided}
    spanned = {a.label for a, p in report.infeasible if getattr(p, "kind", None) == "span"}
    pool = [a for a in enumerate_assignments(task) if a.label not in spanned]
    picked = [pool[i] for i in rng.choice(len(pool), size=min(n, len(pool)), replace=False)]
    bad = 0
    for a in picked:
        alone = solve_alone(concrete_task(task, a), assignment_seed(options.seed, a), options)
        status = {"solved": "solved", "infeasible": "infeasible"}.get(alone.status, "undecided")
        timed = options.complete_time_s > 0 and "undecided" in (status, verdict[a.label])  # a time limit: either side of it
        bad += status != verdict[a.label] and not timed
    return len(picked), bad


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--objects", nargs="+", default=sorted(OBJECTS), choices=sorted(OBJECTS))
    p.add_argument("--hand", choices=("svh", "sa"), default="sa")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--assignment-time", type=float, default=0.5, help="complete solver per undecided assignment [s]")
    p.add_argument("--time-limit", type=float, default=30.0, help="whole search [s] (0: none)")
    p.add_argument("--initial-poses", type=int, default=None,
                   help="local solver's initial poses per assignment (default: LocalOptions' 64)")
    p.add_argument("--agree", type=int, default=0, help="assignments solved one by one against the search (per object)")
    p.add_argument("--round-poses", type=int, default=8, help="initial poses per round (0: one round of every pose)")
    p.add_argument("--random", type=int, default=0, metavar="N", help="also N open tasks drawn on ../shared/objects meshes")
    p.add_argument("--draw-seed", type=int, default=0, help="the seed of the --random draw")
    args = p.parse_args(argv)
    if args.hand == "svh" and not SVH.is_file():
        print(f"{SVH} not found: run with --hand sa", file=sys.stderr)
        return 2
    hand, candidates = hand_and_candidates(args.hand)
    small = open_task(args.objects[0], hand, candidates[:4])
    warm = search_assignments(small, AssignmentOptions(complete_time_s=0))
    print(f"warm-up (numba, spans): {warm.total} assignments in {warm.seconds:.1f} s; load {os.getloadavg()[0]:.1f}\n")
    print("| object | hand | workers | assignments | feasible | impossible (span) | impossible (complete) | undecided | wall [s] "
          "| last feasible at [s] | CPU [s] | agree |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    tasks = [(name, open_task(name, hand, candidates)) for name in args.objects]
    tasks += random_tasks(args.random, args.draw_seed, hand, candidates) if args.random else []
    totals: dict = {}
    for name, task in tasks:
        for workers in args.workers:
            row, report, agree = _measure(task, args, workers, small)
            print(f"| {name} | {args.hand} | {workers} | {row['assignments']} | {row['feasible']} | {row['span']} | "
                  f"{row['complete']} | {row['undecided']} | {row['seconds']:.1f} | {_s(row['last_feasible'])} | "
                  f"{_s(row['cpu'])} | {agree} |", flush=True)  # fmt: skip
            total = totals.setdefault((name in OBJECTS, workers), {})
            for key in ("assignments", "feasible", "span", "complete", "undecided", "seconds"):
                total[key] = total.get(key, 0) + row[key]
    for (builtin, workers), t in totals.items():
        print(f"| all {'built-in' if builtin else 'drawn'} | {args.hand} | {workers} | {t['assignments']} | {t['feasible']} | "
              f"{t['span']} | {t['complete']} | {t['undecided']} | {t['seconds']:.1f} | | | |")  # fmt: skip
    print(f"\nload average after: {os.getloadavg()[0]:.1f}; initial poses {args.initial_poses or 64}, "
          f"--round-poses {args.round_poses}, --assignment-time {args.assignment_time:g} s, --time-limit {args.time_limit:g} s")
    return 0


def _s(seconds: float | None) -> str:
    return "-" if seconds is None else f"{seconds:.1f}"


def _measure(task: OpenTask, args, workers: int, small: OpenTask):
    from prehension.parallel import executor_for

    with executor_for(None, workers if workers > 1 else None) as executor:
        if executor is not None:  # the cluster started, its workers warm, before the clock
            warm = [executor.submit(search_assignments, small, AssignmentOptions(complete_time_s=0)) for _ in range(workers)]
            [f.result() for f in warm]
        local = None if args.initial_poses is None else LocalOptions(i_max=args.initial_poses)
        options = AssignmentOptions(complete_time_s=args.assignment_time, time_limit_s=args.time_limit or None, executor=executor,
                                    local_options=local, round_poses=args.round_poses or None)  # fmt: skip
        row, report = run(task, options)
    agree = "-"
    if args.agree:
        checked, bad = agreement(task, report, options.without_executor(), args.agree, np.random.default_rng(0))
        agree = f"{checked - bad}/{checked}"
    return row, report, agree


if __name__ == "__main__":
    sys.exit(main())
