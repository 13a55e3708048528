"""What a batch task costs beyond the solve (issue 16): the quality measured once per
distinct grasp (the same values, bit for bit), and a chunk's seconds per stage."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

from prehension.batch.records import STAGES, ChunkOutput
from prehension.batch.run import _wire
from prehension.batch.inputs import read_inputs
from prehension.batch.solving import BatchOptions, solve_chunk
from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, contact_quality, force_closure, hull_measures, primitive_wrenches, quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.quality import grasp as grasp_module
from prehension.results import result_to_dict
from prehension.solve import SolveOptions, solve
from prehension.tasks.library import load_builtin_task
from conftest import write_jsonl


def random_grasp(rng, n_contacts):
    d = rng.normal(size=(n_contacts, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    n = -d + 0.2 * rng.normal(size=(n_contacts, 3))
    return 30 * d, n / np.linalg.norm(n, axis=1, keepdims=True)


def measured_afresh(p, n, centre, radius, options):
    """The measures straight from their definition (no memo)."""
    W = primitive_wrenches(p, n, centre, radius, options).reshape(-1, 6)
    closure = force_closure(W)
    distance, volume = hull_measures(W)
    return closure.force_closure, (max(distance, 0.0) if closure.force_closure else 0.0), volume, closure.margin


def test_a_grasp_met_again_gets_bit_identical_measures_without_measuring_again(rng):
    grasp_module.clear_memo()
    for _ in range(12):
        p, n = random_grasp(rng, int(rng.integers(3, 6)))
        centre, options = rng.normal(size=3), QualityOptions(friction=float(rng.uniform(0.2, 0.9)))
        first = contact_quality(p, n, centre, 30.0, options)
        again = contact_quality(p.copy(), n.copy(), centre.copy(), 30.0, options)
        assert again is first  # the memo's entry
        fresh = measured_afresh(p, n, centre, 30.0, options)
        assert (first.force_closure, first.epsilon, first.volume, first.closure_margin) == fresh  # exactly
        assert first.center_mm == tuple(centre.tolist()) and first.radius_mm == 30.0
    info = grasp_module._measured.cache_info()
    assert (info.hits, info.misses) == (12, 12)


def test_a_grasp_one_bit_apart_or_with_other_options_is_measured_afresh(rng):
    grasp_module.clear_memo()
    p, n = random_grasp(rng, 4)
    first = contact_quality(p, n, np.zeros(3), 30.0)
    nudged = p.copy()
    nudged[0, 0] = np.nextafter(nudged[0, 0], np.inf)
    for other in (
        contact_quality(nudged, n, np.zeros(3), 30.0),
        contact_quality(p, n, np.zeros(3), np.nextafter(30.0, 0.0)),
        contact_quality(p, n, np.zeros(3), 30.0, QualityOptions(cone_edges=6)),
        contact_quality(p, n, np.array([0.0, 0.0, 1e-300]), 30.0),
    ):
        assert other is not first
    assert grasp_module._measured.cache_info().misses == 5
    assert grasp_module._measured.cache_info().hits == 0


def test_the_object_reference_is_cached_per_object_and_equals_the_computed_one():
    from prehension.quality.solid import object_center, object_reference

    task = load_builtin_task("teapot-service")
    centre, radius = grasp_module.torque_reference(task, QualityOptions())
    expected_centre, expected_radius = object_reference(task.object, object_center(task.object))
    assert np.array_equal(centre, expected_centre) and radius == expected_radius
    centre[:] = 0.0  # a caller's copy: the cache is not touched
    assert np.array_equal(grasp_module.torque_reference(task, QualityOptions())[0], expected_centre)


def test_given_quality_entries_are_stored_as_given_and_must_match_the_solutions():
    result = solve(load_builtin_task("guitar-tuning"), SolveOptions(method="local", seed=0))
    assert result.success
    measured = result_to_dict(result, quality_entries(result), approach_entries_of(result))["solutions"][0]["quality"]
    given = result_to_dict(result, [measured])["solutions"][0]["quality"]
    assert given is measured
    with pytest.raises(PrehensionError, match="0 quality entries given for 1 solutions"):
        result_to_dict(result, [])


def test_a_chunk_reports_its_seconds_per_stage_and_they_fit_in_its_records(tmp_path):
    path = write_jsonl(tmp_path / "tasks.jsonl", [{"task": "guitar-tuning"}, {"id": "again", "task": "guitar-tuning"}])
    payload = {"kind": "yaml", "text": "hand: [", "source": "bad.yaml", "base_dir": str(tmp_path)}
    bad = {"id": "bad", "name": "bad", "source": "test", "payload": payload}
    output = solve_chunk([_wire(e) for e in read_inputs(path)] + [bad], BatchOptions(method="local"))
    assert [json.loads(r.line)["status"] for r in output.records] == ["invalid", "solved", "solved"]
    assert tuple(output.stages) == STAGES
    assert all(0 < cpu <= wall + 0.01 for wall, cpu in output.stages.values())  # (wall, CPU of the thread) [s]
    seconds = sum(json.loads(r.line)["seconds"] for r in output.records)
    before_the_record = sum(output.stages[s][0] for s in STAGES if s != "record")
    assert before_the_record == pytest.approx(seconds, rel=1e-9)  # a record's seconds: its stages until its record
    assert pickle.loads(pickle.dumps(output)) == output  # it travels back from a worker as it is
    assert ChunkOutput([], {}).stages == {}  # the client's error chunks have none


def test_the_closure_margin_without_presolve_is_the_lp_optimum(rng):
    """``t*`` of the force-closure LP (HiGHS, no presolve) against scipy's ``linprog`` on the
    same LP written independently (dense, HiGHS with its presolve)."""
    from scipy.optimize import linprog

    from prehension.quality.measures import _positive_combination_margin

    positive = 0
    for _ in range(25):
        p, n = random_grasp(rng, int(rng.integers(3, 6)))
        W = primitive_wrenches(p, n, np.zeros(3), 30.0, QualityOptions(friction=float(rng.uniform(0.2, 0.9)))).reshape(-1, 6)
        K = len(W)
        A_eq = np.vstack([np.c_[W.T, np.zeros(6)], np.r_[np.ones(K), 0.0]])  # sum lambda_k w_k = 0, sum lambda_k = 1
        A_ub = np.c_[-np.eye(K), np.ones(K)]  # t - lambda_k <= 0
        lp = linprog(np.r_[np.zeros(K), -1.0], A_ub=A_ub, b_ub=np.zeros(K), A_eq=A_eq, b_eq=np.r_[np.zeros(6), 1.0],
                     bounds=[(0, 1)] * (K + 1), method="highs")  # fmt: skip
        expected = max(-lp.fun, 0.0) if lp.status == 0 else 0.0
        assert _positive_combination_margin(W) == pytest.approx(expected, rel=1e-9, abs=1e-12)
        positive += expected > 1e-9
    assert positive >= 5  # force-closure grasps among them, not only zeros

