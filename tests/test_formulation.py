"""The polynomial formulation (sec. 3): known solutions are points of the system."""

from __future__ import annotations

import numpy as np
import pytest

from fk_tasks import build_fk_case
from prehension.system.embedding import configuration_from_point, embed
from prehension.system.formulation import build_system
from prehension.system.keys import NormalLength, PalmOrigin, PatchParameter, RotationEntry, Side, UnitNormal
from prehension.tasks.library import load_builtin_task
from prehension.tasks.model import Task
from prehension.verification.residuals import Tolerances, evaluate

ANY_COLLISION = Tolerances(penetration_mm=float("inf"))


def _assert_is_solution_point(form, x, tol=1e-9):
    system = form.system
    assert np.abs(system.residuals(x)).max() < tol
    assert system.inequality_violation(x) < tol
    assert np.all(x >= system.lower - tol) and np.all(x <= system.upper + tol)


@pytest.mark.parametrize("seed", range(25))
def test_fk_solutions_are_points_of_the_system(sa_hand, seed):
    rng = np.random.default_rng(seed)
    case = build_fk_case(sa_hand, rng)
    assert evaluate(case.task, case.config, ANY_COLLISION).ok
    form = build_system(case.task)
    _assert_is_solution_point(form, embed(form, case.config))


@pytest.mark.parametrize("seed", range(10))
def test_configuration_read_back_from_a_point_is_the_configuration(sa_hand, seed):
    rng = np.random.default_rng(100 + seed)
    case = build_fk_case(sa_hand, rng)
    form = build_system(case.task)
    back = configuration_from_point(form, embed(form, case.config))
    assert evaluate(case.task, back, ANY_COLLISION).ok
    np.testing.assert_allclose(back.T_palm_object, case.config.T_palm_object, atol=1e-9)
    moving = [sa_hand.dof_index(d) for d in form.dofs_in_system]
    np.testing.assert_allclose(back.joint_angles[moving], case.config.joint_angles[moving], atol=1e-9)


def test_a_configuration_breaking_a_limit_is_not_a_point_of_the_system(sa_hand):
    rng = np.random.default_rng(7)
    case = build_fk_case(sa_hand, rng, fingers=("thumb", "index"))
    q = case.config.joint_angles.copy()
    i = sa_hand.dof_index("index_mcp_abd")
    q[i] = sa_hand.upper[i] + 0.05  # 3 degrees beyond the limit: rebuild the task there
    broken = build_fk_case(sa_hand, np.random.default_rng(7), fingers=("thumb", "index"), q=q)
    form = build_system(broken.task)
    x = embed(form, broken.config)
    assert np.abs(form.system.residuals(x)).max() < 1e-9  # the equations hold...
    assert form.system.inequality_violation(x) > 1e-4  # ...but the limit inequality does not


@pytest.mark.parametrize("name", ["teapot-lid-lifting", "scalpel-incision", "teapot-service", "guitar-holding"])
def test_builtin_systems_have_the_expected_shape(name):
    form = build_system(load_builtin_task(name))
    system = form.system
    assert set(form.links) >= {"palm"}
    assert system.n_equations > system.A.shape[0] > 0
    assert len(system.bernstein) == 6 * len(form.task.contacts)  # point + normal patch, 3 each
    assert np.all(system.lower <= system.upper)
    assert np.all(np.isfinite(system.lower)) and np.all(np.isfinite(system.upper))


def test_system_jacobian_matches_finite_differences(sa_hand):
    case = build_fk_case(sa_hand, np.random.default_rng(11), palm=True)
    system = build_system(case.task).system
    x = embed(build_system(case.task), case.config)
    J = system.jacobian(x).toarray()
    h = 1e-7
    for k in np.random.default_rng(0).choice(system.n, size=40, replace=False):
        dx = np.zeros(system.n)
        dx[k] = h
        fd = (system.residuals(x + dx) - system.residuals(x - dx)) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, atol=1e-5)


def test_solution_dimension_of_a_two_finger_task(sa_hand):
    """Index + thumb, fingertip caps on patches: 7 independent angles + 6 pose + 8 region
    parameters - 10 contact equations = 11 (the dimension the task's counts predict)."""
    case = build_fk_case(sa_hand, np.random.default_rng(5), fingers=("thumb", "index"), palm=False, kinds=("bezier", "bezier"))
    form = build_system(case.task)
    assert form.system.solution_dimension(embed(form, case.config)) == case.task.counts()["dimension"] == 11


def test_base_variables_carry_typed_object_frame_keys(sa_hand):
    """Every base variable is named by a frozen key; rotations are R_object_link entries."""
    case = build_fk_case(sa_hand, np.random.default_rng(12), fingers=("thumb", "index"), palm=False,
                         kinds=("bezier", "cap"))  # fmt: skip
    form = build_system(case.task)
    keys = list(form.base_keys.values())
    assert len(set(keys)) == len(keys)  # hashable and distinct
    assert {type(k) for k in keys} == {RotationEntry, PalmOrigin, PatchParameter, UnitNormal, NormalLength}
    assert {k.link for k in keys if isinstance(k, RotationEntry)} == set(form.links)
    assert sorted(k.axis for k in keys if isinstance(k, PalmOrigin)) == [0, 1, 2]
    assert {(k.contact, k.side) for k in keys if isinstance(k, UnitNormal)} == {(0, Side.OBJECT), (1, Side.OBJECT)}
    assert form.system.names[form.R_object_link["palm"][0, 0]] == "R_object_palm[0,0]"
    assert form.system.names[form.p_palm_in_object[2]] == "p_palm_in_object[2]"
    np.testing.assert_array_equal(form.base_indices, sorted(form.base_keys))
    with pytest.raises(AttributeError):
        keys[0].link = "other"  # frozen


@pytest.mark.parametrize("kind", ["bezier", "point"])
def test_hand_patches_and_points_embed_as_solution_points(sa_hand, kind):
    """A hand region that is a Bézier patch (its own s, t, nu, mu) or a point also gives
    known solutions that are points of the system, read back unchanged."""
    from dataclasses import replace

    from fk_tasks import height_field_patch
    from prehension.geometry.regions import BezierRegion, PointRegion
    from prehension.hands.model import HandRegion

    tip = sa_hand.regions["index_tip"]
    if kind == "bezier":
        patch = height_field_patch(np.random.default_rng(4), 2, 2, size=8.0, bump=1.0)
        region, params = BezierRegion(patch.transformed(np.eye(3), np.asarray(tip.region.center))), (0.3, 0.6)
    else:
        region, params = PointRegion(np.asarray(tip.region.center), np.array([0.0, 0.0, 1.0])), np.zeros(0)
    hand = replace(sa_hand, regions={**sa_hand.regions, "index_tip": HandRegion(tip.link, region)})
    for seed in range(3):
        case = build_fk_case(hand, np.random.default_rng(300 + seed), fingers=("thumb", "index"), palm=False,
                             hand_params=[None, np.asarray(params, dtype=float)])  # fmt: skip
        form = build_system(case.task)
        x = embed(form, case.config)
        _assert_is_solution_point(form, x)
        back = configuration_from_point(form, x)
        assert evaluate(case.task, back, ANY_COLLISION).ok


def test_a_region_kind_the_system_cannot_express_is_refused_by_name():
    from prehension.geometry.regions import Region
    from prehension.system.regions import form_of

    class Blob(Region):
        pass

    with pytest.raises(TypeError, match="Blob"):
        form_of(Blob())
