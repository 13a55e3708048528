"""The complete solver's collision prune: sound enclosures, no known solution lost, and a
task that is infeasible only because of the object is certified so (issue 12, item 4)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fk_tasks import box_around, build_fk_case, perturbed, search_path
from tiny_tasks import pit_task
from prehension.errors import InvalidObject
from prehension.geometry.regions import SphereCap
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.meshes import Sphere
from prehension.objects.model import GraspObject
from prehension.objects.solid import PrimitiveSolid
from prehension.results import Status, write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solvers.complete.collision import collision_probes, collision_prune, probe_enclosures
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.tasks.idle import settle_idle_fingers
from prehension.tasks.model import Configuration, Task
from prehension.tasks.object_collision import link_penetrations
from prehension.verification.residuals import Tolerances, evaluate
from prehension.verification import verify_result_file
from prehension.solvers.local.verifier import LocalVerifier

TOLS = Tolerances()  # strict, as every verified solution
TOL = TOLS.object_penetration_mm  # 0.5 mm


# -- forward-built tasks on solids -------------------------------------------------------
def _solid_under(region) -> Sphere:
    """A sphere the region lies on: a cap's own sphere, or one of radius 15 mm under a point."""
    if isinstance(region, SphereCap):
        return Sphere(tuple(region.center), float(region.radius))
    return Sphere(tuple(region.point - 15.0 * region.normal), 15.0)


def _fk_case_on_spheres(hand, seed: int):
    """A forward-built task whose object is the union of spheres under its contacts (or
    None when the spheres swallow a contact point)."""
    rng = np.random.default_rng(seed)
    case = build_fk_case(hand, rng, kinds=tuple(rng.choice(["point", "cap"], size=4)), palm=False)
    regions = dict(case.task.object.regions)
    solid = PrimitiveSolid(tuple(_solid_under(r) for r in regions.values()))
    try:
        obj = GraspObject("spheres", regions, solid=solid)
    except InvalidObject:
        return None
    task = Task("fk-spheres", hand, obj, case.task.contacts, case.task.fingers)
    return task, settle_idle_fingers(task, case.config)


def _deepest_on(task, config, link: str) -> float:
    """The residual function's depth of ``link``, or of a pad on it, whichever is deeper [mm]."""
    pads_on = {c.name for c in task.contacts if task.hand_region(c).link == link}
    return max([c.value for c in evaluate(task, config).checks
                if (c.kind == "object_collision" and c.name == link) or (c.kind == "pad_collision" and c.name in pads_on)] + [0.0])  # fmt: skip


def _penetration_free(task, config) -> bool:
    return all(c.ok for c in evaluate(task, config).checks if c.kind in ("object_collision", "pad_collision"))


def _probe_points_in_object(task, probes, config) -> np.ndarray:
    """(K, 3) every probe's point for one configuration, object frame, by forward kinematics."""
    pose = forward_kinematics(task.hand, config.joint_angles)
    li = np.array([task.hand.link_index(name) for name in probes.link])
    R, r = pose.R_palm_link[0, li], pose.r_palm_link[0, li]
    p_palm = np.einsum("kij,kj->ki", R, probes.point_in_link) + r  # (K, 3)
    T = config.T_palm_object
    return (p_palm - T[:3, 3]) @ T[:3, :3]


# seeds whose configuration is penetration-free (5), then some whose is not (4)
SEEDS = (7005, 7006, 7009, 7012, 7020, 7000, 7003, 7004, 7007)


@pytest.fixture(scope="module")
def sphere_cases(sa_hand):
    cases = [_fk_case_on_spheres(sa_hand, seed) for seed in SEEDS]
    assert all(c is not None for c in cases)
    return cases


def test_enclosures_hold_the_link_points_of_every_configuration_in_the_box(sphere_cases):
    """(a) Many seeded random boxes, each the hull of several configurations grown at
    random: every probe point (or, outside the system, its joint centre within ``extra``)
    of every one of those configurations lies in its enclosure."""
    rng = np.random.default_rng(11)
    checked = 0
    for task, config in sphere_cases:
        form = build_system(task)
        probes = collision_probes(form)
        assert probes is not None and probes.size > 20
        for _ in range(6):
            size = 10.0 ** rng.uniform(-4, -0.5)
            configs = [config] + [perturbed(rng, config, size) for _ in range(4)]
            points = np.array([embed(form, c) for c in configs])
            lower, upper = box_around(rng, form, points, 10.0 ** rng.uniform(-6, -0.5))
            lo, hi = probe_enclosures(probes, lower, upper)
            for c in configs:
                p = _probe_points_in_object(task, probes, c)
                outside = np.linalg.norm(np.maximum(lo - p, 0.0) + np.maximum(p - hi, 0.0), axis=1)
                assert np.all(outside <= probes.extra + 1e-9), (task.name, probes.link[int(np.argmax(outside - probes.extra))])
                checked += 1
    assert checked == len(SEEDS) * 6 * 5


