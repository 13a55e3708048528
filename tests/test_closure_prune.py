"""The force-closure prune: a sound certificate that no configuration of a box is force closure."""

from __future__ import annotations

import numpy as np
import pytest

from box_example import EXAMPLES, box_grasps
from fk_tasks import build_fk_case
from prehension.cli import EXIT_BAD_INPUT, EXIT_INFEASIBLE, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, configuration_quality, primitive_wrenches, torque_reference
from prehension.results import Status
from prehension.solve import SolveOptions, solve
from prehension.solvers.complete.closure import CERTIFICATE_MARGIN, certified_bound, closure_prune, contact_enclosures
from prehension.solvers.complete.contract import contract
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.verification import verify_result_file
from prehension.solvers.local.verifier import LocalVerifier

REQUIRE = BranchAndPruneOptions(verifier=LocalVerifier(), require="force-closure")
MODELS = (QualityOptions(), QualityOptions(friction=0.3, torsion_mm=5.0), QualityOptions(friction=1.0, cone_edges=4))


def _boxes_around(form, x, rng, n: int):
    """``n`` random boxes of the system holding the point ``x``, from tight to the whole box."""
    lo0, hi0 = form.system.lower, form.system.upper
    for k in range(n):
        f = 10.0 ** rng.uniform(-4, 0) if k else 1.0
        lo = np.maximum(x - f * rng.uniform(0, 1, x.size) * (x - lo0), lo0)
        hi = np.minimum(x + f * rng.uniform(0, 1, x.size) * (hi0 - x), hi0)
        yield np.minimum(lo, x), np.maximum(hi, x)


def _object_frame_contacts(task, config):
    points, normals = [], []
    for contact, (_, op) in zip(task.contacts, config.contact_params):
        p, n = task.object_region(contact).evaluate(np.asarray(op, float)[None])
        points.append(p[0]), normals.append(n[0])
    return np.array(points), np.array(normals)


def _fk_case(sa_hand, rng, near_box_grasp: bool):
    """A forward-built task: random, or around the four-finger box grasp (its joint angles
    moved by up to 0.1 rad, its fingertip contact parameters), which is mostly force closure."""
    if not near_box_grasp:
        return build_fk_case(sa_hand, rng, palm=False)
    task, grasp = box_grasps.four_finger_grasp()
    q = np.clip(grasp.q + np.where(task.active_mask, rng.uniform(-0.1, 0.1, grasp.q.size), 0.0), sa_hand.lower, sa_hand.upper)
    for c in sa_hand.couplings:
        q[sa_hand.dof_index(c.dof)] = c.ratio * q[sa_hand.dof_index(c.source)] + c.offset
    hand_params = [hp for hp, _ in grasp.configuration().contact_params]
    return build_fk_case(sa_hand, rng, fingers=("index", "middle", "ring", "thumb"), q=q, palm=False, hand_params=hand_params)


def test_enclosures_hold_the_contacts_and_no_certificate_covers_a_force_closure_grasp(sa_hand):
    """Forward-built tasks (16 seeds; half of them near a force-closure grasp), three friction
    models, six random boxes around the known configuration each: every box encloses its
    object-frame contacts; a certificate appears only when every primitive wrench of that
    configuration lies in the certified half space -- never for a force-closure one.  Both
    kinds occur often (the test can fail both ways)."""
    around_closure = certified = 0
    for seed in range(16):
        rng = np.random.default_rng(4000 + seed)
        case = _fk_case(sa_hand, rng, near_box_grasp=seed % 2 == 1)
        form = build_system(case.task)
        x = embed(form, case.config)
        points, normals = _object_frame_contacts(case.task, case.config)
        for quality in MODELS:
            closed = configuration_quality(case.task, case.config, quality).force_closure
            centre, rho = torque_reference(case.task, quality)
            W = primitive_wrenches(points, -normals, centre, rho, quality).reshape(-1, 6)
            for lo, hi in _boxes_around(form, x, rng, 6):
                p_lo, p_hi, nu_lo, nu_hi = contact_enclosures(form, lo, hi)
                assert np.all((p_lo - 1e-9 <= points) & (points <= p_hi + 1e-9))
                assert np.all((nu_lo - 1e-12 <= normals) & (normals <= nu_hi + 1e-12))
                certificate = closure_prune(form, lo, hi, quality)
                around_closure += closed
                if certificate is not None:
                    certified += 1
                    assert not closed
                    assert np.all(W @ certificate.direction <= -CERTIFICATE_MARGIN)
    assert around_closure >= 60 and certified >= 60  # measured: 132 and 113 of 288 boxes


