"""Result files state which collision geometry judged them (issue 26 item 2)."""

from __future__ import annotations

import copy

import pytest

from conftest import HANDS_DIR
from prehension.hands.urdf import hand_from_urdf
from prehension.results import SolveResult, result_to_dict
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.tasks.geometry_record import check_collision_geometry, collision_geometry
from prehension.tasks.library import load_builtin_task
from prehension.tasks.yaml_io import hand_from_dict, hand_to_dict, task_from_dict, task_to_dict
from prehension.verification import verify_result

ALLEGRO = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"


def test_link_fit_survives_an_inline_hand():
    hand = load_builtin_task("teapot-lid-lifting").hand
    back = hand_from_dict(hand_to_dict(hand))
    assert [link.fit for link in back.links] == [link.fit for link in hand.links]
    assert back.links[0].fit.miss_mm > 0  # the SA palm's capsules miss its published mesh


@pytest.mark.skipif(not ALLEGRO.exists(), reason="needs ../shared/hands")
def test_link_fit_of_a_urdf_hand_survives_an_inline_hand_and_a_task(tmp_path):
    hand = hand_from_urdf(ALLEGRO)
    assert all(link.fit is not None for link in hand.links if link.collision)
    back = hand_from_dict(hand_to_dict(hand))
    assert [link.fit for link in back.links] == [link.fit for link in hand.links]
    task = load_builtin_task("teapot-lid-lifting")
    entry = collision_geometry(task)
    again = task_from_dict(task_to_dict(task, hand_inline=True), base_dir=tmp_path)
    assert collision_geometry(again) == entry


def test_every_result_states_its_geometry_and_a_batch_record_the_short_form():
    task = load_builtin_task("teapot-lid-lifting")
    result = SolveResult(task, "local", "gave_up", "nothing found")
    whole = result_to_dict(result, quality_entries(result), approach_entries_of(result))["collision_geometry"]
    short = result_to_dict(result, quality_entries(result), approach_entries_of(result), embed_task=False)["collision_geometry"]
    assert whole["hand"].startswith("schunk-sa: 14 links") and whole["digest"].startswith("sha256:")
    assert set(whole["links"]) == {link.name for link in task.hand.links}
    assert short == {k: v for k, v in whole.items() if k != "links"}
    assert whole["encloses"].startswith("no: capsules miss up to 48.31 mm")
    assert "teapot" in whole["object"]
    assert check_collision_geometry(task, short)[0] and check_collision_geometry(task, whole)[0]


def test_check_names_what_differs_and_accepts_older_files():
    task = load_builtin_task("teapot-lid-lifting")
    result = SolveResult(task, "local", "gave_up", "nothing found")
    data = result_to_dict(result, quality_entries(result), approach_entries_of(result))
    wrong = copy.deepcopy(data["collision_geometry"])
    wrong["object"] = "none"
    ok, detail = check_collision_geometry(task, wrong)
    assert not ok and detail.startswith("object: the file says 'none'")
    assert not check_collision_geometry(task, [1, 2])[0]
    older = copy.deepcopy(data)
    del older["collision_geometry"]
    checked = verify_result(older, reprove=False)
    assert checked.holds
    assert any(f.what == "collision geometry" and "not stated" in f.detail for f in checked.findings)
