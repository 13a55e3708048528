"""Grasps that hold: the first solution's epsilon against ``solve --best 5``'s, and its cost.

Tasks, in three groups:

- **generated, shared meshes**: 3- and 4-fingertip tasks on every mesh of ``../shared/objects``
  (the bunny at 100 mm per unit, the five random solids at 10 mm per unit; the thumb against
  index, middle and ring on faces whose normals face each other across the object, seeded
  random; each region the largest patch of radius ``--region-mm``, 3/4 or 1/2 of it fitted by
  ``region_from_mesh``, degree 2, that stays within 0.3 mm of the surface, else a planar patch
  inside the face: the random solids are coarse polyhedra, so most of their regions are small);
- **generated, built-in objects**: the same generator, hand, region maker and ``--per-mesh`` on
  the meshes of the built-in tasks' objects (guitar, scalpel, teapot: their paths are taken from
  the built-in tasks), drawn after the shared meshes from the same seeded generator so the shared
  tasks are those of earlier tables.  Only the guitar yields tasks: the scalpel is about 18 mm
  thick (below ``objects.GRIP_MM``'s 25 mm), and the teapot's largest opposed faces are those of
  its body, 165-176 mm apart (above its 95 mm); a mesh whose faces run out makes 2-contact tasks,
  which are left out, so the guitar gives about one 3-contact task a draw;
- **authored**: the built-in tasks and the examples of ``examples/quality`` (as written, the same
  in every draw; those with 3 or 4 contacts are judged).

``--meshes-only``: the generated tasks alone (both groups); ``--shared-only``: those on
``../shared/objects`` alone (the tasks of the tables before the built-in objects were added).

Per task (friction 0.6, hard fingers unless ``--torsion``): the Ferrari-Canny epsilon of
the first solution (``prehension solve --method local``), of the best of ``solve --best
5 --ascent-steps 0`` (the distinct solutions of the random starts as found, ranked) and of
``solve --best 5`` (each of them then moved along its solution set by the quality ascent,
re-verified at every step), and the time of ``--best 5`` (wall clock and CPU of this
process: one core); the pre-grasp of the first solution (15 mm asked, 10 or 5 mm when
that collides: collision-free or not, the distance used, the least and largest stand-off
of its fingers).  With ``--physics`` (needs MuJoCo; 2-8 s per simulated grasp): the
physics test of the first solution with the uniform squeeze (every contact 10 mm in,
DexGraspBench's), the balanced one (depths in proportion to balanced forces), the forces
one (targets whose actuator torques press with balanced forces) and the push one (the
default: the balanced forces whose squeeze resists the largest push), and the answer of
``solve --hold`` with the two squeezes of ``--squeezes`` (default ``push,forces``: the
default, then the one before it; which candidate held, after how many physics tests)
(the candidates of ``--best 5``, then -- when none holds -- the
force-closure search within ``prehension.hold.CLOSURE_TIME_S``: the regions alone, aimed
starts, the complete solver): which candidate held, or "none", and "PROVEN" where the
search proved that the task's regions admit no force-closure grasp (friction 0.6, torsion
20 mm: the physics test's; "(regions alone)": no choice of points in them is).
Those tasks are counted apart in the summary (never dropped): the hold rate is given over
every judged task and over the tasks not so proven.  Summary: the median ratio best/first over the tasks whose first solution is
force closure, how many tasks go from not force closure to force closure, the median and
largest time, and the hold rates over the solved 3- and 4-contact tasks (``--hold``'s: for the
generated tasks, split into shared meshes and built-in objects, the authored tasks, and all).

    python benchmarks/hold.py                      # every task (~40), a few minutes
    python benchmarks/hold.py --quick              # 2 tasks per mesh, no authored tasks
    python benchmarks/hold.py --physics --regions user --meshes-only --seed 1   # a draw of generated tasks
    python benchmarks/hold.py --torsion 5          # soft fingers
    python benchmarks/hold.py --physics --tasks bunny --limit 4    # the physics columns, in parts
    python benchmarks/hold.py --per-candidate --best 10            # every candidate's epsilon and verdict

``--per-candidate`` (needs MuJoCo): per task, every candidate of ``--best N`` in rank order
with its epsilon (hard fingers, and soft fingers with the physics test's 20 mm torsion),
the squeeze's normal forces and the push margin (:mod:`prehension.sim.push`), the pushes
it held and why the others failed (moved / turned how far), and how often
each measure orders two candidates of one task as the physics test does (concordant
pairs among those the test tells apart): is there a measure to rank ``--hold``'s
candidates by?
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

sys.path.insert(0, str(Path(__file__).resolve().parent))
from objects import MESHES, SHARED, _patch, mesh_tasks  # noqa: E402  (a sibling benchmark script)

from prehension.ascent import AscentOptions  # noqa: E402
from prehension.best import BestOptions, solve_best  # noqa: E402
from prehension.errors import PrehensionError  # noqa: E402
from prehension.hold import hold_first  # noqa: E402
from prehension.pregrasp import pregrasp  # noqa: E402
from prehension.objects.pick import region_from_mesh  # noqa: E402
from prehension.quality import QualityOptions, grasp_quality  # noqa: E402
from prehension.solve import SolveOptions, solve  # noqa: E402
from prehension.tasks.library import builtin_task_names, load_builtin_task, resolve_task  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "quality"
FIRST_SQUEEZES = ("uniform", "balanced", "forces", "push")  # the first solution's physics test with each
HOLD_SQUEEZES = ("push", "forces")  # --hold's: the default squeeze, then the one before it


def _fitted_patch(radius_mm: float):
    """The largest region -- degree 2, radius ``radius_mm``, then 3/4 and 1/2 of it -- that
    fits the surface within 0.3 mm (on a 7 x 7 grid of its parameters); else the planar
    patch inside the face."""
    grid = np.stack(np.meshgrid(np.linspace(0, 1, 7), np.linspace(0, 1, 7)), axis=-1).reshape(-1, 2)

    def patch(mesh, distance, centre, inradius):
        for radius in (radius_mm, 0.75 * radius_mm, 0.5 * radius_mm):
            try:
                region = region_from_mesh(mesh, at=centre, radius=radius, degree=2, distance=distance).region
            except PrehensionError:  # not a height field there
                continue
            if np.max(np.abs(distance.signed_distance(region.evaluate(grid)[0]))) <= 0.3:
                return region
        return _patch(mesh, distance, centre, inradius)

    return patch


USER_TOLERANCE_MM = 0.5  # the largest deviation `prehension region` accepts without a warning (an object's default surface tolerance)


def _user_patch(radius_mm: float):
    """The region a user gets from ``prehension region --at CENTRE --radius R`` (degree 2)
    with the largest ``R`` of ``radius_mm``, 3/4, 1/2 and 1/3 of it that the command
    accepts without a warning (largest deviation from the mesh at most 0.5 mm: the
    object's default surface tolerance); else the planar patch inside the face."""

    def patch(mesh, distance, centre, inradius):
        for radius in (radius_mm, 0.75 * radius_mm, 0.5 * radius_mm, radius_mm / 3):
            try:
                picked = region_from_mesh(mesh, at=centre, radius=radius, degree=2, distance=distance)
            except PrehensionError:  # not a height field there
                continue
            if picked.max_deviation_mm <= USER_TOLERANCE_MM:
                return picked.region
        return _patch(mesh, distance, centre, inradius)

    return patch


REGION_MAKERS = {"strict": _fitted_patch, "user": _user_patch}


def _builtin_meshes() -> list[tuple[str, float]]:
    """The built-in objects' meshes as ``(path, mm per unit)``, each once, in the order of the built-in tasks."""
    meshes = []
    for name in builtin_task_names():
        solid = load_builtin_task(name).object.solid
        if (solid.path, solid.scale) not in meshes:
            meshes.append((solid.path, solid.scale))
    return meshes


def _group(task) -> str:
    """Which group a generated task belongs to: its mesh under ``../shared/objects`` or a built-in object's."""
    return "shared" if Path(task.object.solid.path).resolve().is_relative_to(SHARED.resolve()) else "built-in object"


def _tasks(args) -> list:
    """``(group, task)`` pairs: the generated 3- and 4-fingertip tasks on the shared meshes
    (group ``shared``; first, so the seeded draw of them is unchanged) and on the built-in
    objects' meshes (``built-in object``; not with ``--shared-only``), then the authored
    tasks (``authored``: the built-in tasks and ``examples/quality``; not with ``--meshes-only``,
    ``--shared-only`` or ``--quick``)."""
    meshes = (MESHES if SHARED.is_dir() else []) + ([] if getattr(args, "shared_only", False) else _builtin_meshes())
    made = mesh_tasks(np.random.default_rng(args.seed), 2 if args.quick else args.per_mesh, counts=(3, 4),
                      patch=REGION_MAKERS[getattr(args, "regions", "strict")](args.region_mm), meshes=meshes)  # fmt: skip
    rows = [(_group(task), task) for _, task in made if len(task.contacts) >= 3]  # a mesh short of opposed faces gives fewer
    if not (args.quick or getattr(args, "meshes_only", False) or getattr(args, "shared_only", False)):
        rows += [("authored", load_builtin_task(n)) for n in builtin_task_names()]
        rows += [("authored", resolve_task(str(p))) for p in sorted(EXAMPLES.glob("*.yaml"))]
    return rows


def _epsilon(task, result, quality) -> float | None:
    return grasp_quality(task, result.solutions[0], quality).epsilon if result.solutions else None


def _physics(task, first, best, squeezes=HOLD_SQUEEZES) -> dict:
    """The first solution's physics verdict with each squeeze, and ``--hold``'s answer with
    the squeezes ``squeezes`` (the default's, then the one before it)."""
    from prehension.sim import SimOptions, simulate_grasp

    out = {}
    for kind in FIRST_SQUEEZES:
        r = simulate_grasp(task, first.solutions[0], SimOptions(squeeze=kind)) if first.solutions else None
        out[kind] = None if r is None else (r.success, "rejected" if r.rejected else f"{r.held}/6")
    for key, kind in zip(("hold", "hold_before"), squeezes):
        out[key], out[f"{key}_proven"], out[f"{key}_s"] = _hold(best, SimOptions(squeeze=kind)) if best.solutions else (None, False, None)
    out["proven"] = out["hold_proven"]
    return out


def _hold(best, options) -> tuple:
    """``--hold``'s first answer with the physics test ``options``: ``((held, what), proven, seconds)``."""
    started = time.perf_counter()
    hold = hold_first(best, options)
    seconds = time.perf_counter() - started
    tried, closure = hold.result.stats["hold"]["tried"], hold.closure
    n = hold.result.stats["hold"]["candidates"]  # solve --best's and the force-closure search's
    said = f"#{tried[-1]['candidate'] + 1} of {n} ({len(tried)} tested)" if hold.held else f"none of {n}"
    if closure is not None:
        extra = hold.held and tried[-1]["candidate"] >= len(best.solutions)  # a grasp of the force-closure search held
        method = closure.get("method")
        said += {"infeasible": "; PROVEN: no force-closure grasp" + (" (regions alone)" if method == "regions" else ""),
                 "gave_up": "; complete: none in time",
                 "solved": (" (aimed starts')" if method == "aimed" else " (complete solver's)") if extra else ""}.get(closure["status"], "")  # fmt: skip
    return (hold.held, said), hold.proven_none, seconds


def _pre(p) -> str:
    """The pre-grasp of the first solution: collision-free or not, and the fingers' smallest stand-off."""
    return "-" if p is None else (f"{'free' if p.collision_free else 'COLLIDES'} at {p.back_off_mm:g}: "
                                  f"{p.reached_mm.min():.1f}-{p.reached_mm.max():.1f}")  # fmt: skip


def _verdict(v) -> str:
    return "-" if v is None else ("holds " if v[0] else "drops ") + v[1]


def _measure(task, quality: QualityOptions, n: int, seed: int, physics: bool, squeezes=HOLD_SQUEEZES) -> dict:
    first = solve(task, SolveOptions(method="local", seed=seed))
    found = solve_best(task, BestOptions(n=n, quality=quality, ascent=None), SolveOptions(method="local", seed=seed))
    wall, cpu = time.perf_counter(), time.process_time()
    best = solve_best(task, BestOptions(n=n, quality=quality, ascent=AscentOptions()), SolveOptions(method="local", seed=seed))
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    steps = [a for a in best.stats["best"]["ascent"] if a is not None]
    return {"first": _epsilon(task, first, quality), "found": _epsilon(task, found, quality),
            "best": _epsilon(task, best, quality), "wall": wall, "cpu": cpu,
            "steps": f"{sum(a['accepted'] for a in steps)}/{sum(a['tried'] for a in steps)}", "contacts": len(task.contacts),
            "name": task.name,
            "physics": _physics(task, first, best, squeezes) if physics else None,
            "pregrasp": pregrasp(task, first.solutions[0]) if first.solutions else None}  # fmt: skip


def _per_candidate(console: Console, tasks, args) -> None:
    """Every candidate of ``--best N``: epsilon (hard, soft 20 mm), physics verdict; then the concordance summary."""
    from itertools import combinations

    from prehension.sim import SimOptions, simulate_grasp

    from prehension.sim.push import push_margin, squeeze_forces

    soft = QualityOptions(torsion_mm=SimOptions().torsion_mm)
    keys = ("epsilon", "epsilon, soft", "soft epsilon x squeeze normal force", "push margin")
    concordant = {key: [0, 0] for key in keys}
    for task in tasks:
        best = solve_best(task, BestOptions(n=args.best), SolveOptions(method="local", seed=args.seed))
        rows = []
        for k, s in enumerate(best.solutions):
            r = simulate_grasp(task, s, SimOptions())
            failed = ", ".join(f"{p.direction} {p.shift_mm:.0f} mm {p.turn_deg:.0f} deg" for p in r.pushes if not p.held)
            eps_soft, push = grasp_quality(task, s, soft).epsilon, push_margin(task, s, SimOptions())
            rows.append((grasp_quality(task, s, QualityOptions()).epsilon, eps_soft, eps_soft * push.normal.sum(),
                         push.margin, r.held, "rejected" if r.rejected else failed))  # fmt: skip
            f = squeeze_forces(task, s, SimOptions())
            console.print(f"{task.name} #{k + 1}: epsilon {rows[-1][0]:.4f}, soft {rows[-1][1]:.4f}, squeeze normal "
                          f"{push.normal.round(1)} N (net {np.linalg.norm(f.sum(0)):.1f} N), push margin {push.margin:.3f}, held {r.held}/6"
                          + (f"; failed: {rows[-1][5]}" if rows[-1][5] else ""))  # fmt: skip
        for i, j in combinations(range(len(rows)), 2):
            for col, key in enumerate(keys):
                if rows[i][4] != rows[j][4] and rows[i][col] != rows[j][col]:
                    concordant[key][int((rows[i][4] - rows[j][4]) * (rows[i][col] - rows[j][col]) < 0)] += 1
    for key, (same, other) in concordant.items():
        console.print(f"{key}: orders {same} of {same + other} candidate pairs the physics test tells apart as the test does")


def _fmt(eps) -> str:
    return "-" if eps is None else f"{eps:.4f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--per-mesh", type=int, default=4, help="tasks per shared mesh, 3 and 4 contacts in turn (default 4)")
    parser.add_argument("--region-mm", type=float, default=12.0, help="radius of each mesh region [mm] (default 12)")
    parser.add_argument("--regions", choices=tuple(REGION_MAKERS), default="strict",
                        help="how mesh regions are made: strict (default; within 0.3 mm on a 7x7 grid, else the planar "
                             "patch inside one face) or user (what `prehension region --radius R` accepts without a "
                             "warning: deviation <= 0.5 mm, R = 12, 9, 6, 4 mm)")  # fmt: skip
    parser.add_argument("--meshes-only", action="store_true",
                        help="only the generated tasks (../shared/objects and the built-in objects; no authored tasks)")
    parser.add_argument("--shared-only", action="store_true",
                        help="only the generated tasks on ../shared/objects (the draw of earlier tables)")
    parser.add_argument("--per-candidate", action="store_true",
                        help="every candidate of --best N: epsilon and physics verdict (needs MuJoCo; the docstring)")  # fmt: skip
    parser.add_argument("--best", type=int, default=5, help="N of --best N (default 5)")
    parser.add_argument("--torsion", type=float, default=0.0, help="soft fingers: torsional friction [mm] (default 0)")
    parser.add_argument("--quick", action="store_true", help="2 tasks per mesh, no authored tasks")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--physics", action="store_true", help="the physics columns (needs MuJoCo; 2-8 s per grasp)")
    parser.add_argument("--tasks", default=None, metavar="TEXT", help="only the tasks whose name contains TEXT")
    parser.add_argument("--skip", type=int, default=0, metavar="K", help="skip the first K tasks (run in parts)")
    parser.add_argument("--limit", type=int, default=None, metavar="N", help="at most N tasks")
    parser.add_argument("--squeezes", type=lambda s: tuple(s.split(",")), default=HOLD_SQUEEZES, metavar="A,B",
                        help="--hold's squeeze kinds compared: the default's, then the one before it (default push,forces)")
    args = parser.parse_args()
    if len(args.squeezes) != 2:
        parser.error("--squeezes takes two kinds, e.g. push,forces")
    quality = QualityOptions(torsion_mm=args.torsion)
    console = Console(width=150)
    table = Table(title=f"first solution vs --best {args.best} (epsilon, mu {quality.friction:g}, "
                        f"{'torsion %g mm' % args.torsion if args.torsion else 'hard fingers'})")  # fmt: skip
    for col in ("task", "contacts", "first", f"best {args.best} as found", f"best {args.best}", "ratio", "ascent steps",
                "time [s] wall", "cpu", "pre-grasp of first [mm]", "first: uniform squeeze", *(f"first: {k}" for k in FIRST_SQUEEZES[1:]),
                f"--hold ({args.squeezes[1]})", f"--hold ({args.squeezes[0]})"):  # fmt: skip
        table.add_column(col, justify="left" if col == "task" else "right")
    rows = []
    tasks = [(g, t) for g, t in _tasks(args) if args.tasks is None or args.tasks in t.name][args.skip:]
    if args.per_candidate:
        _per_candidate(console, [t for _, t in tasks[: args.limit] if len(t.contacts) in (3, 4)], args)
        return
    for group, task in tasks[: args.limit]:
        m = _measure(task, quality, args.best, args.seed, args.physics, args.squeezes) | {"group": group}
        rows.append(m)
        ratio = m["best"] / m["first"] if m["first"] and m["best"] is not None else None
        table.add_row(task.name, str(len(task.contacts)), _fmt(m["first"]), _fmt(m["found"]), _fmt(m["best"]),
                      "-" if ratio is None else f"{ratio:.2f}", m["steps"], f"{m['wall']:.2f}", f"{m['cpu']:.2f}", _pre(m["pregrasp"]),
                      *(_verdict((m["physics"] or {}).get(k)) for k in (*FIRST_SQUEEZES, "hold_before", "hold")))  # fmt: skip
        console.file.flush()
    console.print(table)
    _summary(console, rows, args.squeezes)