def test_the_interval_bound_bounds_every_cone_force():
    """``certified_bound`` is at least ``w . wrench`` for sampled contacts of the boxes and
    forces of their full friction cones (seeded random boxes, directions and models)."""
    rng = np.random.default_rng(9)
    for quality in MODELS:
        for _ in range(40):
            C = int(rng.integers(1, 5))
            p_lo = rng.uniform(-50, 50, (C, 3))
            p_hi = p_lo + rng.uniform(0, 20, (C, 3))
            n0 = rng.normal(size=(C, 3))
            n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
            n_lo, n_hi = n0 - rng.uniform(0, 0.3, (C, 3)), n0 + rng.uniform(0, 0.3, (C, 3))
            w = rng.uniform(-1, 1, 6)
            bound = certified_bound(w, p_lo, p_hi, n_lo, n_hi, np.zeros(3), 40.0, quality)
            for _ in range(20):
                p = rng.uniform(p_lo, p_hi)
                n = rng.uniform(n_lo, n_hi)
                n /= np.linalg.norm(n, axis=1, keepdims=True)
                inside = np.all((n_lo <= n) & (n <= n_hi), axis=1)
                if not inside.any():
                    continue
                fine = QualityOptions(friction=quality.friction, cone_edges=24, torsion_mm=quality.torsion_mm)
                W = primitive_wrenches(p[inside], n[inside], np.zeros(3), 40.0, fine).reshape(-1, 6)
                assert np.max(W @ w) <= bound + 1e-9


def test_regions_that_all_face_one_way_are_proven_to_admit_no_force_closure(tmp_path):
    """Three fingertips on one face of the box: infeasible, by certificate, and check re-proves it."""
    task = box_grasps.one_face_task()
    result = solve_complete(task, REQUIRE)
    assert result.status == Status.INFEASIBLE and "no force-closure grasp" in result.message
    assert result.stats["closure_pruned"] >= 1
    assert solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier())).status == Status.SOLVED  # the task itself has grasps: the proof is about force closure
    out = tmp_path / "one-face.result.json"
    assert main(["solve", str(EXAMPLES / "box-one-face.yaml"), "--method", "complete", "--require", "force-closure",
                 "-o", str(out), "--quiet"]) == EXIT_INFEASIBLE  # fmt: skip
    check = verify_result_file(out)
    assert check.holds and check.infeasibility_reproved and check.reproof.stats["closure_pruned"] >= 1


def test_the_four_finger_box_gets_a_force_closure_grasp(tmp_path):
    out = tmp_path / "four.result.json"
    assert main(["solve", str(EXAMPLES / "box-four-fingers.yaml"), "--method", "complete", "--require", "force-closure",
                 "-o", str(out), "--quiet"]) == EXIT_OK  # fmt: skip
    check = verify_result_file(out)
    assert check.holds
    assert any(f.what.endswith("force closure (required)") and f.ok for f in check.findings)


@pytest.mark.parametrize("seed", range(3))
def test_a_task_with_a_force_closure_grasp_is_never_proven_infeasible(sa_hand, seed):
    """Forward-built tasks whose known grasp is force closure: the search with the requirement
    (a short one) never answers infeasible."""
    rng = np.random.default_rng(7000 + seed)
    for _ in range(50):
        case = _fk_case(sa_hand, rng, near_box_grasp=True)
        if configuration_quality(case.task, case.config).force_closure:
            break
    else:
        pytest.fail("no force-closure forward-built task in 50 draws")
    result = solve_complete(case.task, BranchAndPruneOptions(verifier=LocalVerifier(), require="force-closure", max_boxes=6))
    assert result.status != Status.INFEASIBLE
    for s in result.solutions:
        assert configuration_quality(case.task, s.configuration()).force_closure


def test_the_local_solver_cannot_be_asked_for_a_proof(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", str(EXAMPLES / "box-one-face.yaml"), "--method", "local", "--require", "force-closure",
                 "-o", str(out)]) == EXIT_BAD_INPUT  # fmt: skip
    assert "--require force-closure needs the complete solver" in capsys.readouterr().err and not out.exists()


def test_auto_drops_the_local_answers_that_are_not_force_closure():
    """The one-face task: the local solver finds grasps, none force closure; auto then proves none."""
    task = box_grasps.one_face_task()
    assert solve(task, "local").success
    result = solve(task, SolveOptions(require="force-closure"))
    assert result.status == Status.INFEASIBLE and "no force-closure grasp" in result.message
    assert solve(task, SolveOptions(method="local", require="force-closure")).status == Status.GAVE_UP


def test_the_requirement_is_checked_and_stated():
    with pytest.raises(PrehensionError, match="require must be 'force-closure' or None"):
        BranchAndPruneOptions(verifier=LocalVerifier(), require="holds")
    with pytest.raises(PrehensionError, match="quality must be a QualityOptions"):
        BranchAndPruneOptions(verifier=LocalVerifier(), require="force-closure", quality={"friction": 0.5})


def test_a_contracted_root_box_is_certified_only_for_the_one_face_task():
    for task, proved in ((box_grasps.one_face_task(), True), (box_grasps.four_finger_task(), False)):
        form = build_system(task)
        lo, hi, empty = contract(form.system, form.system.lower, form.system.upper)
        assert not empty and (closure_prune(form, lo, hi, QualityOptions()) is not None) == proved
