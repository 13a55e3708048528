"""Real objects: solved, penetration-free and time, with collisions checked and ignored.

Rows: the nine built-in tasks (their closed meshes) and 30 tasks on the meshes of ../shared/objects (the bunny at 100 mm per unit,
about 90 x 140 x 200 mm; the five random solids at 10 mm per unit, about 60-80 mm a
side).  Each mesh task is made with the region tools: 2, 3 or 4 fingertip contacts
(thumb against index, middle, ring) on large faces whose normals face each other across
the object, each region a planar patch picked with ``region_from_mesh`` (degree 1,
inside one face, so it lies on the mesh).

For each method and each task, the same task is solved twice: with the object's
collisions checked (``object_collision`` in the residual function, the local solver's
kernel repairing penetrating answers with its penetration rows and its driver
re-checking them, idle fingers settled clear) and with them ignored
(``collisions: false``).  "clear" counts answers whose links and pads are all within 0.5 mm
of the surface (the residual function's verdict), measured on both (an answer found with collisions ignored is measured
afterwards).  Times are wall-clock medians per task; read ratios, not absolute values.

"deepest" re-measures each answer found with collisions checked independently of the
project's distance code (``remeasure.py``: each capsule's axis sampled at 64 points and
each pad ball, against the closed mesh by brute force, only a capsule ball inside its own
pad excused) and prints its deepest penetration [mm]; the summary counts answers deeper
than 1 mm.  ``--baseline SRC`` times the same local solves (collisions checked) with the
code in ``SRC`` (e.g. a checkout of the previous commit's ``src``) in a subprocess of the
same run, and prints the ratio of the median times.  Each process first solves the first
task once with collisions ignored, untimed (loading the compiled code); each mesh's first
solves with collisions checked still pay the filling of its signed-distance grid.

    python benchmarks/objects.py                       # local solver, every task
    python benchmarks/objects.py --methods local,complete --time-limit 10
    python benchmarks/objects.py --quick               # built-in tasks and 9 mesh tasks
    python benchmarks/objects.py --queries             # microseconds per distance query
    python benchmarks/objects.py --verify              # make_solution of each local answer, both ways
    python benchmarks/objects.py --simulate            # simulate's start on each local answer (slow: ~3 s a task)
    python benchmarks/objects.py --baseline ../old/src # and the local solver's time against older code

``--simulate`` (behind a flag: the physics test costs seconds per task) prints, per task the
local solver solves, the solver-side depth re-measured by ``remeasure.py`` (the deepest
capsule ball or pad, and which) beside the penetration MuJoCo sees at the start of
``prehension simulate``, split into the hand's own (its geoms into the solver's mesh) and the object's
approximation error (its convex pieces off the mesh next to the hand), with the counts
at most 1 mm.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from prehension.errors import InvalidObject
from prehension.objects.distance import MeshDistance
from prehension.objects.mesh_io import load_mesh
from prehension.objects.model import GraspObject
from prehension.objects.pick import region_from_mesh
from prehension.objects.solid import MeshFileSolid
from prehension.solve import solve
from prehension.tasks.library import builtin_task_names, load_builtin_task
from prehension.tasks.model import Contact, Task

try:  # the code of today; --baseline may run this script with older code, which has neither
    from prehension.solve import SolveOptions
    from prehension.verification.residuals import evaluate
except ImportError:  # older code: solve(task, method, complete_options=...); only --times-json runs there
    SolveOptions = evaluate = None

sys.path.insert(0, str(Path(__file__).resolve().parent))
from remeasure import deepest  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "objects"
MESHES = [("bunny.obj", 100.0)] + [(f"random/{i:03d}.obj", 10.0) for i in range(5)]
FINGERS = ("index", "middle", "ring")
GRIP_MM = (25.0, 95.0)  # widths a pinch can span


def _faces(mesh):
    tri = mesh.vertices[mesh.faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    normal = cross / (2 * area[:, None])
    a, b, c = (np.linalg.norm(tri[:, (i + 1) % 3] - tri[:, (i + 2) % 3], axis=1) for i in range(3))
    incentre = (a[:, None] * tri[:, 0] + b[:, None] * tri[:, 1] + c[:, None] * tri[:, 2]) / (a + b + c)[:, None]
    return incentre, normal, 2 * area / (a + b + c)  # inradius


def _opposed_pairs(mesh, distance, rng, n_pairs: int):
    """Face pairs (thumb side, finger side) with opposed normals across a graspable width,
    on the outer surface (a face whose both sides are inside is an internal wall)."""
    centre, normal, inradius = _faces(mesh)
    outer = (distance.signed_distance(centre + 1.5 * normal) > 0) & (distance.signed_distance(centre - 0.3 * normal) < 0)
    big = np.flatnonzero((inradius >= 1.5) & outer)
    big = big[np.argsort(-inradius[big])][:60]
    pairs = []
    for i in big:
        for j in big:
            d = centre[j] - centre[i]
            width = np.linalg.norm(d)
            if normal[i] @ normal[j] < -0.7 and GRIP_MM[0] <= width <= GRIP_MM[1] and (-normal[i]) @ d / width > 0.6:
                pairs.append((i, j))
    order = rng.permutation(len(pairs))
    return [pairs[k] for k in order[:n_pairs]], centre, normal, inradius


def _patch(mesh, distance, centre, inradius):
    return region_from_mesh(mesh, at=centre, radius=min(0.8 * inradius, 6.0), degree=1, distance=distance).region


def mesh_tasks(rng, per_mesh: int, counts=(2, 3, 4), patch=None, meshes=None) -> list[tuple[str, Task]]:
    """``per_mesh`` tasks on each mesh of ``meshes`` (``(file, mm per unit)`` pairs, a
    relative file under ``SHARED``; default ``MESHES``, the shared meshes), ``counts``
    contacts in turn (2, 3 or 4); ``patch(mesh, distance, centre, inradius)`` makes each
    region (default: a planar patch inside the face).  The meshes are drawn from ``rng`` in
    order, so meshes appended after ``MESHES`` leave the shared meshes' tasks unchanged."""
    patch = patch or _patch
    hand = load_builtin_task("guitar-tuning").hand
    out = []
    for file, scale in MESHES if meshes is None else meshes:
        path = SHARED / file  # an absolute file stays itself
        mesh = load_mesh(path, scale)
        distance = MeshDistance(mesh.vertices, mesh.faces)
        pairs, centre, normal, inradius = _opposed_pairs(mesh, distance, rng, 200)
        made, used = 0, set()
        for i, j in pairs:
            if made == per_mesh:
                break
            if i in used:
                continue
            used.add(i)
            others = [q for p, q in pairs if p == i and q != j and np.linalg.norm(centre[q] - centre[j]) > 15.0]
            partners = ([j] + others)[: counts[made % len(counts)] - 1]  # counts in turn (fewer when the faces run out)
            n_fingers = len(partners)
            try:  # a face that another part of the solid covers in part is refused by region_from_mesh
                regions = {"thumb_side": patch(mesh, distance, centre[i], inradius[i])}
                contacts = [Contact("thumb_tip", "thumb_side")]
                for f, face in zip(FINGERS, partners):
                    regions[f"{f}_side"] = patch(mesh, distance, centre[face], inradius[face])
                    contacts.append(Contact(f"{f}_tip", f"{f}_side"))
            except InvalidObject:
                continue
            obj = GraspObject(Path(file).stem, regions, solid=MeshFileSolid(str(path), scale))
            name = f"{Path(file).stem}-{len(contacts)}c-{made}"
            out.append((name, Task(name, hand, obj, tuple(contacts), ("thumb",) + FINGERS[:n_fingers])))
            made += 1
    return out


