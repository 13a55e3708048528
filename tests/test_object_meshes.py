"""Objects from mesh files and primitives: formats, units, validation, regions on the surface."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.errors import InvalidObject, InvalidTask
from prehension.geometry.regions import BezierRegion, PointRegion
from prehension.objects.mesh_io import load_mesh
from prehension.objects.model import GraspObject
from prehension.objects.solid import MeshFileSolid, PrimitiveSolid
from prehension.objects.meshes import Box, Sphere
from prehension.tasks.library import builtin_mesh_dir, builtin_regions, builtin_task_names, load_builtin_task
from prehension.tasks.yaml_io import dump_task, load_task, loads_task, task_to_dict

trimesh = pytest.importorskip("trimesh")


def _box_file(tmp_path, suffix, extents=(0.04, 0.02, 0.03)):
    path = tmp_path / f"box{suffix}"
    trimesh.creation.box(extents=extents).export(str(path))
    return path


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".off", ".glb"])
def test_every_format_loads_in_mm(tmp_path, suffix):
    mesh = load_mesh(_box_file(tmp_path, suffix), 1000.0)  # metres -> mm
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [40, 20, 30], atol=1e-6)
    tri = trimesh.Trimesh(mesh.vertices, mesh.faces)
    assert tri.volume == pytest.approx(40 * 20 * 30)  # closed and outward


def test_inward_mesh_is_turned_outwards(tmp_path):
    box = trimesh.creation.box(extents=(10, 10, 10))
    box.invert()
    path = tmp_path / "inv.stl"
    box.export(str(path))
    mesh = load_mesh(path, 1.0)
    assert trimesh.Trimesh(mesh.vertices, mesh.faces).volume == pytest.approx(1000)


def test_bad_meshes_are_refused_with_the_reason(tmp_path):
    with pytest.raises(InvalidObject, match="mesh file not found"):
        load_mesh(tmp_path / "none.obj", 1.0)
    (tmp_path / "a.txt").write_text("hello")
    with pytest.raises(InvalidObject, match="unsupported mesh format .txt"):
        load_mesh(tmp_path / "a.txt", 1.0)
    (tmp_path / "junk.stl").write_bytes(b"\x00\x01garbage")
    with pytest.raises(InvalidObject, match="junk.stl: (not a readable mesh|holds no triangles)"):
        load_mesh(tmp_path / "junk.stl", 1.0)
    (tmp_path / "points.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(InvalidObject, match="holds no triangles"):
        load_mesh(tmp_path / "points.obj", 1.0)
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n")
    with pytest.raises(InvalidObject, match="degenerate mesh: flat"):
        load_mesh(tmp_path / "flat.obj", 1.0)
    (tmp_path / "line.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(InvalidObject, match="degenerate mesh: every face has zero area"):
        load_mesh(tmp_path / "line.obj", 1.0)
    open_box = trimesh.creation.box(extents=(10, 10, 10))
    open_box.update_faces(np.arange(len(open_box.faces)) != 0)
    open_box.export(str(tmp_path / "open.stl"))
    with pytest.raises(InvalidObject, match=r"not watertight \(3 edges.*collisions: false"):
        load_mesh(tmp_path / "open.stl", 1.0)
    assert load_mesh(tmp_path / "open.stl", 1.0, closed=False).faces.shape == (11, 3)



def _flipped_box(tmp_path, suffix=".obj"):
    """A closed box with one face listed the other way round: 3 of its 18 edges disagree."""
    box = trimesh.creation.box(extents=(10, 10, 10))
    faces = box.faces.copy()
    faces[0] = faces[0][::-1]
    path = tmp_path / f"flipped{suffix}"
    trimesh.Trimesh(box.vertices, faces, process=False).export(str(path))
    return path


def _no_networkx(monkeypatch):
    """Make networkx unimportable, as on an install without trimesh's optional modules."""
    import builtins

    real_import = builtins.__import__

    def guarded(name, *args, **kwargs):
        if name == "networkx" or name.startswith("networkx."):
            raise ModuleNotFoundError("No module named 'networkx'", name="networkx")
        return real_import(name, *args, **kwargs)

    monkeypatch.setitem(__import__("sys").modules, "networkx", None)
    monkeypatch.setattr(builtins, "__import__", guarded)
    monkeypatch.setattr(trimesh.graph, "nx", trimesh.exceptions.ExceptionWrapper(ModuleNotFoundError("networkx")))


@pytest.mark.parametrize("suffix", [".obj", ".stl"])
def test_inconsistent_winding_is_refused_without_networkx(tmp_path, monkeypatch, suffix):
    """Issue 28 item 5: this crashed with "No module named 'networkx'" (trimesh's repair)."""
    path = _flipped_box(tmp_path, suffix)
    _no_networkx(monkeypatch)
    with pytest.raises(InvalidObject, match=rf"flipped{suffix}: .*not wound consistently \(3 of 18 edges"):
        load_mesh(path, 1.0)
    assert load_mesh(path, 1.0, closed=False).faces.shape == (12, 3)  # no collisions: taken as it is
    good = load_mesh(_box_file(tmp_path, suffix), 1.0)  # a well-wound mesh needs no networkx either
    assert trimesh.Trimesh(good.vertices, good.faces).volume > 0


