"""Task variants: one object region moved or turned."""

from __future__ import annotations

import numpy as np
import pytest

from prehension.errors import InvalidTask
from prehension.tasks.library import load_builtin_task
from prehension.tasks.variants import move_object_region, turn_object_region


@pytest.fixture(scope="module")
def lid():
    return load_builtin_task("teapot-lid-lifting")


def test_moving_a_region_shifts_it_and_nothing_else(lid):
    moved = move_object_region(lid, "knob_back", (0, 0, 25))
    before, after = lid.object.regions["knob_back"].patch, moved.object.regions["knob_back"].patch
    assert np.allclose(after.control_points - before.control_points, [0, 0, 25])
    assert moved.object.regions["knob_front"] is lid.object.regions["knob_front"]
    assert moved.contacts == lid.contacts and "+25 mm" in moved.name


def test_turning_a_region_half_a_turn_reverses_its_normals(lid):
    turned = turn_object_region(lid, "knob_front", (0, 1, 0), 180)
    st = np.array([[0.5, 0.5], [0.2, 0.7]])
    _, n_before = lid.object.regions["knob_front"].evaluate(st)
    _, n_after = turned.object.regions["knob_front"].evaluate(st)
    R = np.diag([-1.0, 1.0, -1.0])  # half a turn about y
    assert np.allclose(n_after, n_before @ R.T, atol=1e-12)


def test_unknown_region_is_named_with_the_valid_ones(lid):
    with pytest.raises(InvalidTask, match="knob_front"):
        move_object_region(lid, "spout", (0, 0, 1))