def _clear(task: Task, result) -> bool:
    if not result.solutions:
        return False
    colliding = replace(task, object=replace(task.object, collisions=True))
    report = evaluate(colliding, result.solutions[0].configuration())
    return max(report.worst("object_collision"), report.worst("pad_collision")) <= 0.5


def _run(task: Task, method: str, collide: bool, time_limit: float):
    from prehension.solvers.complete.search import BranchAndPruneOptions

    variant = replace(task, object=replace(task.object, collisions=collide))
    complete = BranchAndPruneOptions(time_limit_s=time_limit)
    t0 = time.perf_counter()
    if SolveOptions is None:  # older code (--baseline)
        result = solve(variant, method, complete_options=complete)
    else:
        result = solve(variant, SolveOptions(method=method, complete_options=complete))
    return result, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--methods", default="local", help="comma-separated: local, complete, auto (default local)")
    parser.add_argument("--per-mesh", type=int, default=5, help="tasks per shared mesh (default 5: 30 tasks)")
    parser.add_argument("--time-limit", type=float, default=10.0, help="complete solver: seconds per task (default 10)")
    parser.add_argument("--quick", action="store_true", help="built-in tasks and 9 mesh tasks")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--queries", action="store_true", help="only the distance-query speeds, per mesh")
    parser.add_argument("--verify", action="store_true", help="only the cost of verifying each local answer, both ways")
    parser.add_argument("--simulate", action="store_true", help="only simulate's start on each local answer (needs the sim extra)")
    parser.add_argument("--baseline", help="a checkout's src folder: time the local solver with it too, in the same run")
    parser.add_argument("--times-json", action="store_true", help=argparse.SUPPRESS)  # the baseline's subprocess
    args = parser.parse_args()
    console = Console(width=150)
    if args.queries:
        _queries(console)
        return
    rows = [(n, load_builtin_task(n)) for n in builtin_task_names()]
    if SHARED.is_dir():
        rows += mesh_tasks(np.random.default_rng(args.seed), 2 if args.quick else args.per_mesh)[: 9 if args.quick else None]
    _run(rows[0][1], "local", False, args.time_limit)  # the process's first solve loads the compiled code: not timed
    if args.times_json:  # run by --baseline with the older code on the path
        print(json.dumps([_run(task, "local", True, args.time_limit)[1] for _, task in rows]))
        return
    if args.verify:
        _verify_cost(console, rows)
        return
    if args.simulate:
        _simulate_start(console, rows)
        return
    for method in args.methods.split(","):
        times = _table(console, rows, method.strip(), args.time_limit)
        if args.baseline and method.strip() == "local":
            _against_baseline(console, args, times)