def _hold_rate(judged: list, key: str) -> tuple[int, int, int]:
    """``(proven, held, rest)``: of ``judged``, the tasks proven to admit no force-closure
    grasp, and of the others (judged by ``key``) how many held."""
    proven = sum(1 for m in judged if m["physics"][f"{key}_proven"])
    rest = [m for m in judged if not m["physics"][f"{key}_proven"] and m["physics"][key] is not None]
    return proven, sum(m["physics"][key][0] for m in rest), len(rest)


def _hold_summary(console: Console, judged: list, squeezes) -> None:
    """``--hold`` counted two ways, with each squeeze: over every judged task, and over the
    tasks whose regions are not proven to admit no force-closure grasp (those are reported
    apart, never dropped); for the generated tasks (split: shared meshes, built-in objects),
    the authored tasks and all."""
    for key, what in (("hold", f"{squeezes[0]} squeeze (default)"), ("hold_before", f"{squeezes[1]} squeeze (before)")):
        groups = {"generated": [m for m in judged if m["group"] != "authored"],
                  "authored": [m for m in judged if m["group"] == "authored"], "all": judged}  # fmt: skip
        for name, members in groups.items():
            if not members:
                console.print(f"--hold, {what}, {name} tasks: none judged in this run")
                continue
            proven, held, rest = _hold_rate(members, key)
            split = ""
            if name == "generated":
                parts = (("shared meshes", "shared"), ("built-in objects", "built-in object"))
                rates = [(label, _hold_rate([m for m in members if m["group"] == g], key)) for label, g in parts]
                split = " (" + "; ".join(f"{label}: {h}/{r}, {p} proven" for label, (p, h, r) in rates) + ")"
            console.print(f"--hold, {what}, {name} tasks: {proven} of {len(members)} proven to admit no force-closure "
                          f"grasp (the physics test's friction and torsion; none of them held); of the other {rest}, "
                          f"the first answer holds in {held} ({held / max(rest, 1):.0%}){split}")  # fmt: skip
        times = [m["physics"][f"{key}_s"] for m in judged if m["physics"][f"{key}_s"] is not None]
        if times:
            console.print(f"--hold wall time per task, {what} (physics tests and the force-closure search): median "
                          f"{statistics.median(times):.1f} s, max {max(times):.1f} s")  # fmt: skip


