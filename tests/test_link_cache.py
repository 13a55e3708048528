"""A file hand's fitted capsules are kept on disk: a second read fits nothing (issue 26 item 2)."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.disk_cache import CACHE_ENV
from prehension.hands import shapes
from prehension.hands.urdf import _vertices_mm, hand_from_urdf

MESH_LINK = """<robot name='s'><link name='palm'><collision><geometry>
<mesh filename='{mesh}'/></geometry></collision></link></robot>"""


def _write_obj(path, pts):
    n = len(pts)
    faces = "".join(f"f {i + 1} {(i + 1) % n + 1} {(i + 2) % n + 1}\n" for i in range(0, n, 3))  # every point a corner
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in pts.tolist()) + faces)


@pytest.fixture
def urdf(tmp_path, monkeypatch):
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    mesh = tmp_path / "m.obj"
    _write_obj(mesh, np.random.default_rng(3).normal(size=(200, 3)) * [0.03, 0.01, 0.01])
    path = tmp_path / "h.urdf"
    path.write_text(MESH_LINK.format(mesh=mesh))
    return path, mesh


def _refuse(points):
    raise AssertionError("fitted again: the stored capsules were not used")


def test_a_second_read_uses_the_stored_fit(urdf, monkeypatch):
    path, _ = urdf
    first = hand_from_urdf(path).links[0]
    monkeypatch.setattr(shapes, "mesh_capsule", _refuse)
    second = hand_from_urdf(path).links[0]
    assert second.fit == first.fit and first.fit.miss_mm == 0.0
    for a, b in zip(first.collision, second.collision, strict=True):
        assert np.array_equal(a.a, b.a) and np.array_equal(a.b, b.b) and a.radius == b.radius


def test_an_edited_mesh_misses_the_cache(urdf, monkeypatch):
    path, mesh = urdf
    first = hand_from_urdf(path).links[0]
    _write_obj(mesh, np.random.default_rng(4).normal(size=(200, 3)) * [0.01, 0.03, 0.01])
    _vertices_mm.cache_clear()  # as a new process: the reader keeps files by path within one
    second = hand_from_urdf(path).links[0]
    axis = lambda c: np.abs(c.b - c.a) / np.linalg.norm(c.b - c.a)  # noqa: E731
    assert np.argmax(axis(first.collision[0])) == 0 and np.argmax(axis(second.collision[0])) == 1


def test_without_a_cache_every_read_fits(urdf, monkeypatch):
    path, _ = urdf
    monkeypatch.setenv(CACHE_ENV, "off")
    hand_from_urdf(path)
    monkeypatch.setattr(shapes, "mesh_capsule", _refuse)
    with pytest.raises(AssertionError, match="fitted again"):
        hand_from_urdf(path)
