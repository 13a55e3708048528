"""Peak memory and first-call time of the local solver, per hand.

    python benchmarks/memory.py                          # SA, Allegro, SVH
    python benchmarks/memory.py path/to/leap_hand_right.urdf ...

Each hand runs in a fresh process (the compiled kernel loaded from numba's cache, as in
any run after the first): load the hand, give each finger's tip link a fingertip cap
when the hand has no sphere-cap region of its own, build forward problems (random
collision-free poses; the rejection sampling tests every capsule pair), then time the
first ``solve_local`` call (which also builds the hand's tables and, for a hand without a
shipped sequence, samples its default initial-pose sequence), a second call on another
task, and one batch.  Peak memory is the process's maximum resident set size.  The
Allegro and SVH hands are read from ``../shared/hands`` beside the checkout.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED_HANDS = ROOT.parent / "shared" / "hands"
DEFAULT_HANDS = [
    "sa",
    str(SHARED_HANDS / "allegro_hand" / "allegro_hand_right.urdf"),
    str(SHARED_HANDS / "schunk_hand" / "schunk_svh_hand_right.urdf"),
]

_CHILD = r"""
import json, resource, sys, time
t0 = time.perf_counter()
import numpy as np
from prehension.geometry.regions import SphereCap
from prehension.hands.collision import collision_pairs
from prehension.hands.model import HandRegion
from prehension.solvers.local import LocalOptions, random_point_problems, solve_local, solve_local_batch
t_import = time.perf_counter() - t0
spec, n_batch = sys.argv[1], int(sys.argv[2])
t0 = time.perf_counter()
if spec == "sa":
    from prehension.hands.sa_hand import schunk_sa_hand
    hand = schunk_sa_hand()
    regions = ("thumb_tip", "index_tip", "middle_tip", "ring_tip")
else:
    from prehension.hands.urdf import hand_from_urdf
    hand = hand_from_urdf(spec)
    caps = {n: r for n, r in hand.regions.items() if isinstance(r.region, SphereCap)}
    if not caps:  # a 10 mm fingertip cap at each tip link, 90 deg about its x axis
        caps = {f"{f.name}_tip": HandRegion(f.tip_link, SphereCap((0, 0, 0), 10.0, (1, 0, 0), np.pi / 2)) for f in hand.fingers}
        hand = hand.with_regions(caps)
    regions = tuple(caps)[:4]
t_hand = time.perf_counter() - t0
t0 = time.perf_counter()
problems = random_point_problems(n_batch + 2, hand, regions, seed=0)
t_problems = time.perf_counter() - t0
t0 = time.perf_counter()
first = solve_local(problems.task(0))
t_first = time.perf_counter() - t0
t0 = time.perf_counter()
second = solve_local(problems.task(1))
t_second = time.perf_counter() - t0
t0 = time.perf_counter()
batch = solve_local_batch(problems.subset(np.arange(2, n_batch + 2)))
t_batch = time.perf_counter() - t0
print(json.dumps({
    "hand": hand.name, "capsules": int(len(collision_pairs(hand).link)), "pairs": int(len(collision_pairs(hand).first)),
    "contacts": len(regions), "import_s": t_import, "hand_s": t_hand, "problems_s": t_problems,
    "first_call_s": t_first, "second_call_s": t_second, "first_status": first.status, "second_status": second.status,
    "batch_ms_per_problem": 1e3 * t_batch / n_batch, "batch_solved": float(batch.success.mean()),
    "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
}))
"""


def measure(spec: str, n_batch: int) -> dict:
    proc = subprocess.run([sys.executable, "-c", _CHILD, spec, str(n_batch)], capture_output=True, text=True)
    if proc.returncode != 0:
        return {"hand": spec, "error": (proc.stderr.strip().splitlines() or ["killed"])[-1], "exit": proc.returncode}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("urdf", nargs="*", help="more hands (URDF files)")
    ap.add_argument("--batch", type=int, default=200, help="problems in the timed batch (default 200)")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows as JSON")
    args = ap.parse_args(argv)
    specs = [h for h in DEFAULT_HANDS if h == "sa" or Path(h).is_file()] + args.urdf
    measure("sa", 4)  # make sure the kernel is compiled and cached before timing first calls
    rows = []
    head = f"{'hand':<16}{'capsules':>9}{'pairs':>8}{'peak MB':>9}{'import s':>9}{'1st call s':>11}{'2nd call s':>11}" \
           f"{'extra s':>9}{'batch ms':>9}{'solved %':>9}"  # fmt: skip
    print(head)
    for spec in specs:
        r = measure(spec, args.batch)
        rows.append(r)
        if "error" in r:
            print(f"{Path(spec).stem:<16} failed (exit {r['exit']}): {r['error']}")
            continue
        print(f"{r['hand']:<16}{r['capsules']:>9}{r['pairs']:>8}{r['peak_mb']:>9.0f}{r['import_s']:>9.2f}"
              f"{r['first_call_s']:>11.3f}{r['second_call_s']:>11.3f}{r['first_call_s'] - r['second_call_s']:>9.3f}"
              f"{r['batch_ms_per_problem']:>9.3f}{100 * r['batch_solved']:>9.1f}", flush=True)  # fmt: skip
    print("extra s = first call - second call: building the hand's tables, its default sequence, loading the kernel")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