def _summary(console: Console, rows: list, squeezes=HOLD_SQUEEZES) -> None:
    closed = [m for m in rows if m["first"] and m["best"] is not None]
    opened = sum(1 for m in rows if m["first"] == 0.0 and (m["best"] or 0.0) > 0.0)
    still = sum(1 for m in rows if m["first"] == 0.0 and m["best"] == 0.0)
    solved = [m for m in rows if m["best"] is not None]
    if closed:
        ratios = [m["best"] / m["first"] for m in closed]
        found = [m["found"] / m["first"] for m in closed]
        console.print(f"median epsilon ratio, --best vs first, over the {len(closed)} tasks whose first solution is force "
                      f"closure: {statistics.median(ratios):.2f} (as found, without the ascent: {statistics.median(found):.2f})")  # fmt: skip
    console.print(f"first solution not force closure: {opened} become force closure with --best, {still} do not")
    pres = [m["pregrasp"] for m in rows if m["pregrasp"] is not None]
    if pres:
        full = np.concatenate([p.reached_mm >= p.back_off_mm - 0.01 for p in pres])
        console.print(f"pre-grasps of the {len(pres)} first solutions (15 mm asked, 10 or 5 when that collides): "
                      f"{sum(p.collision_free for p in pres)} collision-free ({sum(p.back_off_mm == 15.0 for p in pres)} "
                      f"at 15 mm); {np.mean(full):.0%} of the fingers back off the whole distance used")  # fmt: skip
    judged = [m for m in solved if m["physics"] is not None and m["contacts"] in (3, 4)]
    if judged:
        parts = []
        for key, what in (*((k, f"first solution, {k} squeeze") for k in FIRST_SQUEEZES),
                          ("hold_before", f"first answer of --hold, {squeezes[1]} squeeze"),
                          ("hold", f"first answer of --hold ({squeezes[0]} squeeze)")):  # fmt: skip
            got = [m["physics"][key] for m in judged if m["physics"][key] is not None]
            parts.append(f"{what}: {sum(v[0] for v in got)}/{len(got)}")
        console.print(f"holds (all six pushes) over the {len(judged)} solved 3- and 4-contact tasks: " + "; ".join(parts))
        for m in judged:
            console.print(f"  --hold, {m['name']}: {_verdict(m['physics']['hold'])} ({squeezes[1]} squeeze: "
                          f"{_verdict(m['physics']['hold_before'])})")  # fmt: skip
        _hold_summary(console, judged, squeezes)
    unsolved = [m for m in rows if m["best"] is None]
    console.print(f"tasks --best leaves unsolved: {len(unsolved)} of {len(rows)} (left out of the rates above): "
                  + (", ".join(f"{m['name']} ({m['group']})" for m in unsolved) or "none"))  # fmt: skip
    if solved:
        cpu = [m["cpu"] for m in solved]
        wall = [m["wall"] for m in solved]
        console.print(f"--best time over {len(solved)} solved tasks: CPU median {statistics.median(cpu):.2f} s, "
                      f"max {max(cpu):.2f} s; wall median {statistics.median(wall):.2f} s, max {max(wall):.2f} s")  # fmt: skip


if __name__ == "__main__":
    main()
