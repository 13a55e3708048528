"""``prehension simulate``: seconds per grasp, cold and warm, and where the physics scene starts.

Rows: one solved task per mesh of ../shared/objects (the tasks of ``objects.py``), one per
built-in object, and a procedural noisy blob of 128,160 triangles (a UV sphere of 180 x 180
segments, closed, with twelve seeded bumps and dents, ~70 mm across; two fingertip patches at its
ends along x; ``--blob-segments`` sets its size: about 4 n^2 triangles).  Each
row solves the task (local solver), writes the result, then runs ``prehension simulate``
twice as a user would, each in a new process: *cold* with an empty geometry cache (the
convex decomposition computed), *after solve* with the cache that this process's solves
left (the solver's mesh and distance structure, as ``prehension solve`` leaves them for a
user's first ``simulate``: only the decomposition computed), *warm* with the cache the
cold run left (read back); wall seconds, and CPU seconds of the process (user + system,
every thread: what the load of the machine does not change).
Columns: the penetration MuJoCo sees at the start, the hand's own penetration into the
solver's mesh, the object's approximation error next to the hand, the number of pieces.

The last row is the blob with 200 triangles removed (an open mesh, ``collisions: false``):
``simulate`` must refuse it with a message, not hang.

    python benchmarks/simulate.py            # every row
    python benchmarks/simulate.py --quick    # the blob, a random solid and the guitar
    python benchmarks/simulate.py --blob     # the blob and the open blob only
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from prehension.objects.model import GraspObject
from prehension.objects.pick import region_from_mesh
from prehension.objects.solid import MeshFileSolid
from prehension.results import write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solve import solve
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Contact, Task

sys.path.insert(0, str(Path(__file__).resolve().parent))
from objects import SHARED, mesh_tasks  # noqa: E402 - the shared-mesh tasks of objects.py

BUILTIN = ("teapot-service", "guitar-tuning", "scalpel-handling")


BLOB_SEGMENTS = 180  # a UV sphere of 180 x 180 segments: 128,160 triangles (the issue: a mesh of >= 100k faces)


def blob_obj(path: Path, seed: int = 0, radius: float = 35.0, hole: int = 0, segments: int = BLOB_SEGMENTS) -> Path:
    """Write the noisy blob (OBJ, mm; ``hole`` triangles removed) to ``path``: a closed UV
    sphere of ``segments`` x ``segments`` (about ``4 segments^2`` triangles), twelve seeded
    bumps and dents."""
    import trimesh

    sphere = trimesh.creation.uv_sphere(count=[segments, segments])
    rng = np.random.default_rng(seed)
    v = sphere.vertices
    r = np.ones(len(v))
    for _ in range(12):
        c = rng.normal(size=3)
        c /= np.linalg.norm(c)
        r += rng.uniform(-0.25, 0.35) * np.exp(-np.sum((v - c) ** 2, 1) / 0.15)
    faces = sphere.faces[hole:]
    trimesh.Trimesh(v * (radius * r)[:, None], faces, process=False).export(path)
    return path


def blob_task(path: Path, closed: bool = True) -> Task:
    """Thumb against index across the blob's x extent (degree-2 patches of radius 6 mm)."""
    from prehension.objects.distance import MeshDistance
    from prehension.objects.mesh_io import load_mesh

    mesh = load_mesh(path, 1.0, closed=closed)
    distance = MeshDistance(mesh.vertices, mesh.faces)
    ends = mesh.vertices[[np.argmin(mesh.vertices[:, 0]), np.argmax(mesh.vertices[:, 0])]]
    regions = {name: region_from_mesh(mesh, at=p, radius=6.0, degree=2, distance=distance).region
               for name, p in zip(("thumb_side", "index_side"), ends)}  # fmt: skip
    obj = GraspObject("blob", regions, solid=MeshFileSolid(str(path), 1.0), collisions=closed)
    hand = load_builtin_task("guitar-tuning").hand
    contacts = (Contact("thumb_tip", "thumb_side"), Contact("index_tip", "index_side"))
    return Task("blob-2c" if closed else "open-blob-2c", hand, obj, contacts, ("thumb", "index"))