def test_inconsistent_winding_is_refused_not_repaired_where_a_repair_could_run(tmp_path, monkeypatch):
    """Issue 28 item 5: with networkx installed trimesh re-wound the mesh silently; docs/objects.md
    says it is refused.  No trimesh repair is called whether or not networkx is there."""
    calls = []
    monkeypatch.setattr(trimesh.Trimesh, "fix_normals", lambda self, *a, **k: calls.append("fix_normals"))
    monkeypatch.setattr(trimesh.repair, "fix_winding", lambda *a, **k: calls.append("fix_winding"))
    with pytest.raises(InvalidObject, match="not wound consistently"):
        load_mesh(_flipped_box(tmp_path), 1.0)
    load_mesh(_box_file(tmp_path, ".stl"), 1.0)
    assert calls == []


def test_a_garbage_mesh_file_is_named_with_its_problem(tmp_path, monkeypatch):
    """Issue 28 item 9: random bytes in an .stl were reported as a missing charset_normalizer module."""
    rng = np.random.default_rng(5)
    for suffix in (".stl", ".obj", ".off"):
        path = tmp_path / f"garbage{suffix}"
        path.write_bytes(rng.integers(128, 256, 300, dtype=np.uint8).tobytes())
        with pytest.raises(InvalidObject, match=rf"garbage{suffix}: not a readable {suffix[1:].upper()} file: it is not text") as info:
            load_mesh(path, 1.0)
        assert "charset" not in str(info.value)
    (tmp_path / "empty.obj").write_bytes(b"")
    with pytest.raises(InvalidObject, match=r"empty.obj: the file is empty \(0 bytes\)"):
        load_mesh(tmp_path / "empty.obj", 1.0)
    (tmp_path / "folder.stl").mkdir()
    with pytest.raises(InvalidObject, match="mesh file .*folder.stl is a folder, not a file"):
        load_mesh(tmp_path / "folder.stl", 1.0)

KNOB_TASK = """\
prehension: task/1
name: mesh-box
hand: schunk-sa
object:
  name: box
  {solid}
  regions:
    top: {{bezier: [[[-10, -5, 15], [-10, 5, 15]], [[10, -5, 15], [10, 5, 15]]]}}
    bottom: {{point: [0, 0, -15], normal: [0, 0, -1]}}
contacts:
  - {{hand: index_tip, object: top}}
  - {{hand: thumb_tip, object: bottom}}
fingers: [index, thumb]
"""


def _write_task(tmp_path, solid: str, name="task.yaml"):
    path = tmp_path / name
    path.write_text(KNOB_TASK.format(solid=solid), encoding="utf-8")
    return path


def test_task_with_a_mesh_file_reads_and_writes_back(tmp_path):
    _box_file(tmp_path, ".stl", extents=(0.04, 0.02, 0.03))
    task = load_task(_write_task(tmp_path, "mesh: box.stl\n  units: m"))
    assert isinstance(task.object.solid, MeshFileSolid) and task.object.solid.scale == 1000.0
    assert task.object.collides
    dump_task(task, tmp_path / "copy.yaml")
    again = load_task(tmp_path / "copy.yaml")
    assert task_to_dict(again)["object"]["mesh"] == str((tmp_path / "box.stl").resolve())  # no base_dir: absolute
    assert task_to_dict(again)["object"]["units"] == "m"
    text = (tmp_path / "copy.yaml").read_text()
    assert "mesh: box.stl\n" in text and "units: m\n" in text and "scale" not in text


def test_task_with_primitives_shape(tmp_path):
    solid = "shape:\n    - {box: {center: [0, 0, 0], size: [40, 20, 30]}}\n    - {sphere: {center: [20, 0, 0], radius: 5}}"
    task = load_task(_write_task(tmp_path, solid))
    assert isinstance(task.object.solid, PrimitiveSolid) and len(task.object.solid.primitives) == 2
    d = task_to_dict(task)["object"]
    assert list(d["shape"][0]) == ["box"] and list(d["shape"][1]) == ["sphere"]


