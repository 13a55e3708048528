"""Result files report each solution's quality, and `check` re-derives it."""

from __future__ import annotations

import copy
import json
from types import SimpleNamespace

import numpy as np
import pytest

from prehension.cli import EXIT_CHECK_FAILED, EXIT_OK, main
from prehension.geometry.regions import PointRegion
from prehension.objects.model import GraspObject
from prehension.quality import QualityOptions, check_quality_entry, grasp_quality, quality_entries, quality_entry
from prehension.pregrasp import approach_entries_of
from prehension.results import result_to_dict
from prehension.solve import solve
from prehension.tasks.library import load_builtin_task
from prehension.verification import verify_result

SOFT = QualityOptions(torsion_mm=5.0)


@pytest.fixture(scope="module")
def lid():
    result = solve(load_builtin_task("teapot-lid-lifting"), "local")
    assert result.success
    return result


def test_every_solution_states_its_quality_and_the_friction_model(lid):
    data = result_to_dict(lid, quality_entries(lid, SOFT), approach_entries_of(lid))
    q = data["solutions"][0]["quality"]
    expected = grasp_quality(lid.task, lid.solutions[0], SOFT)
    assert q["force_closure"] is True and q["epsilon"] == expected.epsilon > 0
    assert q["options"] == {"friction": 0.6, "cone_edges": 8, "torsion_mm": 5.0, "radius_mm": None, "center_mm": None}
    assert q["radius_mm"] == pytest.approx(expected.radius_mm) and len(q["center_mm"]) == 3
    hard = result_to_dict(lid, quality_entries(lid), approach_entries_of(lid))["solutions"][0]["quality"]  # default: hard fingers; a pinch is no closure
    assert hard["force_closure"] is False and hard["epsilon"] == 0.0


def test_check_re_derives_the_quality(lid, tmp_path, capsys):
    data = result_to_dict(lid, quality_entries(lid, SOFT), approach_entries_of(lid))
    checked = verify_result(copy.deepcopy(data), reprove=False)
    found = [f for f in checked.findings if "quality" in f.what]
    assert checked.holds and found and "force closure, epsilon" in found[0].detail
    path = tmp_path / "lid.json"
    path.write_text(json.dumps(data))
    assert main(["check", str(path)]) == EXIT_OK
    assert "quality" in capsys.readouterr().out


def _epsilon(data):
    data["solutions"][0]["quality"]["epsilon"] *= 1.5


def _closure(data):
    data["solutions"][0]["quality"]["force_closure"] = False


def _friction(data):
    data["solutions"][0]["quality"]["options"]["friction"] = 0.9  # the stored measures are for 0.6


def _radius(data):
    data["solutions"][0]["quality"]["radius_mm"] = 10.0


def _bad_options(data):
    data["solutions"][0]["quality"]["options"] = {"mu": 0.6}


TAMPERS = [_epsilon, _closure, _friction, _radius, _bad_options]


@pytest.mark.parametrize("tamper", TAMPERS, ids=[t.__name__.strip("_") for t in TAMPERS])
def test_a_tampered_quality_is_caught(lid, tamper, tmp_path, capsys):
    data = result_to_dict(lid, quality_entries(lid, SOFT), approach_entries_of(lid))
    tamper(data)
    checked = verify_result(data, reprove=False)
    assert not checked.holds and any("quality" in f.what for f in checked.failures)
    path = tmp_path / "r.json"
    path.write_text(json.dumps(data))
    assert main(["check", str(path), "--no-reprove"]) == EXIT_CHECK_FAILED
    assert "DOES NOT HOLD" in capsys.readouterr().out


def test_a_file_from_before_quality_still_holds(lid):
    data = result_to_dict(lid, quality_entries(lid), approach_entries_of(lid))
    del data["solutions"][0]["quality"]
    checked = verify_result(data, reprove=False)
    assert checked.holds and any(f.detail.startswith("not stated") for f in checked.findings)


def test_an_object_without_size_states_why_its_quality_is_unavailable():
    task = SimpleNamespace(object=GraspObject("dot", {"A": PointRegion((0, 0, 0), (1, 0, 0))}))
    contacts = [SimpleNamespace(object_point=np.zeros(3), object_normal=np.array([1.0, 0, 0]))]
    entry = quality_entry(task, np.eye(4), contacts)
    assert "no size to scale torques" in entry["unavailable"]
    assert check_quality_entry(task, np.eye(4), contacts, entry)[0]
    stated = quality_entry(task, np.eye(4), contacts, QualityOptions(radius_mm=10.0))  # a stated radius makes it computable
    assert stated["force_closure"] is False and stated["radius_mm"] == 10.0
    assert not check_quality_entry(task, np.eye(4), contacts, dict(entry, options=stated["options"]))[0]