def _cpu_of_children() -> float:
    """CPU seconds (user + system) of every finished child process so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _simulate(result: Path, cache: Path) -> tuple[float, float, int, dict | None, str]:
    """One ``prehension simulate`` process: ``(wall seconds, CPU seconds, exit code, first
    grasp's outcome, stderr)``; the CPU time (every thread of the process) does not depend
    on what else the machine runs, the wall time does."""
    out = result.with_suffix(".physics.json")
    out.unlink(missing_ok=True)
    env = dict(os.environ, PREHENSION_CACHE_DIR=str(cache))
    t0, c0 = time.perf_counter(), _cpu_of_children()
    run = subprocess.run([sys.executable, "-m", "prehension.cli", "simulate", str(result), "--solution", "0", "-o", str(out)],
                         env=env, capture_output=True, text=True, timeout=1800)  # fmt: skip
    seconds, cpu = time.perf_counter() - t0, _cpu_of_children() - c0
    grasp = json.loads(out.read_text())["grasps"][0] if out.is_file() else None
    return seconds, cpu, run.returncode, grasp, run.stderr.strip().splitlines()[-1] if run.stderr.strip() else ""


def rows(quick: bool, folder: Path, segments: int, blob_only: bool = False) -> list[tuple[str, Task]]:
    out = [("blob", blob_task(blob_obj(folder / "blob.obj", segments=segments)))]
    if blob_only:
        return out
    if SHARED.is_dir():
        shared = mesh_tasks(np.random.default_rng(0), 1)
        out += shared[1:2] if quick else shared
    out += [(name, load_builtin_task(name)) for name in (BUILTIN[1:2] if quick else BUILTIN)]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the blob, one random solid and the guitar")
    parser.add_argument("--blob", action="store_true", help="the blob and the open blob only")
    parser.add_argument("--blob-segments", type=int, default=BLOB_SEGMENTS,
                        help=f"the blob's UV segments (default {BLOB_SEGMENTS}: 128,160 triangles)")  # fmt: skip
    args = parser.parse_args()
    console = Console(width=160)
    table = Table(title="prehension simulate: seconds per grasp (each run a new process) and the start")
    for col in ("task", "triangles", "cold [s]", "CPU", "after solve [s]", "CPU", "warm [s]", "CPU", "exit", "MuJoCo start [mm]",
                "hand's own [mm]", "approximation [mm]", "pieces"):  # fmt: skip
        table.add_column(col, justify="left" if col == "task" else "right")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        solved = folder / "cache-of-solve"  # what this process's solves store (the solver's geometry), as a user's solve would
        os.environ["PREHENSION_CACHE_DIR"] = str(solved)
        for name, task in rows(args.quick, folder, args.blob_segments, args.blob):
            result = solve(task, "local")
            faces = str(len(task.object.surface.faces))
            if not result.solutions:
                table.add_row(name, faces, *("-",) * 6, "unsolved", "", "", "", "")
                continue
            path = folder / f"{name.split()[0]}.json"
            write_result(result, path, quality_entries(result), approach_entries_of(result))
            cache, after = folder / f"cache-{name.split()[0]}", folder / f"after-{name.split()[0]}"
            after.mkdir()
            if solved.is_dir():
                shutil.copytree(solved, after, dirs_exist_ok=True)
            runs = [_simulate(path, cache), _simulate(path, after), _simulate(path, cache)]  # cold, after solve, warm
            _, _, code, grasp, err = runs[-1]
            times = [f"{x:.1f}" for run in runs for x in run[:2]]
            if grasp is None:
                table.add_row(name, faces, *times, str(code), err[:60], "", "", "")
                continue
            hand = grasp["hand_penetration_mm"]
            table.add_row(name, faces, *times, str(code), f"{grasp['initial_penetration_mm']:.2f}",
                          "-" if hand is None else f"{hand:.2f}", f"{grasp['approximation_mm']:.2f}", str(grasp["object_pieces"]))  # fmt: skip
        open_task = blob_task(blob_obj(folder / "open.obj", hole=200, segments=args.blob_segments), closed=False)
        result = solve(open_task, "local")
        if result.solutions:
            write_result(result, folder / "open.json", quality_entries(result), approach_entries_of(result))
            seconds, cpu, code, _, err = _simulate(folder / "open.json", folder / "cache-open")
            table.add_row("open blob (200 removed)", str(len(open_task.object.surface.faces)), f"{seconds:.1f}", f"{cpu:.1f}",
                          *("",) * 4, str(code), err[:80])  # fmt: skip
    console.print(table)


if __name__ == "__main__":
    main()