def _against_baseline(console: Console, args, times: list[float]) -> None:
    """The same local solves (collisions checked) with the code in ``args.baseline``, timed in a subprocess."""
    cmd = [sys.executable, __file__, "--times-json", "--per-mesh", str(args.per_mesh), "--seed", str(args.seed)]
    cmd += ["--quick"] if args.quick else []
    env = {**os.environ, "PYTHONPATH": str(Path(args.baseline).resolve())}
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
    before = json.loads(out.strip().splitlines()[-1])
    n = len(builtin_task_names())
    for what, now, then in (("built-in tasks", times[:n], before[:n]), (f"all {len(times)} tasks", times, before)):
        console.print(f"local, collisions checked, {what}: median {np.median(now):.3f} s against {np.median(then):.3f} s with "
                      f"{args.baseline} ({np.median(now) / max(np.median(then), 1e-12):.2f}x), total {sum(now):.2f} s against "
                      f"{sum(then):.2f} s ({sum(now) / max(sum(then), 1e-12):.2f}x)")


def _table(console: Console, rows, method: str, time_limit: float) -> list[float]:
    table = Table(title=f"{method} solver: collisions checked vs ignored (clear = every link within 0.5 mm)")
    for col in ("task", "contacts", "checked: solved", "clear", "deepest [mm]", "time [s]", "ignored: solved", "clear", "time [s]"):
        table.add_column(col, justify="left" if col == "task" else "right")
    totals = {True: [0, 0, []], False: [0, 0, []]}
    deep: list[float] = []
    for name, task in rows:
        cells = [name, str(len(task.contacts))]
        for collide in (True, False):
            result, seconds = _run(task, method, collide, time_limit)
            clear = _clear(task, result)
            cells += [result.status, "yes" if clear else "-"]
            if collide:
                depth, where = deepest(task, result.solutions[0]) if result.solutions else (np.nan, "")
                deep.append(depth)
                cells.append(f"{depth:.2f}" + (f" {where}" if depth > 1.0 else ""))
            cells.append(f"{seconds:.3f}")
            totals[collide][0] += result.success
            totals[collide][1] += clear
            totals[collide][2].append(seconds)
        table.add_row(*cells)
    n = len(rows)
    summary = [f"all {n}", ""]
    measured = np.array(deep)[np.isfinite(deep)]
    for collide in (True, False):
        solved, clear, secs = totals[collide]
        summary += [f"{solved}/{n}", f"{clear}/{n}"]
        summary += [f"{int(np.sum(measured > 1.0))} > 1 mm, max {measured.max(initial=0.0):.2f}"] if collide else []
        summary += [f"median {np.median(secs):.3f}"]
    table.add_row(*summary, style="bold")
    console.print(table)
    ratio = np.median(totals[True][2]) / max(np.median(totals[False][2]), 1e-12)
    console.print(f"{method}: median time with collisions / without: {ratio:.2f}x")
    return totals[True][2]


