"""Grasps planned on bare meshes: ``prehension plan`` on every mesh, per hand.

Objects: every mesh of ``../shared/objects`` (the bunny at 100 mm per unit, the five
random solids at 10 mm per unit: 6-8 cm across) and the built-in objects (teapot, scalpel,
guitar; mm).  Hands: the built-in SA hand and the Allegro hand of ``../shared/hands``
(fingertip pads fitted from its meshes).  For each object and hand,
:func:`prehension.planning.plan_grasps` with the command's defaults (3 fingertips, the
thumb opposing the others, 600 surface samples, seed 0, the local solver with 16 initial
poses per assignment, no complete solver) until 10 grasps are found.

Per row: the candidate sets proposed, the sets tried and the assignments decided, the
grasps found, how many of them the one residual function (:func:`prehension.evaluate`)
accepts again from the solution alone ("verified"), the wall and CPU time of this process
(one core: the plan runs in one process), and with ``--simulate`` (MuJoCo) how many
grasps hold in the physics test (:func:`prehension.sim.simulate_grasp`, six pushes).

    python benchmarks/plan.py                     # both hands, every object
    python benchmarks/plan.py --hands sa --objects bunny,000
    python benchmarks/plan.py --simulate          # + physics (a few s per grasp)
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
HANDS = {"sa": "sa", "allegro": str(SHARED / "hands" / "allegro_hand" / "allegro_hand_right.urdf")}


def objects():
    """``(name, path, scale)`` of every benchmark object."""
    from prehension.tasks.library import builtin_mesh_dir

    out = [("bunny", SHARED / "objects" / "bunny.obj", 100.0)]
    out += [(p.stem, p, 10.0) for p in sorted((SHARED / "objects" / "random").glob("*.obj"))]
    out += [(n, builtin_mesh_dir() / f"{n}.ply", 1.0) for n in ("teapot", "scalpel", "guitar")]
    return out


def verified(grasp) -> bool:
    from prehension import evaluate

    result = grasp.outcome.result
    return bool(result.solutions) and all(evaluate(result.task, s.configuration()).ok for s in result.solutions)


def held(grasp) -> bool | None:
    """Whether the grasp's first solution holds in the physics test; ``None`` when MuJoCo
    refuses the scene (e.g. a convex piece of the object with too small a volume)."""
    from prehension.sim import simulate_grasp

    result = grasp.outcome.result
    try:
        return bool(simulate_grasp(result.task, result.solutions[0]).success)
    except ValueError:
        return None


def holds(grasps) -> str:
    """``held / simulated`` (and how many scenes MuJoCo refused)."""
    verdicts = [held(g) for g in grasps]
    refused = sum(v is None for v in verdicts)
    text = f"{sum(v is True for v in verdicts)} / {len(verdicts) - refused}"
    return text + (f" ({refused} scenes refused)" if refused else "")


def row(hand, name: str, path: Path, scale: float, simulate: bool, grasps: int) -> list[str]:
    from prehension.objects.solid import MeshFileSolid
    from prehension.planning import NoGraspError, PlanOptions, plan_grasps

    wall, cpu = time.perf_counter(), time.process_time()
    try:
        report = plan_grasps(MeshFileSolid(str(path), scale), hand, PlanOptions(grasps=grasps))
    except NoGraspError as exc:
        return [name, "-", "-", "-", "0", "-", f"{time.perf_counter() - wall:.1f}", f"{time.process_time() - cpu:.1f}", "-",
                str(exc)[:60]]  # fmt: skip
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    ok = sum(verified(g) for g in report.grasps)
    hold = holds(report.grasps) if simulate else "-"
    return [name, str(report.sets), str(report.tried), str(report.assignments), str(len(report.grasps)), str(ok),
            f"{wall:.1f}", f"{cpu:.1f}", hold, ""]  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--hands", default="sa,allegro", help="comma-separated: sa, allegro")
    parser.add_argument("--objects", default="", help="comma-separated object names (default: all)")
    parser.add_argument("--grasps", type=int, default=10)
    parser.add_argument("--simulate", action="store_true", help="physics test of every grasp (needs MuJoCo)")
    args = parser.parse_args(argv)
    from prehension.tasks.format.tasks import resolve_hand

    wanted = set(filter(None, args.objects.split(",")))
    header = ["object", "candidates", "sets tried", "assignments", "grasps", "verified", "wall s", "CPU s", "hold", "note"]
    for hand_name in args.hands.split(","):
        hand = resolve_hand(HANDS[hand_name])
        print(f"\nhand {hand.name} ({hand_name}), {args.grasps} grasps wanted, {os.cpu_count()} cores on the machine, one used")
        print("| " + " | ".join(header) + " |")
        print("|" + "|".join("---" for _ in header) + "|")
        for name, path, scale in objects():
            if wanted and name not in wanted:
                continue
            print("| " + " | ".join(row(hand, name, path, scale, args.simulate, args.grasps)) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
