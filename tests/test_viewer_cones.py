"""The viewer's friction cones: one per contact, apex at the contact, opening into the object."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.quality.solid import _volume_integrals
from prehension.solve import solve
from prehension.tasks.library import load_builtin_task
from prehension.viewer import build_scene, scene_to_html
from prehension.viewer.cones import cone_mesh


def test_a_cone_has_its_apex_axis_and_half_angle():
    apex, axis = np.array([1.0, 2.0, 3.0]), np.array([0.0, 0.6, 0.8])
    mesh = cone_mesh(apex, axis, np.arctan(0.5), 40.0)
    assert np.allclose(mesh.vertices[0], apex)
    rim = mesh.vertices[2:] - apex
    along = rim @ axis
    across = np.linalg.norm(rim - along[:, None] * axis, axis=1)
    assert np.allclose(along, 40.0) and np.allclose(across / along, 0.5)
    volume = _volume_integrals(mesh)[0]  # closed and outward: a positive volume near pi r^2 h / 3
    assert volume == pytest.approx(np.pi * 20.0**2 * 40.0 / 3, rel=0.02)


def test_a_solved_grasp_shows_one_friction_cone_per_contact():
    task = load_builtin_task("teapot-lid-lifting")
    solution = solve(task, "local").solutions[0]
    scene = build_scene(task, solution)
    layer = scene.layer("friction_cones")
    assert len(layer.meshes) == len(solution.contacts) and layer.visible
    for mesh, c, color in zip(layer.meshes, solution.contacts, [m.color for m in scene.layer("hand_regions").meshes]):
        assert np.allclose(mesh.vertices_mm[0], c.object_point)
        opening = mesh.vertices_mm[1] - mesh.vertices_mm[0]  # apex -> centre of the base
        assert opening @ c.object_normal < 0  # into the object
        assert mesh.color == color
    assert '"friction_cones"' in scene_to_html(scene)


def test_a_task_alone_has_no_cones():
    scene = build_scene(load_builtin_task("teapot-lid-lifting"))
    assert "friction_cones" not in {l.key for l in scene.layers}
