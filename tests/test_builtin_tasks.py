"""The nine built-in tasks of Table 2 load, are consistent, and round-trip."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.errors import InvalidTask
from prehension.paper import TABLE2
from prehension.tasks.library import builtin_task_names, load_builtin_task, resolve_task
from prehension.tasks.yaml_io import dumps_task, loads_task, task_to_dict

NINE = {
    "scalpel-upholding", "scalpel-handling", "scalpel-incision",
    "teapot-lid-lifting", "teapot-service", "teapot-transportation",
    "guitar-tuning", "guitar-playing", "guitar-holding",
}  # fmt: skip


def test_the_nine_tasks_of_table2_are_built_in():
    assert set(builtin_task_names()) == NINE == set(TABLE2)


@pytest.mark.parametrize("name", sorted(NINE))
def test_builtin_task_is_consistent(name):
    task = load_builtin_task(name)
    assert task.name == name
    assert task.hand.name == "schunk-sa" and len(task.hand.couplings) == 4
    expected_contacts = {"upholding": 2, "lid-lifting": 2, "tuning": 2, "handling": 3, "service": 3, "playing": 3}
    assert len(task.contacts) == expected_contacts.get(name.split("-", 1)[1], 4)
    assert "thumb" in task.fingers or name == "teapot-transportation"
    for c in task.contacts:
        region = task.object_region(c)
        _, normals = region.evaluate(region.seed_params(4))
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    assert task.object.display_mesh().faces.shape[0] > 0
    counts = task.counts()
    assert counts["equations"] == 5 * len(task.contacts)
    assert counts["dimension"] > 0


@pytest.mark.parametrize("name", sorted(NINE))
def test_builtin_task_round_trips(name):
    task = load_builtin_task(name)
    again = loads_task(dumps_task(task))
    assert task_to_dict(again) == task_to_dict(task)


def test_builtin_tasks_use_the_mechanical_limits_not_the_files():
    hand = load_builtin_task("teapot-transportation").hand
    i = hand.dof_index("index_mcp_flex")
    assert np.degrees([hand.lower[i], hand.upper[i]]) == pytest.approx([-4.0, 75.0])


def test_resolve_task_names_what_is_valid(tmp_path):
    with pytest.raises(InvalidTask, match="neither a built-in task.*built-in tasks are: guitar-holding"):
        resolve_task("teapot")
    assert resolve_task("guitar-tuning").name == "guitar-tuning"
    path = tmp_path / "t.yaml"
    path.write_text(dumps_task(load_builtin_task("guitar-tuning")))
    assert resolve_task(path).name == "guitar-tuning"
