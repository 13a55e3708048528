"""The disk cache of checked meshes and distance trees (prehension.objects.geometry_cache):
what a later process reads is bit for bit what it would have built; any change of the
input misses; a damaged entry or a switched-off cache only costs the rebuild."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from prehension.errors import InvalidObject
from prehension.objects import geometry_cache as gc
from prehension.objects.distance import MeshDistance
from prehension.objects.meshes import Box
from prehension.objects.solid import MeshFileSolid, PrimitiveSolid, _cached_geometry, solid_geometry
from prehension.tasks.library import builtin_task_names  # noqa: F401  (the package's data is found)

TEAPOT = "teapot.ply"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv(gc.CACHE_ENV, str(folder))
    _cached_geometry.cache_clear()
    yield folder
    _cached_geometry.cache_clear()


def _mesh_file(tmp_path):
    from pathlib import Path

    import prehension.tasks

    src = Path(prehension.tasks.__file__).parent / "builtin" / "meshes" / TEAPOT
    dst = tmp_path / TEAPOT
    shutil.copyfile(src, dst)
    return dst


def _same(a, b):
    (mesh_a, dist_a), (mesh_b, dist_b) = a, b
    np.testing.assert_array_equal(mesh_a.vertices, mesh_b.vertices)
    np.testing.assert_array_equal(mesh_a.faces, mesh_b.faces)
    for name, x, y in zip(dist_a.arrays._fields, dist_a.arrays, dist_b.arrays):
        assert type(x) is type(y) or name == "robust_sign", name
        np.testing.assert_array_equal(x, y, err_msg=name)
    assert isinstance(dist_b.arrays.robust_sign, bool)


def test_a_stored_entry_is_what_building_gives(cache, tmp_path):
    solid = MeshFileSolid(str(_mesh_file(tmp_path)), 1.0)
    built = solid_geometry(solid)
    assert len(list(cache.glob("*.npz"))) == 1
    _cached_geometry.cache_clear()  # as a new process
    read = solid_geometry(solid)
    assert read is not built
    _same(built, read)
    points = np.random.default_rng(0).uniform(-80, 80, (50, 3))
    np.testing.assert_array_equal(built[1].signed_distance(points), read[1].signed_distance(points))
    direct = MeshDistance(built[0].vertices, built[0].faces)  # no cache involved
    _same((built[0], direct), read)


def test_primitive_solids_are_stored_too(cache):
    solid = PrimitiveSolid((Box((0.0, 0.0, 0.0), (10.0, 20.0, 30.0)),))
    built = solid_geometry(solid)
    _cached_geometry.cache_clear()
    _same(built, solid_geometry(solid))
    other = PrimitiveSolid((Box((0.0, 0.0, 0.0), (10.0, 20.0, 30.000001)),))
    assert gc.geometry_key(other, True) != gc.geometry_key(solid, True)


def test_any_change_of_the_input_misses(cache, tmp_path):
    path = _mesh_file(tmp_path)
    solid = MeshFileSolid(str(path), 1.0)
    key = gc.geometry_key(solid, True)
    assert gc.geometry_key(MeshFileSolid(str(path), 1000.0), True) != key  # scale
    assert gc.geometry_key(solid, False) != key  # closed or not
    path.write_bytes(path.read_bytes() + b"\n")  # the file's bytes
    assert gc.geometry_key(solid, True) != key
    assert gc.geometry_key(MeshFileSolid(str(tmp_path / "missing.ply"), 1.0), True) is None


def test_a_damaged_entry_is_rebuilt_and_a_bad_mesh_never_stored(cache, tmp_path):
    solid = MeshFileSolid(str(_mesh_file(tmp_path)), 1.0)
    built = solid_geometry(solid)
    (entry,) = cache.glob("*.npz")
    entry.write_bytes(entry.read_bytes()[:1000])  # cut short
    _cached_geometry.cache_clear()
    _same(built, solid_geometry(solid))
    _cached_geometry.cache_clear()
    _same(built, solid_geometry(solid))  # rewritten whole
    bad = tmp_path / "open.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    with pytest.raises(InvalidObject, match="not watertight|flat"):
        solid_geometry(MeshFileSolid(str(bad), 1.0))
    assert len(list(cache.glob("*.npz"))) == 1


@pytest.mark.parametrize("value", ["off", "0", ""])
def test_the_cache_can_be_switched_off(tmp_path, monkeypatch, value):
    monkeypatch.setenv(gc.CACHE_ENV, value)
    assert gc.cache_folder() is None
    monkeypatch.delenv(gc.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert gc.cache_folder() == tmp_path / "prehension" / "geometry"


def test_an_unwritable_folder_only_costs_the_rebuild(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(gc.CACHE_ENV, str(blocker / "cache"))
    _cached_geometry.cache_clear()
    try:
        mesh, distance = solid_geometry(PrimitiveSolid((Box((0.0, 0.0, 0.0), (10.0, 10.0, 10.0)),)))
        assert len(mesh.faces) == 12 and distance.signed_distance(np.zeros((1, 3)))[0] == pytest.approx(-5.0)
    finally:
        _cached_geometry.cache_clear()
