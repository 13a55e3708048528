"""The residual function (prehension.verification.residuals) on tasks built by forward kinematics.

Core property: for random configurations built by forward kinematics (random joint angles
within limits, the object placed so that the contacts hold) every residual is ~0, while
perturbed configurations fail exactly the checks the perturbation breaks.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import random_angles
from fk_tasks import (
    DEG,
    FKCase,
    active_mask,
    build_fk_case,
    cap_params_at_angle,
    frame_rotation,
    idle_angles,
    random_cap_params,
    random_rotation,
)
from prehension.errors import InvalidConfiguration
from prehension.geometry.regions import PointRegion, SphereCap
from prehension.geometry.rotations import make_transform, rotation_about
from prehension.hands.collision import capsule_clearances, segment_distance
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.model import GraspObject
from prehension.tasks.model import Configuration, Contact, Task
from prehension.verification.residuals import (
    Check,
    ResidualReport,
    Tolerances,
    contact_residuals,
    coupling_violations,
    evaluate,
    limit_violations,
)

NO_COLLISION = Tolerances(penetration_mm=float("inf"))
N_TASKS = 40
CONTACT_KINDS = ("contact_distance", "contact_normal", "hand_region", "object_region")


def failing(report: ResidualReport) -> set[tuple[str, str]]:
    return {(c.kind, c.name) for c in report.failures}


def check(report: ResidualReport, kind: str, name: str) -> Check:
    found = [c for c in report.checks if c.kind == kind and c.name == name]
    assert len(found) == 1, (kind, name, [(c.kind, c.name) for c in report.checks])
    return found[0]


def fk_cases(hand, seeds, **kwargs) -> list[FKCase]:
    return [build_fk_case(hand, np.random.default_rng(seed), **kwargs) for seed in seeds]


def _translated(T, d):
    T2 = T.copy()
    T2[:3, 3] += d
    return T2


def _rotated_about_point(T, axis, angle, point):
    """The object turned by ``angle`` about ``axis`` through ``point`` (palm frame)."""
    Rd = rotation_about(axis, angle)
    return make_transform(Rd @ T[:3, :3], Rd @ (T[:3, 3] - point) + point)


def _angle_deg(a, b):
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))


# -- the core property ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def cases(sa_hand):
    return fk_cases(sa_hand, range(N_TASKS))


def test_fk_cases_cover_what_they_should(cases):
    kinds = {k for c in cases for k in c.object_kinds}
    assert kinds == {"point", "bezier", "cap"}
    assert {len(c.fingers) for c in cases} == {2, 3, 4}
    assert all(c.fingers[0] == "thumb" for c in cases)
    assert any("palm" in c.hand_regions for c in cases)
    degrees = {
        c.task.object_region(ct).patch.degree
        for c in cases
        for ct, k in zip(c.task.contacts, c.object_kinds)
        if k == "bezier"
    }
    assert degrees == {(1, 1), (2, 3), (3, 3)}


def test_fk_configurations_satisfy_every_constraint(cases):
    for i, case in enumerate(cases):
        report = evaluate(case.task, case.config, NO_COLLISION)
        assert report.ok, (i, report.summary())
        assert report.failures == ()
        assert report.summary() == "all constraints satisfied"
        C = len(case.task.contacts)
        assert len(report.contacts) == C
        for kind in ("contact_distance", "contact_normal", "hand_region", "object_region"):
            assert sum(c.kind == kind for c in report.checks) == C
        assert report.worst("contact_distance") < 1e-9, i
        assert report.worst("contact_normal") < 1e-6, i
        assert report.worst("hand_region") == 0.0
        assert report.worst("object_region") == 0.0
        lim = [c for c in report.checks if c.kind == "joint_limit"]
        cpl = [c for c in report.checks if c.kind == "coupling"]
        assert [c.name for c in lim] == list(case.task.hand.dof_names)
        assert len(cpl) == len(case.task.hand.couplings) == 4
        assert all(c.value == 0.0 for c in lim), i
        assert all(c.value < 1e-12 for c in cpl), i
        # The contact states are where the forward kinematics put the contacts.
        for k, state in enumerate(report.contacts):
            assert state.name == case.task.contacts[k].name
            np.testing.assert_allclose(state.hand_point, case.hand_points[k], atol=1e-10)
            np.testing.assert_allclose(state.object_point, case.hand_points[k], atol=1e-9)
            np.testing.assert_allclose(state.hand_normal, case.hand_normals[k], atol=1e-12)
            np.testing.assert_allclose(state.object_normal, -case.hand_normals[k], atol=1e-12)
            np.testing.assert_array_equal(state.hand_params, case.config.contact_params[k][0])
            np.testing.assert_array_equal(state.object_params, case.config.contact_params[k][1])
            assert state.distance_mm == check(report, "contact_distance", state.name).value
            assert state.normal_angle_deg == check(report, "contact_normal", state.name).value


def test_evaluate_finds_the_contact_parameters_itself(cases):
    """contact_params=None exercises locate.py: it must find a witness of each contact."""
    for i, case in enumerate(cases):
        report = evaluate(case.task, case.without_params(), NO_COLLISION)
        assert report.ok, (i, case.object_kinds, report.summary())
        assert report.worst("contact_distance") < 1e-6, i
        assert report.worst("contact_normal") < 1e-6, i
        for k, state in enumerate(report.contacts):
            hp, op = case.config.contact_params[k]
            assert state.hand_params.shape == hp.shape and state.object_params.shape == op.shape
            # The contact point is unique here, so the parameters found are the known ones.
            np.testing.assert_allclose(state.hand_point, case.hand_points[k], atol=1e-6)
            np.testing.assert_allclose(state.hand_params, hp, atol=1e-6)
            if case.object_kinds[k] == "bezier":
                np.testing.assert_allclose(state.object_params, op, atol=1e-6)


def test_default_tolerances_are_those_of_a_verified_solution():
    tol = Tolerances()
    assert (tol.contact_mm, tol.normal_deg, tol.region, tol.limit_deg, tol.coupling_deg, tol.penetration_mm) == (
        1e-6, 1e-6, 1e-9, 1e-9, 1e-9, 0.0,
    )  # fmt: skip


# -- perturbations -------------------------------------------------------------------------
def test_moving_the_object_half_a_millimetre_fails_only_the_distances(cases):
    rng = np.random.default_rng(7)
    for case in cases[:15]:
        d = rng.normal(size=3)
        d *= 0.5 / np.linalg.norm(d)
        report = evaluate(case.task, case.with_pose(_translated(case.config.T_palm_object, d)), NO_COLLISION)
        assert not report.ok
        names = [c.name for c in case.task.contacts]
        assert failing(report) == {("contact_distance", n) for n in names}
        for state in report.contacts:
            assert state.distance_mm == pytest.approx(0.5, abs=1e-9)
            assert state.normal_angle_deg < 1e-6
            np.testing.assert_allclose(state.object_point - state.hand_point, d, atol=1e-9)
        assert report.worst("contact_distance") == pytest.approx(0.5, abs=1e-9)


def test_moving_the_object_along_the_normal_is_measured_without_params(sa_hand):
    """Single point contact, object moved 0.5 mm along the contact normal: the best
    parameters stay where they were, the distance found is 0.5 mm, the normals agree."""
    for seed in range(5):
        case = build_fk_case(sa_hand, np.random.default_rng(100 + seed), fingers=("thumb",), palm=False, kinds=("point",))
        for sign in (1.0, -1.0):
            d = sign * 0.5 * case.hand_normals[0]
            T = _translated(case.config.T_palm_object, d)
            report = evaluate(case.task, Configuration(case.config.joint_angles, T), NO_COLLISION)
            name = case.task.contacts[0].name
            assert failing(report) == {("contact_distance", name)}
            assert report.contacts[0].distance_mm == pytest.approx(0.5, abs=1e-6)
            assert report.contacts[0].normal_angle_deg < 1e-6
            np.testing.assert_allclose(report.contacts[0].hand_params, case.config.contact_params[0][0], atol=1e-6)


def test_rotating_a_single_contact_object_misaligns_the_normals_by_the_angle(sa_hand):
    rng = np.random.default_rng(11)
    for seed in range(10):
        kinds = (("point", "bezier", "cap")[seed % 3],)
        case = build_fk_case(sa_hand, np.random.default_rng(200 + seed), fingers=("thumb",), palm=False, kinds=kinds)
        n, p = case.hand_normals[0], case.hand_points[0]
        axis = np.cross(n, rng.normal(size=3))  # through the contact point, orthogonal to the normal
        T = _rotated_about_point(case.config.T_palm_object, axis, 2 * DEG, p)
        report = evaluate(case.task, case.with_pose(T), NO_COLLISION)
        name = case.task.contacts[0].name
        assert failing(report) == {("contact_normal", name)}
        assert report.contacts[0].normal_angle_deg == pytest.approx(2.0, abs=1e-9)
        assert report.contacts[0].distance_mm < 1e-9


def test_rotating_the_object_moves_every_contact_as_computed_by_hand(cases):
    rng = np.random.default_rng(12)
    for case in cases[:15]:
        k = int(rng.integers(len(case.task.contacts)))
        p = case.hand_points[k]
        axis = np.cross(case.hand_normals[k], rng.normal(size=3))
        T = _rotated_about_point(case.config.T_palm_object, axis, 2 * DEG, p)
        Rd = rotation_about(axis, 2 * DEG)
        report = evaluate(case.task, case.with_pose(T), NO_COLLISION)
        assert report.contacts[k].normal_angle_deg == pytest.approx(2.0, abs=1e-9)
        assert report.contacts[k].distance_mm < 1e-9
        for j, state in enumerate(report.contacts):
            moved = Rd @ (case.hand_points[j] - p) + p
            assert state.distance_mm == pytest.approx(np.linalg.norm(moved - case.hand_points[j]), abs=1e-9)
            n = case.hand_normals[j]
            assert state.normal_angle_deg == pytest.approx(_angle_deg(n, Rd @ n), abs=1e-9)
        assert ("contact_normal", case.task.contacts[k].name) in failing(report)
        assert {kind for kind, _ in failing(report)} <= {"contact_distance", "contact_normal"}


def test_a_joint_angle_beyond_its_limit_fails_only_that_limit(sa_hand):
    coupled = {c.dof for c in sa_hand.couplings} | {c.source for c in sa_hand.couplings}
    for seed in range(12):
        rng = np.random.default_rng(300 + seed)
        fingers = ("thumb", "index")
        mask = active_mask(sa_hand, fingers)
        q = np.where(mask, random_angles(sa_hand, rng, 1)[0], idle_angles(sa_hand))
        choices = [i for i, d in enumerate(sa_hand.dof_names) if mask[i] and d not in coupled]
        i = int(rng.choice(choices))
        above = bool(seed % 2)
        q[i] = sa_hand.upper[i] + 1 * DEG if above else sa_hand.lower[i] - 1 * DEG
        case = build_fk_case(sa_hand, rng, fingers=fingers, q=q)  # contacts hold at this q
        report = evaluate(case.task, case.config, NO_COLLISION)
        dof = sa_hand.dof_names[i]
        assert failing(report) == {("joint_limit", dof)}, report.summary()
        c = check(report, "joint_limit", dof)
        assert c.value == pytest.approx(1.0, abs=1e-9) and c.unit == "deg" and not c.ok
        assert report.worst("joint_limit") == c.value
        assert dof in report.summary() and "FAILED" in report.summary()


def test_an_idle_finger_beyond_its_limit_fails_only_that_limit(sa_hand):
    for seed in range(4):
        case = build_fk_case(sa_hand, np.random.default_rng(350 + seed), fingers=("thumb", "middle"))
        q = case.config.joint_angles.copy()
        i = sa_hand.dof_index("ring_mcp_abd")
        q[i] = sa_hand.upper[i] + 1 * DEG
        report = evaluate(case.task, Configuration(q, case.config.T_palm_object, case.config.contact_params), NO_COLLISION)
        assert failing(report) == {("joint_limit", "ring_mcp_abd")}
        assert check(report, "joint_limit", "ring_mcp_abd").value == pytest.approx(1.0, abs=1e-9)


def test_breaking_a_coupling_fails_only_that_coupling(sa_hand):
    for seed in range(8):
        rng = np.random.default_rng(400 + seed)
        fingers = ("thumb", "ring", "middle")
        mask = active_mask(sa_hand, fingers)
        q = np.where(mask, random_angles(sa_hand, rng, 1)[0], idle_angles(sa_hand))
        f = fingers[seed % 3]
        pip, dip = sa_hand.dof_index(f"{f}_pip"), sa_hand.dof_index(f"{f}_dip")
        sign = 1.0 if seed % 2 else -1.0
        q[pip] = rng.uniform(sa_hand.lower[pip] + 1 * DEG, sa_hand.upper[pip] - 1 * DEG)
        q[dip] = q[pip] + sign * 0.5 * DEG  # still within the limits
        case = build_fk_case(sa_hand, rng, fingers=fingers, q=q)
        report = evaluate(case.task, case.config, NO_COLLISION)
        name = f"{f}_dip={f}_pip"
        assert failing(report) == {("coupling", name)}, report.summary()
        c = check(report, "coupling", name)
        assert c.value == pytest.approx(0.5, abs=1e-9) and c.unit == "deg"
        assert report.worst("coupling") == c.value


def test_hand_parameters_outside_the_cone_fail_the_hand_region(sa_hand):
    for seed in range(8):
        rng = np.random.default_rng(500 + seed)
        cap = sa_hand.region("thumb_tip").region
        excess = rng.uniform(0.5, 10.0)
        hp = cap_params_at_angle(cap, rng, cap.half_angle + excess * DEG)
        case = build_fk_case(sa_hand, rng, fingers=("thumb", "index"), palm=False, hand_params=[hp, None])
        report = evaluate(case.task, case.config, NO_COLLISION)
        name = case.task.contacts[0].name
        assert failing(report) == {("hand_region", name)}, report.summary()
        c = check(report, "hand_region", name)
        assert c.value == pytest.approx(excess, abs=1e-9) and c.unit == "deg"
        assert report.contacts[0].distance_mm < 1e-9


def test_patch_parameters_outside_the_patch_fail_the_object_region(sa_hand):
    for seed, st in enumerate(((1.1, 0.5), (0.3, -0.25), (1.05, 1.2))):
        rng = np.random.default_rng(600 + seed)
        case = build_fk_case(sa_hand, rng, fingers=("thumb",), palm=False, kinds=("bezier",), object_st=[st])
        report = evaluate(case.task, case.config, NO_COLLISION)
        name = case.task.contacts[0].name
        assert failing(report) == {("object_region", name)}, report.summary()
        expected = max(max(-x, x - 1.0, 0.0) for x in st)
        c = check(report, "object_region", name)
        assert c.value == pytest.approx(expected, abs=1e-12) and c.unit == "param"


def test_contact_on_a_wide_object_cap_beyond_90_degrees_is_found(sa_hand):
    """An object cap of half-angle 150 deg touched where its normal is 140 deg from the cap
    axis with alpha = 180 deg: inside the cone, so evaluate must find the contact itself."""
    rng = np.random.default_rng(700)
    q = np.where(active_mask(sa_hand, ("thumb",)), random_angles(sa_hand, rng, 1)[0], idle_angles(sa_hand))
    pose = forward_kinematics(sa_hand, q)
    hreg = sa_hand.region("thumb_tip")
    hp = random_cap_params(hreg.region, rng)
    p_link, n_link = hreg.region.evaluate(hp)
    li = sa_hand.link_index(hreg.link)
    p_palm, n_palm = pose.points(li, p_link)[0], pose.directions(li, n_link)[0]
    cap = SphereCap([1.0, 2.0, 3.0], 20.0, [0.3, -0.2, 1.0], 150 * DEG)
    e1, _, m = cap.frame.T
    n_obj = -np.cos(40 * DEG) * m + np.sin(40 * DEG) * e1  # 140 deg from m, alpha = 180 deg
    op = cap.params_for_normal(n_obj)[0]
    p_obj = cap.evaluate(op)[0][0]
    R = frame_rotation(n_obj, -n_palm, 0.3)
    T = make_transform(R, p_palm - R @ p_obj)
    task = Task("wide-cap", sa_hand, GraspObject("ball", {"ball": cap}), (Contact("thumb_tip", "ball"),), ("thumb",))
    known = evaluate(task, Configuration(q, T, ((hp, op),)), NO_COLLISION)
    assert known.ok, known.summary()
    found = evaluate(task, Configuration(q, T), NO_COLLISION)
    assert found.ok, found.summary()
    assert found.contacts[0].distance_mm < 1e-6


# -- batch cores ---------------------------------------------------------------------------
def test_contact_residuals_batch_equals_loop(sa_hand, cases):
    rng = np.random.default_rng(13)
    for case in cases[:6]:
        task, B = case.task, 7
        Q = random_angles(sa_hand, rng, B)
        T = np.stack([make_transform(random_rotation(rng), rng.uniform(-100, 100, 3)) for _ in range(B)])
        params = []
        for c in task.contacts:
            hreg, oreg = task.hand_region(c).region, task.object_region(c)
            lo_h, hi_h = hreg.param_bounds()
            lo_o, hi_o = oreg.param_bounds()
            params.append((rng.uniform(lo_h, hi_h, (B, hreg.n_params)), rng.uniform(lo_o, hi_o, (B, oreg.n_params))))
        batch = contact_residuals(task, forward_kinematics(sa_hand, Q), T, params)
        C = len(task.contacts)
        for key in ("distance_mm", "normal_angle_deg", "hand_region", "object_region"):
            assert batch[key].shape == (B, C), key
        for key in ("hand_point", "hand_normal", "object_point", "object_normal"):
            assert batch[key].shape == (B, C, 3), key
        for b in range(B):
            one = contact_residuals(
                task, forward_kinematics(sa_hand, Q[b]), T[b], [(h[b : b + 1], o[b : b + 1]) for h, o in params]
            )
            for key, value in batch.items():
                np.testing.assert_allclose(one[key][0], value[b], rtol=1e-12, atol=1e-9, err_msg=key)
            # ...and the same numbers as the named report
            report = evaluate(task, Configuration(Q[b], T[b], [(h[b], o[b]) for h, o in params]), NO_COLLISION)
            for k, state in enumerate(report.contacts):
                assert state.distance_mm == pytest.approx(batch["distance_mm"][b, k], rel=1e-12, abs=1e-9)
                assert state.normal_angle_deg == pytest.approx(batch["normal_angle_deg"][b, k], rel=1e-12, abs=1e-9)
                assert check(report, "hand_region", state.name).value == pytest.approx(batch["hand_region"][b, k], abs=1e-12)
        # distances and angles from the returned points and normals
        np.testing.assert_allclose(
            batch["distance_mm"], np.linalg.norm(batch["hand_point"] - batch["object_point"], axis=-1), atol=1e-12
        )
        cos = -np.sum(batch["hand_normal"] * batch["object_normal"], axis=-1)
        np.testing.assert_allclose(np.cos(np.radians(batch["normal_angle_deg"])), cos, atol=1e-12)
        assert np.all((batch["normal_angle_deg"] >= 0) & (batch["normal_angle_deg"] <= 180))


def test_limit_violations_by_hand(sa_hand):
    lo, hi = sa_hand.lower, sa_hand.upper
    q = np.tile(np.clip(0.0, lo, hi), (3, 1))
    q[0, 0] = hi[0] + 0.1
    q[0, 5] = lo[5] - 0.25
    q[1, 12] = hi[12]  # on the limit: 0
    q[1, 2] = lo[2]
    q[2] = hi + 0.01
    expected = np.zeros((3, sa_hand.n_dof))
    expected[0, 0] = 0.1
    expected[0, 5] = 0.25
    expected[2] = 0.01
    np.testing.assert_allclose(limit_violations(sa_hand, q), expected, atol=1e-15)
    single = limit_violations(sa_hand, q[0])
    assert single.shape == (1, sa_hand.n_dof)
    np.testing.assert_allclose(single[0], expected[0], atol=1e-15)
    with pytest.raises(InvalidConfiguration, match="n_dof = 17"):
        limit_violations(sa_hand, np.zeros(16))


def test_coupling_violations_by_hand(sa_hand):
    names = [f"{c.dof}={c.source}" for c in sa_hand.couplings]
    assert names == ["ring_dip=ring_pip", "middle_dip=middle_pip", "index_dip=index_pip", "thumb_dip=thumb_pip"]
    q = np.zeros((2, sa_hand.n_dof))
    q[0, sa_hand.dof_index("ring_pip")] = 0.3
    q[0, sa_hand.dof_index("ring_dip")] = 0.3  # satisfied
    q[0, sa_hand.dof_index("index_pip")] = 0.2
    q[0, sa_hand.dof_index("index_dip")] = 0.5  # off by 0.3
    q[1, sa_hand.dof_index("thumb_dip")] = -0.1  # off by 0.1
    expected = np.array([[0.0, 0.0, 0.3, 0.0], [0.0, 0.0, 0.0, 0.1]])
    np.testing.assert_allclose(coupling_violations(sa_hand, q), expected, atol=1e-15)
    assert coupling_violations(sa_hand.without_couplings(), q).shape == (2, 0)


def test_coupling_violations_with_ratio_and_offset(sa_hand):
    from prehension.hands.model import Coupling, Hand

    h = sa_hand
    hand = Hand(h.name, h.links, h.joints, (Coupling("index_dip", "index_pip", ratio=0.5, offset=0.1),), h.fingers, h.regions)
    q = np.zeros((3, h.n_dof))
    pip, dip = h.dof_index("index_pip"), h.dof_index("index_dip")
    q[:, pip] = [0.4, 0.4, -0.2]
    q[:, dip] = [0.3, 0.5, 0.0]
    np.testing.assert_allclose(coupling_violations(hand, q)[:, 0], [0.0, 0.2, 0.0], atol=1e-15)


# -- collision -----------------------------------------------------------------------------
def _contact_task_at(hand, q, fingers, rng):
    """An FK-consistent task at ``q`` (contacts hold), for collision checks."""
    return build_fk_case(hand, rng, fingers=fingers, q=q, palm=False, kinds=("point",) * len(fingers))


def test_idle_pose_does_not_collide(sa_hand):
    q = idle_angles(sa_hand)
    clearance, names = capsule_clearances(sa_hand, forward_kinematics(sa_hand, q))
    assert clearance.shape == (1, len(names)) and len(names) > 0
    assert clearance.min() > 0
    case = _contact_task_at(sa_hand, q, ("thumb", "index", "middle", "ring"), np.random.default_rng(1))
    report = evaluate(case.task, case.config)  # default tolerances: no penetration allowed
    assert report.ok, report.summary()
    coll = [c for c in report.checks if c.kind == "collision"]
    assert coll and all(c.value == 0.0 and c.unit == "mm" for c in coll)
    assert len({c.name for c in coll}) == len(coll)  # one check per link pair


def _fingertip_clearance(hand, q):
    clearance, names = capsule_clearances(hand, forward_kinematics(hand, q))
    return min(c for c, n in zip(clearance[0], names) if set(n) == {"index_distal", "middle_distal"})


def test_fingertips_driven_into_each_other_collide(sa_hand):
    """Index and middle abducted towards each other (flexed equally): search the grid of
    abductions for the first one at which their distal capsules overlap."""
    ia, ma = sa_hand.dof_index("index_mcp_abd"), sa_hand.dof_index("middle_mcp_abd")
    q0 = idle_angles(sa_hand)
    assert _fingertip_clearance(sa_hand, q0) > 0
    found = None
    for abd in np.arange(0.5, 15.01, 0.5) * DEG:
        q = q0.copy()
        q[ia], q[ma] = abd, -abd  # positive abduction turns a finger towards -y
        if _fingertip_clearance(sa_hand, q) < -1.0:
            found = q
            break
    assert found is not None
    depth = -_fingertip_clearance(sa_hand, found)

    # Independent check of the depth: sample both distal capsule segments densely.
    pose = forward_kinematics(sa_hand, found)
    s = np.linspace(0, 1, 2001)[:, None]
    seg = {}
    for f in ("index", "middle"):
        li = sa_hand.link_index(f"{f}_distal")
        cap = sa_hand.links[li].collision[0]
        a, b = pose.points(li, cap.a)[0], pose.points(li, cap.b)[0]
        seg[f] = (a + s * (b - a), cap.radius)
    d = np.linalg.norm(seg["index"][0][:, None] - seg["middle"][0][None], axis=-1).min()
    assert depth == pytest.approx(seg["index"][1] + seg["middle"][1] - d, abs=0.05)

    case = _contact_task_at(sa_hand, found, ("thumb", "index", "middle"), np.random.default_rng(2))
    report = evaluate(case.task, case.config)
    assert not report.ok
    assert {kind for kind, _ in failing(report)} == {"collision"}
    tip = [c for c in report.failures if set(c.name.split("/")) == {"index_distal", "middle_distal"}]
    assert len(tip) == 1
    assert tip[0].value == pytest.approx(depth, abs=1e-9) and tip[0].unit == "mm"
    assert "index_distal" in report.summary() and "middle_distal" in report.summary()
    assert report.worst("collision") >= depth
    # the penetration tolerance decides
    assert evaluate(case.task, case.config, NO_COLLISION).ok
    assert evaluate(case.task, case.config, Tolerances(penetration_mm=report.worst("collision") + 1e-9)).ok


def test_segment_distance_by_hand():
    p0, p1 = np.array([0.0, 0, 0]), np.array([10.0, 0, 0])
    assert segment_distance(p0, p1, np.array([5.0, 3, 0]), np.array([5.0, 3, 7])) == pytest.approx(3.0)
    assert segment_distance(p0, p1, np.array([13.0, 4, 0]), np.array([13.0, 4, 0])) == pytest.approx(5.0)
    assert segment_distance(p0, p1, np.array([2.0, 1, 0]), np.array([8.0, 1, 0])) == pytest.approx(1.0)


# -- the report ----------------------------------------------------------------------------
def test_report_summary_failures_and_worst_by_hand():
    checks = (
        Check("contact_distance", "a", 0.5, "mm", 1e-6),
        Check("contact_distance", "b", 1e-7, "mm", 1e-6),
        Check("joint_limit", "j", 0.0, "deg", 1e-9),
        Check("coupling", "c", 2.0, "deg", 1e-9),
        Check("collision", "x/y", 1e-9, "mm", 1e-9),  # on the tolerance: ok
    )
    report = ResidualReport(checks, ())
    assert not report.ok
    assert report.failures == (checks[0], checks[3])
    assert report.worst("contact_distance") == 0.5
    assert report.worst("coupling") == 2.0
    assert report.worst("collision") == 1e-9
    assert report.worst("contact_normal") == 0.0  # no such check
    assert report.summary() == (
        "contact_distance a: 0.5 mm (tolerance 1e-06) FAILED; coupling c: 2 deg (tolerance 1e-09) FAILED"
    )
    assert checks[1].describe() == "contact_distance b: 1e-07 mm (tolerance 1e-06) ok"
    ok = ResidualReport(checks[1:3], ())
    assert ok.ok and ok.failures == () and ok.summary() == "all constraints satisfied"
    assert ResidualReport((), ()).ok


def test_report_from_columns_is_the_report_of_its_checks(cases):
    """evaluate() builds its report from columns and makes Check objects only when asked:
    the same checks, verdict, failures and worst values as a report of Check objects; read-only;
    pickled whole (batch workers send reports between processes)."""
    import pickle

    case = cases[0]
    T = _translated(case.config.T_palm_object, [0.0, 0.0, 0.5])
    report = evaluate(case.task, Configuration(case.config.joint_angles, T, case.config.contact_params))
    again = ResidualReport(report.checks, report.contacts)
    assert not report.ok and report.ok == again.ok and report.failures == again.failures
    assert report.kinds == tuple(dict.fromkeys(c.kind for c in report.checks))
    for kind in report.kinds + ("no_such_kind",):
        assert report.worst(kind) == again.worst(kind)
    assert report.summary() == again.summary()
    with pytest.raises(AttributeError, match="read-only"):
        report.contacts = ()
    copy = pickle.loads(pickle.dumps(report))
    assert copy.checks == report.checks and copy.summary() == report.summary()
    with pytest.raises(ValueError, match="one kind, name, value, unit and tolerance per check"):
        ResidualReport.from_columns(("contact_distance",), ("a",), [1.0, 2.0], ("mm",), [1e-6], ())


def test_report_failures_list_exactly_the_failing_checks(cases):
    case = cases[0]
    T = _translated(case.config.T_palm_object, [0.0, 0.0, 0.5])
    q = case.config.joint_angles.copy()
    i = case.task.hand.dof_index("thumb_base")
    q[i] = case.task.hand.upper[i] + 2 * DEG  # also breaks the contacts of the thumb
    report = evaluate(case.task, Configuration(q, T, case.config.contact_params), NO_COLLISION)
    assert report.failures == tuple(c for c in report.checks if c.value > c.tolerance)
    assert ("joint_limit", "thumb_base") in failing(report)
    assert check(report, "joint_limit", "thumb_base").value == pytest.approx(2.0, abs=1e-9)
    summary = report.summary()
    assert summary.count("FAILED") == len(report.failures)
    assert " ok" not in summary
    for c in report.failures:
        assert c.describe() in summary


# -- configuration shapes ------------------------------------------------------------------
def test_check_against_names_the_expected_sizes(sa_hand, cases):
    case = next(c for c in cases if len(c.task.contacts) >= 2 and c.object_kinds[0] == "point")
    task, cfg = case.task, case.config
    with pytest.raises(InvalidConfiguration, match=r"16 joint angles; hand 'schunk-sa' has 17"):
        Configuration(cfg.joint_angles[:-1], cfg.T_palm_object).check_against(task)
    with pytest.raises(InvalidConfiguration, match=r"16 joint angles; hand 'schunk-sa' has 17"):
        evaluate(task, Configuration(cfg.joint_angles[:-1], cfg.T_palm_object))
    C = len(task.contacts)
    with pytest.raises(InvalidConfiguration, match=rf"parameters for {C - 1} contacts; task has {C}"):
        Configuration(cfg.joint_angles, cfg.T_palm_object, cfg.contact_params[:-1]).check_against(task)
    bad = list(cfg.contact_params)
    bad[0] = (np.zeros(1), np.zeros(0))
    name = task.contacts[0].name
    with pytest.raises(InvalidConfiguration, match=rf"contact '{name}': expected 2 hand and 0 object parameters, got 1 and 0"):
        evaluate(task, Configuration(cfg.joint_angles, cfg.T_palm_object, bad))
    bad[0] = (np.zeros(2), np.zeros(2))
    with pytest.raises(InvalidConfiguration, match=r"expected 2 hand and 0 object parameters, got 2 and 2"):
        Configuration(cfg.joint_angles, cfg.T_palm_object, bad).check_against(task)
    cfg.check_against(task)  # the right sizes pass
    Configuration(cfg.joint_angles, cfg.T_palm_object).check_against(task)


@pytest.mark.parametrize(
    "T, message",
    [
        (np.diag([2.0, 2.0, 2.0, 1.0]), "rigid"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "rigid"),  # a reflection
        (np.array([[1, 0.1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]]), "rigid"),  # a shear
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1.0]]), "rigid"),  # last row
        (np.eye(3), "4x4"),
        (np.full((4, 4), np.nan), "finite"),
    ],
)
def test_non_rigid_object_pose_is_refused(sa_hand, T, message):
    with pytest.raises(InvalidConfiguration, match=message):
        Configuration(np.zeros(sa_hand.n_dof), T)


def test_bad_joint_angles_are_refused(sa_hand):
    with pytest.raises(InvalidConfiguration, match="1-D array"):
        Configuration(np.zeros((2, sa_hand.n_dof)), np.eye(4))
    q = np.zeros(sa_hand.n_dof)
    q[3] = np.nan
    with pytest.raises(InvalidConfiguration, match="finite"):
        Configuration(q, np.eye(4))


def test_point_to_point_contact_needs_no_parameters(sa_hand):
    """A palm point region (no parameters) touching an object point region."""
    hand = sa_hand.with_regions({"palm_point": type(sa_hand.region("palm"))("palm", PointRegion([20.55, 0, 100], [1, 0, 0]))})
    obj = GraspObject("plate", {"face": PointRegion([0, 0, 0], [0, 0, 1])})
    task = Task("p2p", hand, obj, (Contact("palm_point", "face"),), ())
    R = frame_rotation(np.array([0.0, 0.0, 1.0]), np.array([-1.0, 0.0, 0.0]), 0.4)
    T = make_transform(R, [20.55, 0, 100])
    q = idle_angles(hand)
    for params in (None, ((np.zeros(0), np.zeros(0)),)):
        report = evaluate(task, Configuration(q, T, params))
        assert report.ok, report.summary()
        assert report.contacts[0].hand_params.shape == (0,)
    report = evaluate(task, Configuration(q, _translated(T, [0, 0.3, 0.4])))
    assert failing(report) == {("contact_distance", "palm_point->face")}
    assert report.contacts[0].distance_mm == pytest.approx(0.5, abs=1e-12)


def test_a_report_judged_with_other_tolerances_is_evaluate_with_them(cases):
    """first_solution evaluates a configuration once for the strict and the acceptance
    tolerances: judging the report with other tolerances gives exactly evaluate's report
    with them (same checks, same tolerances, same verdict), and every kind has a field."""
    from dataclasses import fields

    from prehension.results import first_solution, make_solution
    from prehension.verification.residuals import TOLERANCE_OF_KIND

    names = {f.name for f in fields(Tolerances)}
    assert set(TOLERANCE_OF_KIND.values()) <= names
    strict_tol = NO_COLLISION  # the random FK cases are not all clear of self-collision
    loose = Tolerances(contact_mm=1.0, normal_deg=2.0, region=0.5, limit_deg=3.0, coupling_deg=1e-3,
                       penetration_mm=float("inf"), object_penetration_mm=0.5)  # fmt: skip
    for case in cases[:4]:
        T = _translated(case.config.T_palm_object, [0.0, 0.0, 0.3])  # fails strict, passes loose
        for config in (case.config, Configuration(case.config.joint_angles, T, case.config.contact_params)):
            strict = evaluate(case.task, config, strict_tol)
            assert set(strict.kinds) <= set(TOLERANCE_OF_KIND)
            for tol in (loose, Tolerances(), strict_tol):
                direct, judged = evaluate(case.task, config, tol), strict.judged(tol)
                assert judged.checks == direct.checks and judged.ok == direct.ok
            k, sol = first_solution(case.task, config, (strict_tol, loose))
            assert k == (0 if strict.ok else 1) and sol is not None and sol.tolerances == (strict_tol, loose)[k]
            assert sol.report.checks == make_solution(case.task, config, sol.tolerances).report.checks
    far = Configuration(case.config.joint_angles, _translated(T, [0, 0, 5.0]), case.config.contact_params)
    assert first_solution(case.task, far, (strict_tol, loose)) == (-1, None)
