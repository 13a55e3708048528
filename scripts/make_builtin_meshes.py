"""Write the closed meshes of the built-in objects (src/prehension/tasks/builtin/meshes/*.ply).

Usage: python scripts/make_builtin_meshes.py [--check]

The meshes are made by :mod:`prehension.objects.builtin_shapes` from primitives and the
contact regions of the built-in task files (every task that names the object), so that
the regions lie on the mesh.  ``--check`` writes nothing and exits 1 when a shipped file
differs from what would be written by more than 0.01 mm.
"""

from __future__ import annotations

import sys

from prehension.objects.builtin_shapes import BUILTIN_OBJECTS, mesh_difference_mm, write_ply
from prehension.tasks.library import builtin_mesh_dir, builtin_regions


def main(argv: list[str]) -> int:
    check = "--check" in argv
    regions = builtin_regions()
    status = 0
    for name, make in BUILTIN_OBJECTS.items():
        mesh = make(regions[name])
        path = builtin_mesh_dir() / f"{name}.ply"
        if check:
            diff = mesh_difference_mm(mesh, path)
            print(f"{name}: {diff:.4f} mm from {path}")
            status |= diff > 0.01
        else:
            write_ply(mesh, path)
            print(f"{name}: {len(mesh.vertices)} vertices, {len(mesh.faces)} faces -> {path}")
    return int(status)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
