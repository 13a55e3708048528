"""``solve(task, SolveOptions)``: the options object, its validation, and the one ``auto``
policy (:func:`prehension.solve.complete_after_local`) that ``solve`` and ``batch`` share."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import prehension
from prehension.errors import PrehensionError
from prehension.results import Status, result_to_dict
from prehension.solve import SolveOptions, complete_after_local, solve, solve_locally
from tiny_tasks import pincer_task


@pytest.mark.parametrize(
    "fields,match",
    [
        ({"method": "fast"}, "method must be 'auto', 'local' or 'complete', got 'fast'"),
        ({"require": "closure"}, "require must be 'force-closure' or None"),
        ({"time_limit_s": 0}, "time_limit_s must be a number of seconds > 0 or None, got 0"),
        ({"time_limit_s": "10"}, "time_limit_s must be a number of seconds > 0"),
    ],
)
def test_bad_options_are_refused_naming_what_would_be_valid(fields, match):
    with pytest.raises(PrehensionError, match=match):
        SolveOptions(**fields)


def test_solve_takes_options_or_a_method_name_and_nothing_else():
    task = pincer_task(40.0)
    by_name = solve(task, "local")
    by_options = solve(task, SolveOptions(method="local"))
    assert by_name.success and by_name.method == "local"
    assert np.array_equal(by_name.solutions[0].q, by_options.solutions[0].q)
    with pytest.raises(PrehensionError, match="options must be a SolveOptions or a method name, got int"):
        solve(task, 3)
    assert prehension.SolveOptions is SolveOptions and SolveOptions().method == "auto"


def test_auto_is_the_local_answer_then_the_complete_one_from_it():
    """``solve(auto)`` is ``solve_locally`` then ``complete_after_local``: the same answer."""
    far = pincer_task(60.0)  # beyond reach: the local solver fails, the complete one proves it
    options = SolveOptions(seed=4)
    local = solve_locally(far, options)
    assert local.status == Status.GAVE_UP
    after = complete_after_local(far, local, options)
    whole = solve(far, options)
    assert after.status == whole.status == Status.INFEASIBLE
    assert after.message == whole.message and after.message.startswith(f"the local solver found no solution ({local.message})")
    assert after.stats["local"] == dict(local.stats) and after.stats["boxes"] == whole.stats["boxes"]


def test_a_solved_local_answer_is_the_answer_and_no_time_left_says_so():
    near, far = pincer_task(40.0), pincer_task(60.0)
    solved = solve_locally(near, SolveOptions(seed=1))
    assert solved.success and complete_after_local(near, solved, SolveOptions()) is solved
    failed = solve_locally(far, SolveOptions())
    spent = replace(failed, seconds=5.0)  # the local stage already took all of a 2 s limit
    answer = complete_after_local(far, spent, SolveOptions(time_limit_s=2.0))
    assert answer.status == Status.GAVE_UP and answer.method == "local"
    assert answer.message.endswith("the time limit (2 s) was reached before the complete solver could start")


def test_a_result_file_stores_the_quality_it_is_given_and_refuses_a_wrong_count():
    result = solve(pincer_task(40.0), "local")
    entries = [{"stated": "by the caller"}]
    assert result_to_dict(result, entries)["solutions"][0]["quality"] == {"stated": "by the caller"}
    for wrong, said in (([], "0 quality entries"), (None, "NoneType as quality entries"), ({}, "dict as quality entries")):
        with pytest.raises(PrehensionError, match=f"{said} given for 1 solutions"):
            result_to_dict(result, wrong)