@pytest.mark.parametrize(
    "solid, message",
    [
        ("mesh: box.stl", "a mesh file carries no units: give exactly one of scale"),
        ("mesh: box.stl\n  scale: 1000\n  units: m", "give exactly one of scale"),
        ("scale: 10", "scale and units belong to a mesh file"),
        ("mesh: nothing.stl\n  units: m", r"object.mesh: mesh file not found: .*nothing.stl"),
        ("mesh: box.stl\n  scale: 1", r"object: object 'box': region 'top' is 18\.7 mm from the object's surface"),
        ("mesh: box.stl\n  units: m\n  surface_tolerance_mm: -1", "surface_tolerance_mm: must be greater than 0"),
    ],
)
def test_bad_object_solids(tmp_path, solid, message):
    _box_file(tmp_path, ".stl", extents=(0.04, 0.02, 0.03))
    with pytest.raises(InvalidTask, match=message):
        load_task(_write_task(tmp_path, solid))


def test_region_off_the_surface_names_region_and_distance():
    top = BezierRegion(np.array([[[-10, -5, 16.2], [-10, 5, 16.2]], [[10, -5, 16.2], [10, 5, 16.2]]], float))
    with pytest.raises(InvalidObject, match=r"region 'top' is 1.2 mm from the object's surface .*within 0.5 mm"):
        GraspObject("box", {"top": top}, solid=PrimitiveSolid((Box((0, 0, 0), (40, 20, 30)),)))
    obj = GraspObject("box", {"top": top}, solid=PrimitiveSolid((Box((0, 0, 0), (40, 20, 30)),)), surface_tolerance_mm=1.5)
    assert obj.collides


def test_flipped_patch_and_inward_point_are_refused():
    box = PrimitiveSolid((Box((0, 0, 0), (40, 20, 30)),))
    flipped = BezierRegion(np.array([[[-10, -5, 15], [10, -5, 15]], [[-10, 5, 15], [10, 5, 15]]], float))
    with pytest.raises(InvalidObject, match=r"region 'top' has its normal pointing into the object.*other order"):
        GraspObject("box", {"top": flipped}, solid=box)
    with pytest.raises(InvalidObject, match="region 'dot' has its normal pointing into the object"):
        GraspObject("box", {"dot": PointRegion((0, 0, 15), (0, 0, -1))}, solid=box)
    ok = GraspObject("box", {"dot": PointRegion((0, 0, 15), (0, 0, 1))}, solid=box)
    assert ok.surface.faces.shape[0] == 12


def test_sphere_primitive_is_within_the_tessellation_tolerance():
    obj = GraspObject("ball", {"p": PointRegion((0, 0, 25), (0, 0, 1))}, solid=PrimitiveSolid((Sphere((0, 0, 0), 25),)))
    r = np.linalg.norm(obj.surface.vertices, axis=1)
    np.testing.assert_allclose(r, 25.0, atol=1e-9)  # vertices on the sphere, chords within 0.05 mm
    face_centres = obj.surface.vertices[obj.surface.faces].mean(axis=1)
    assert np.min(np.linalg.norm(face_centres, axis=1)) > 25.0 - 0.05


# Built-in tasks whose answers are checked for collisions: all of them since phase 2 of issue 12.
COLLIDING = set(builtin_task_names())


def test_every_builtin_task_has_a_closed_solid_that_its_regions_lie_on():
    for name in builtin_task_names():
        task = load_builtin_task(name)  # the region check runs on load
        assert isinstance(task.object.solid, MeshFileSolid)
        assert task.object.collides == (name in COLLIDING), name
        closed = load_mesh(task.object.solid.path, 1.0)  # closed and outward, whatever the task says
        assert len(closed.faces) == len(task.object.surface.faces)


def test_shipped_builtin_meshes_are_what_the_generator_makes():
    from prehension.objects.builtin_shapes import BUILTIN_OBJECTS, mesh_difference_mm

    regions = builtin_regions()
    for name, make in BUILTIN_OBJECTS.items():
        assert mesh_difference_mm(make(regions[name]), builtin_mesh_dir() / f"{name}.ply") < 0.01, name


def test_loads_task_with_relative_mesh_needs_base_dir(tmp_path):
    _box_file(tmp_path, ".stl")
    text = KNOB_TASK.format(solid="mesh: box.stl\n  units: m")
    assert loads_task(text, "t", base_dir=tmp_path).object.collides


def test_a_task_on_a_mesh_file_in_fifteen_lines_solves_from_the_cli(tmp_path):
    """Issue 12: a task written on a mesh file, in at most 15 lines of YAML, solves from the
    command line, and its answer is penetration-free (check re-derives the object checks)."""
    from prehension.cli import EXIT_OK, main

    _box_file(tmp_path, ".stl")
    path = _write_task(tmp_path, "mesh: box.stl\n  units: m")
    assert len(path.read_text(encoding="utf-8").splitlines()) <= 15
    out = tmp_path / "result.json"
    assert main(["solve", str(path), "-o", str(out)]) == EXIT_OK
    assert main(["check", str(out)]) == EXIT_OK
    import json

    worst = json.loads(out.read_text())["solutions"][0]["worst"]
    assert worst["object_collision"] <= 0.5  # measured: the object has a solid