def test_enclosures_through_the_contacts_hold_every_solution_and_are_tighter(sphere_cases):
    """(a, contact anchors) Boxes of every size around each known configuration (its
    contacts made): the enclosures intersected with those through the contacts still hold
    its probe points, and they are tighter than the chain from the palm alone."""
    rng = np.random.default_rng(13)
    tighter = 0
    for task, config in sphere_cases:
        form = build_system(task)
        probes = collision_probes(form)
        assert len(probes.anchors) == len(task.contacts)  # every SA fingertip is a cap
        x = embed(form, config)
        p = _probe_points_in_object(task, probes, config)
        for _ in range(8):
            lower, upper = box_around(rng, form, x[None], 10.0 ** rng.uniform(-7, -0.5))
            lo, hi = probe_enclosures(probes, lower, upper, form, TOLS)
            outside = np.linalg.norm(np.maximum(lo - p, 0.0) + np.maximum(p - hi, 0.0), axis=1)
            assert np.all(outside <= probes.extra + 1e-9), (task.name, probes.link[int(np.argmax(outside - probes.extra))])
            palm_lo, palm_hi = probe_enclosures(probes, lower, upper)
            tighter += bool(np.sum(hi - lo) < 0.5 * np.sum(palm_hi - palm_lo))
    assert tighter >= len(sphere_cases) * 4


def test_probes_inside_the_system_are_exact_and_idle_ones_reach_from_their_joint(sphere_cases):
    task, config = sphere_cases[0]
    form = build_system(task)
    probes = collision_probes(form)
    x = embed(form, config)
    lo, hi = probe_enclosures(probes, x, x)  # a point box: the enclosure is the point (to rounding)
    p = _probe_points_in_object(task, probes, config)
    inside = probes.extra == 0.0
    assert inside.any() and (~inside).any()  # idle fingers have probes too
    np.testing.assert_allclose(0.5 * (lo + hi)[inside], p[inside], atol=1e-9)
    assert np.all(hi - lo < 1e-6)
    assert {n for n, e in zip(probes.link, probes.extra) if e > 0} <= {
        link for f in task.hand.fingers if f.name not in task.fingers for link in f.links
    } | {link.name for link in task.hand.links if link.name not in form.links}


def test_the_prune_never_discards_a_box_holding_a_penetration_free_solution(sphere_cases):
    """(b) Forward-built tasks on solids: around each known penetration-free configuration,
    boxes from a point up to the initial box, and every box of the search's own path down to
    it (contracted, shrunk, split), are never pruned for collision."""
    rng = np.random.default_rng(12)
    tried = 0
    for task, config in sphere_cases:
        if not _penetration_free(task, config):
            continue
        form = build_system(task)
        x = embed(form, config)
        boxes = [(x, x), (form.system.lower, form.system.upper)]
        boxes += [box_around(rng, form, x[None], 10.0 ** rng.uniform(-9, 0)) for _ in range(12)]
        for lower, upper in boxes:
            assert collision_prune(form, lower, upper, TOLS) is None
        tried += 1
    assert tried == 5


def test_a_point_box_is_pruned_only_for_a_link_the_residual_function_finds_too_deep(sphere_cases):
    """At a single configuration the prune is a verdict on it: when it fires, the residual
    function finds the link it names deeper than the tolerance (and it does fire on some)."""
    fired = 0
    for task, config in sphere_cases:
        form = build_system(task)
        x = embed(form, config)
        proof = collision_prune(form, x, x, TOLS)
        if proof is not None:
            assert _deepest_on(task, config, proof.link) > TOL
            fired += 1
    assert fired >= 2


def test_search_path_to_a_known_solution_is_never_cut_by_collision(sphere_cases):
    task, config = sphere_cases[1]  # two contacts, penetration-free
    assert _penetration_free(task, config)
    form = build_system(task)
    for out in search_path(form, embed(form, config)):
        assert not out.by_collision


# -- a task whose only contact configurations pass through the object -------------------
def test_a_task_infeasible_only_through_the_object_is_certified_and_re_proved(tmp_path, capsys):
    """(c) Every way of touching the pit's floor puts the palm into its walls: certified
    infeasible with the collision prune named, ``prehension check`` proves it again, and
    without the prune the same search cannot end."""
    from prehension.cli import EXIT_INFEASIBLE, main

    task = pit_task(15.0)
    result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert result.status == Status.INFEASIBLE and not result.solutions
    assert "no penetration-free solution" in result.message and result.stats["collision_pruned"] > 0
    assert f"{result.stats['collision_pruned']} of them because every configuration" in result.message
    out = tmp_path / "pit.json"
    write_result(result, out, quality_entries(result), approach_entries_of(result))
    assert json.loads(out.read_text())["stats"]["collision_pruned"] == result.stats["collision_pruned"]
    assert main(["check", str(out)]) == EXIT_INFEASIBLE
    assert "the proof was run again on the embedded task and holds" in capsys.readouterr().out
    again = next(f for f in verify_result_file(out).findings if f.what == "infeasibility re-proved")
    assert again.ok and f"{result.stats['collision_pruned']} of them for hand-object collision: no penetration-free" in again.detail
    boxes = result.stats["boxes"]
    off = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=3 * boxes, collision_prune=False, verify_starts=1))
    assert off.status == Status.GAVE_UP and off.stats["collision_pruned"] == 0 and not off.solutions


