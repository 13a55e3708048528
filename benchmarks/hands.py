"""Hands from files: import, fingers and fingertips found, both solvers on forward-built tasks.

    python benchmarks/hands.py              # 50 tasks per group (a few minutes on 2 cores)
    python benchmarks/hands.py --quick      # 10 tasks per group

For each hand of ``../shared/hands`` (the Schunk SVH and the Allegro), read from its URDF
and from the MJCF that MuJoCo compiles from that URDF (``urdf_to_mjcf``, in a temporary
folder), the script prints:

1. **Hands**: the import time (median of ``--repeats`` uncached reads, ms), links, joint
   angles, couplings, the fingers found (the opposing one marked ``*``) and each fitted
   fingertip's radius and fit (rms / largest distance of the surface inside the cap).
2. **Tasks**: for 2, 3 and 4 fingers (the thumb, then index, middle, ring), ``--tasks``
   forward-built point-contact tasks (``random_point_problems``: random angles within the
   limits and couplings, random points on the fitted fingertip caps, no self-collision,
   the contacts expressed in a random object frame -- each task has a known solution),
   solved one by one with ``solve(task, "local")`` and ``solve(task, "complete")``
   (``--time-limit`` per task): solved fraction, the first call's time (the hand's first
   task: default initial-pose sequence, system building; the very first call of the
   process also compiles the numba kernels) and the median warm time.

Every solution counted was re-verified by the one residual function within the strict
tolerances (that is what ``solved`` means).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from rich.console import Console  # noqa: E402
from rich.table import Table  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from prehension.hands.mjcf import hand_from_mjcf, urdf_to_mjcf  # noqa: E402
from prehension.hands.urdf import hand_from_urdf  # noqa: E402
from prehension.solve import SolveOptions, solve  # noqa: E402
from prehension.solvers.complete.search import BranchAndPruneOptions  # noqa: E402
from prehension.solvers.local.problems import random_point_problems  # noqa: E402

HANDS_DIR = Path(__file__).resolve().parents[2] / "shared" / "hands"
HANDS = {"svh": "schunk_hand/schunk_svh_hand_right.urdf", "allegro": "allegro_hand/allegro_hand_right.urdf"}
GROUPS = (("thumb", "index"), ("thumb", "index", "middle"), ("thumb", "index", "middle", "ring"))


def _median_ms(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000.0 * statistics.median(times)


def _forms(key: str, tmp: Path) -> list[tuple[str, Path, object]]:
    urdf = HANDS_DIR / HANDS[key]
    mjcf = urdf_to_mjcf(urdf, tmp / f"{key}.xml")
    return [("URDF", urdf, hand_from_urdf), ("MJCF", mjcf, hand_from_mjcf)]


def _hand_row(key, form, path, reader, repeats):
    ms = _median_ms(lambda: reader(path), repeats)
    hand = reader(path)
    fingers = ", ".join(f.name + ("*" if f.name == hand.opposing_finger else "") for f in hand.fingers)
    tips = []
    for f in hand.fingers:
        reg, fit = hand.regions.get(f"{f.name}_tip"), hand.tip_fits.get(f"{f.name}_tip")
        if reg is not None:
            tips.append(f"{f.name} {reg.region.radius:.1f} ({fit.rms_mm:.2f}/{fit.max_mm:.2f})")
    row = [key, form, f"{ms:.0f}", str(len(hand.links)), str(hand.n_dof), str(len(hand.couplings)), fingers, "; ".join(tips)]
    return hand, row


def _run(tasks, method: str, limit: float) -> tuple[str, float, float]:
    """(solved fraction and the others' statuses, first call [s], median warm [ms]) of
    solving ``tasks`` one by one.  Every task has a solution: ``infeasible`` would be a bug."""
    statuses, times = [], []
    options = BranchAndPruneOptions(time_limit_s=limit)
    for task in tasks:
        t0 = time.perf_counter()
        result = solve(task, SolveOptions(method=method, complete_options=options, seed=0))
        times.append(time.perf_counter() - t0)
        statuses.append(result.status)
    warm = 1000.0 * statistics.median(times[1:]) if len(times) > 1 else float("nan")
    solved = f"{100 * statuses.count('solved') / len(tasks):.0f}%"
    others = ", ".join(f"{statuses.count(s)} {s}" for s in sorted(set(statuses) - {"solved"}))
    return solved + (f" ({others})" if others else ""), times[0], warm


def _task_rows(key, form, hand, n, limit, seed):
    rows = []
    for fingers in GROUPS:
        regions = tuple(f"{f}_tip" for f in fingers if f"{f}_tip" in hand.regions)
        if len(regions) != len(fingers):
            continue
        problems = random_point_problems(n, hand, regions, seed)
        tasks = [problems.task(i, f"{key}-{len(fingers)}-{i}") for i in range(n)]
        local = _run(tasks, "local", limit)
        complete = _run(tasks, "complete", limit)
        rows.append([
            key, form, str(len(fingers)), str(n),
            local[0], f"{local[1]:.2f}", f"{local[2]:.0f}", complete[0], f"{complete[1]:.2f}", f"{complete[2]:.0f}",
        ])  # fmt: skip
    return rows


def _table(title: str, columns, rows) -> Table:
    table = Table(title=title, title_justify="left")
    for c in columns:
        table.add_column(c, overflow="fold")
    for r in rows:
        table.add_row(*r)
    return table


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="10 tasks per group")
    parser.add_argument("--tasks", type=int, default=None, help="tasks per group (default 50; --quick: 10)")
    parser.add_argument("--time-limit", type=float, default=60.0, help="complete solver: seconds per task")
    parser.add_argument("--repeats", type=int, default=5, help="import time: median of this many reads")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    n = args.tasks or (10 if args.quick else 50)
    if not HANDS_DIR.is_dir():
        raise SystemExit(f"{HANDS_DIR} not found: the shared hands sit beside the checkout")
    console = Console(width=160)
    hand_rows, task_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for key in HANDS:
            for form, path, reader in _forms(key, Path(tmp)):
                hand, row = _hand_row(key, form, path, reader, args.repeats)
                hand_rows.append(row)
                task_rows += _task_rows(key, form, hand, n, args.time_limit, args.seed)
                console.print(f"done: {key} {form}")
    console.print(_table("Hands read from files", (
        "hand", "file", "import ms", "links", "angles", "couplings", "fingers (* opposes)",
        "fingertip radius mm (fit rms/max mm)"), hand_rows))  # fmt: skip
    console.print(_table(f"Forward-built point-contact tasks ({n} per row, complete solver limit {args.time_limit:g} s)", (
        "hand", "file", "fingers", "tasks", "local solved", "local first s", "local warm ms",
        "complete solved", "complete first s", "complete warm ms"), task_rows))  # fmt: skip


if __name__ == "__main__":
    main()