def _verify_cost(console: Console, rows, repeats: int = 5) -> None:
    """Milliseconds of ``make_solution`` (the one residual function, idle fingers settled)
    on each local answer, with the object's collisions checked and ignored (same answer)."""
    from prehension.results import make_solution

    times = {True: [], False: []}
    for _, task in rows:
        result = solve(task, "local")
        if not result.solutions:
            continue
        config = result.solutions[0].configuration()
        for collide in (True, False):
            variant = replace(task, object=replace(task.object, collisions=collide))
            make_solution(variant, config)
            t0 = time.perf_counter()
            for _ in range(repeats):
                make_solution(variant, config)
            times[collide].append((time.perf_counter() - t0) / repeats)
    n = len(times[True])
    console.print(f"make_solution of {n} local answers (mean of {repeats} calls each, median over the answers): collisions checked "
                  f"{1e3 * np.median(times[True]):.2f} ms, ignored {1e3 * np.median(times[False]):.2f} ms")


def _simulate_start(console: Console, rows) -> None:
    """Per solved task: the solver-side depth (re-measured, ``remeasure.py``) beside the
    penetration MuJoCo sees at the start of the physics test, split into the hand's own and
    the object's convex approximation error."""
    from prehension.sim import simulate_grasp

    table = Table(title="simulate's start on the local solver's first answer (MuJoCo = hand's own + approximation, roughly)")
    for col in ("task", "re-measured [mm]", "MuJoCo start [mm]", "hand's own [mm]", "approximation [mm]", "pieces", "held", "time [s]"):
        table.add_column(col, justify="left" if col == "task" else "right")
    depths, starts, hands, approx = [], [], [], []
    for name, task in rows:
        result = solve(task, "local")
        if not result.solutions:
            continue
        t0 = time.perf_counter()
        report = simulate_grasp(task, result.solutions[0])
        seconds = time.perf_counter() - t0
        depth, where = deepest(task, result.solutions[0])
        hand = report.hand_penetration_mm or 0.0
        depths.append(depth)
        starts.append(report.initial_penetration_mm)
        hands.append(hand)
        approx.append(report.approximation_mm)
        table.add_row(name, f"{depth:.2f} ({where})" if where else f"{depth:.2f}", f"{report.initial_penetration_mm:.2f}",
                      f"{hand:.2f}", f"{report.approximation_mm:.2f}", str(report.object_pieces), f"{report.held}/6",
                      f"{seconds:.1f}")  # fmt: skip
    n = len(starts)
    at_most = [sum(np.asarray(x) <= 1.0) for x in (depths, starts, hands, approx)]
    table.add_row(f"<= 1 mm of {n} solved", *[f"{k}/{n}" for k in at_most], "", "", "", style="bold")
    console.print(table)


def _queries(console: Console, n: int = 300) -> None:
    """Microseconds per query on each mesh: signed distance of a point, distance of a
    40 mm segment, and a capsule depth, at random places within 20 mm of the mesh's box."""
    table = Table(title=f"distance queries (median of 3 runs of {n} queries each)")
    for col in ("mesh", "faces", "sign", "point [us]", "segment [us]", "capsule depth [us]"):
        table.add_column(col, justify="left" if col == "mesh" else "right")
    meshes = [(f"built-in {k}", load_builtin_task(t).object.surface) for k, t in
              (("teapot", "teapot-service"), ("scalpel", "scalpel-handling"), ("guitar", "guitar-tuning"))]
    meshes += [(file, load_mesh(SHARED / file, scale)) for file, scale in MESHES if (SHARED / file).is_file()]
    rng = np.random.default_rng(0)
    for name, mesh in meshes:
        md = MeshDistance(mesh.vertices, mesh.faces)
        lo, hi = mesh.vertices.min(0) - 20, mesh.vertices.max(0) + 20
        a = rng.uniform(lo, hi, (n, 3))
        d = rng.normal(size=(n, 3))
        b = a + 40 * d / np.linalg.norm(d, axis=1, keepdims=True)
        r = np.full(n, 10.0)
        md.capsule_depth(a[:10], b[:10], r[:10])  # compile / load the cache
        cells = []
        for fn in (lambda: md.signed_distance(a), lambda: md.segment_distance(a, b), lambda: md.capsule_depth(a, b, r)):
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                fn()
                times.append(time.perf_counter() - t0)
            cells.append(f"{1e6 * np.median(times) / n:.1f}")
        sign = "winding" if md.arrays.robust_sign else "pseudonormal"
        table.add_row(name, str(len(mesh.faces)), sign, *cells)
    console.print(table)


if __name__ == "__main__":
    main()