def test_a_wide_pit_is_solved_by_the_same_search_and_a_proud_sphere_is_not_excused():
    """The same task with the pit wide enough for the palm: solved, penetration-free, and
    not pruned at the solution's own point box.  With the palm's tip sphere 1.5 mm proud of
    its point pad (which has no volume and excuses nothing) every touch of the floor sinks
    it 1.5 mm: certified infeasible by the collision prune (before issue 26 the zone around
    the contact excused it)."""
    task = pit_task(120.0)
    result = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert result.status == Status.SOLVED
    solution = result.solutions[0]
    assert solution.report.worst("object_collision") <= TOL and solution.report.worst("pad_collision") <= TOL
    config = solution.configuration()
    form = build_system(task)
    x = embed(form, config)
    assert collision_prune(form, x, x, TOLS) is None
    proud = pit_task(120.0, proud_mm=1.5)
    pose = forward_kinematics(proud.hand, config.joint_angles)
    T = config.T_palm_object
    points = [(s.hand_point - T[:3, 3]) @ T[:3, :3] for s in solution.report.contacts]
    assert link_penetrations(proud, pose, T, points)["palm"] == pytest.approx(1.5, abs=0.13)  # pad or no pad
    again = solve_complete(proud, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=60))
    assert again.status == Status.INFEASIBLE and again.stats["collision_pruned"] > 0


def test_the_prune_gives_the_same_certificate_on_an_executor():
    """Boxes processed ahead on workers: the same boxes, the same collision prunes."""
    from concurrent.futures import ThreadPoolExecutor

    task = pit_task(15.0)
    options = BranchAndPruneOptions(verifier=LocalVerifier(), verify_starts=2)
    alone = solve_complete(task, options)
    with ThreadPoolExecutor(2) as pool:
        pooled = solve_complete(task, options, executor=pool, workers=2)
    assert alone.status == pooled.status == Status.INFEASIBLE
    for key in ("boxes", "lps", "collision_pruned"):
        assert pooled.stats[key] == alone.stats[key] > 0


def test_a_resumed_search_keeps_its_count_of_collision_prunes(tmp_path):
    task = pit_task(15.0)
    options = BranchAndPruneOptions(verifier=LocalVerifier(), verify_starts=2)
    whole = solve_complete(task, options)
    ckpt = tmp_path / "pit-search.json"
    first = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), verify_starts=2, max_boxes=whole.stats["boxes"] // 2), checkpoint=ckpt)
    assert first.status == Status.GAVE_UP and 0 < first.stats["collision_pruned"] < whole.stats["collision_pruned"]
    resumed = solve_complete(task, options, checkpoint=ckpt, resume=True)
    assert resumed.status == Status.INFEASIBLE
    assert resumed.stats["collision_pruned"] == whole.stats["collision_pruned"] and resumed.stats["boxes"] == whole.stats["boxes"]


@pytest.mark.parametrize("name", ["teapot-lid-lifting", "teapot-service", "guitar-tuning", "scalpel-upholding"])
def test_the_prune_never_discards_a_box_around_a_builtin_answer(name):
    """Real meshes and fingertip pads: around each built-in task's verified local answer
    (which the residual function accepts, pads and all), the point box and seeded random
    boxes up to the initial box are never pruned for collision; and the object pushed
    3 mm into the first pad along its normal is pruned at its point box for that pad's
    link (the residual function rejects it too)."""
    from prehension.solve import solve
    from prehension.tasks.library import load_builtin_task

    task = load_builtin_task(name)
    solution = solve(task, "local").solutions[0]
    config = solution.configuration()
    assert _penetration_free(task, config)
    form = build_system(task)
    x = embed(form, config)
    rng = np.random.default_rng(len(name))
    boxes = [(x, x), (form.system.lower, form.system.upper)]
    boxes += [box_around(rng, form, x[None], 10.0 ** rng.uniform(-9, -1)) for _ in range(10)]
    for lower, upper in boxes:
        assert collision_prune(form, lower, upper, TOLS) is None
    state = solution.report.contacts[0]
    T = config.T_palm_object.copy()
    T[:3, 3] -= 3.0 * state.hand_normal  # into the first pad: 3 mm deep
    sunk = Configuration(config.joint_angles, T, config.contact_params)
    assert not _penetration_free(task, sunk)
    xs = embed(form, sunk)
    proof = collision_prune(form, xs, xs, Tolerances(contact_mm=np.inf, normal_deg=np.inf))  # contacts not made: no anchors
    assert proof is not None and _deepest_on(task, sunk, proof.link) > TOL  # the residual function agrees
