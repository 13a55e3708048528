"""A checkpoint is a file a user can edit: changes are refused, fields validated, and a
search resumed from one says so and is re-proved by ``check`` (issue 28, item 6)."""

from __future__ import annotations

import json
from collections import deque

import numpy as np
import pytest

from prehension.cli import EXIT_BAD_INPUT, main
from prehension.errors import PrehensionError
from prehension.results import Status, result_to_dict
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.solvers.complete.checkpoint import SearchState, _content_digest, save_state, search_fingerprint
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.system.formulation import build_system
from prehension.tasks.yaml_io import dumps_task
from prehension.verification import verify_result
from prehension.solvers.local.verifier import LocalVerifier
from tiny_tasks import pincer_task

NO_PAIR = BranchAndPruneOptions(verifier=LocalVerifier(), pair_test_boxes=0, time_limit_s=120)


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A checkpoint of the infeasible pincer (d = 50 mm) after 3 boxes: ``(path, its JSON)``."""
    path = tmp_path_factory.mktemp("ckpt") / "search.json"
    solve_complete(pincer_task(50.0), BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=3, pair_test_boxes=0), checkpoint=path)
    return path, json.loads(path.read_text())


@pytest.fixture(scope="module")
def resumed(saved):
    """The search resumed from ``saved`` (to its end: infeasible)."""
    return _resume(saved[0])


def _write(path, data, *, digest: bool = True):
    """``data`` written as a checkpoint; with ``digest``, its digest recomputed (a forger's edit)."""
    data = dict(data)
    if digest:
        data["digest"] = _content_digest(data)
    path.write_text(json.dumps(data))
    return path


def _resume(path, d: float = 50.0):
    return solve_complete(pincer_task(d), NO_PAIR, checkpoint=path, resume=True)


def test_a_checkpoint_carries_a_digest_of_its_content(saved, resumed):
    path, data = saved
    assert data["digest"] == _content_digest(data) and len(data["digest"]) == 64
    assert resumed.status == Status.INFEASIBLE
    assert resumed.stats["resumed"] == {"checkpoint": str(path), "boxes": 3, "lps": data["lps"]}


@pytest.mark.parametrize("edit", ["empty open", "one box less", "boxes count", "a bound"])
def test_an_edited_checkpoint_is_refused_by_its_digest(saved, tmp_path, edit):
    path, data = saved
    data = json.loads(json.dumps(data))
    if edit == "empty open":  # the report: a feasible task resumed as "infeasible"
        data["open"] = []
    elif edit == "one box less":
        data["open"] = data["open"][:-1]
    elif edit == "boxes count":
        data["boxes"] = 1000
    else:
        data["open"][0]["lower"][0] += 1e-6
    edited = _write(tmp_path / "edited.json", data, digest=False)
    with pytest.raises(PrehensionError, match="was changed after it was written .*start again without --resume"):
        _resume(edited)


def _box_edit(data, edit):
    box = data["open"][0]
    if edit == "lower > upper":
        box["lower"][3], box["upper"][3] = box["upper"][3] + 1.0, box["lower"][3]
        return r"open\[0\]' must be a box with lower <= upper"
    if edit == "NaN":
        box["upper"][2] = float("nan")
        return r"open\[0\]\.upper' must be finite numbers"
    if edit == "infinity":
        box["lower"][0] = float("-inf")
        return r"open\[0\]\.lower' must be finite numbers"
    if edit == "outside the root box":
        box["upper"][5] = box["upper"][5] + 1e3
        return r"open\[0\]' must be a box inside the task's initial box \(variable 5 lies outside\)"
    if edit == "wrong dimension":
        box["lower"] = box["lower"][:-1]
        return r"open\[0\]\.lower' must be a list of \d+ numbers"
    if edit == "no open box":
        data["open"] = []
        return "'open' holds no box; a checkpoint is only written while boxes are open"
    raise AssertionError(edit)


@pytest.mark.parametrize("edit", ["lower > upper", "NaN", "infinity", "outside the root box", "wrong dimension", "no open box"])
def test_boxes_are_validated_even_with_a_matching_digest(saved, tmp_path, edit):
    path, data = saved
    data = json.loads(json.dumps(data))
    message = _box_edit(data, edit)
    with pytest.raises(PrehensionError, match=message):
        _resume(_write(tmp_path / "forged.json", data))


@pytest.mark.parametrize("field, value, message", [
    ("boxes", "3", "'boxes' must be a non-negative integer, got '3'"),
    ("lps", -1, "'lps' must be a non-negative integer, got -1"),
    ("max_depth", 2.5, "'max_depth' must be a non-negative integer"),
    ("collision_pruned", True, "'collision_pruned' must be a non-negative integer"),
    ("open", {"lower": []}, "'open' must be a list of boxes"),
    ("small", "none", "'small' must be a list of boxes"),
    ("open", [[0, 1]], r"'open\[0\]' must be a mapping \{lower, upper\}"),
    ("open", [{"lower": "abc", "upper": [], "depth": 0}], r"'open\[0\].lower' must be a list of"),
    ("solutions", {"q": 1}, "'solutions' must be a list of configurations"),
    ("solutions", [{"joint_angles": "x"}], r"solutions\[0\]: not a configuration of this task"),
])  # fmt: skip
def test_wrongly_typed_fields_are_named(saved, tmp_path, field, value, message):
    path, data = saved
    data = {**json.loads(json.dumps(data)), field: value}
    with pytest.raises(PrehensionError, match=message):
        _resume(_write(tmp_path / "typed.json", data))


def test_a_wrong_depth_is_named(saved, tmp_path):
    path, data = saved
    data = json.loads(json.dumps(data))
    data["open"][0]["depth"] = "deep"
    with pytest.raises(PrehensionError, match="'depth' must be a non-negative integer, got 'deep'"):
        _resume(_write(tmp_path / "depth.json", data))


def test_wrongly_typed_fields_on_the_command_line_are_an_error_not_a_traceback(tmp_path, capsys):
    task = tmp_path / "pincer.yaml"
    task.write_text(dumps_task(pincer_task(30.0)))
    ckpt, out = tmp_path / "all.json", str(tmp_path / "r.json")
    solve = ["solve", str(task), "--method", "complete", "--all", "--checkpoint", str(ckpt), "-o", out]
    main(solve + ["--max-boxes", "3"])
    data = json.loads(ckpt.read_text())
    for field, value in (("boxes", "many"), ("open", 7)):
        _write(ckpt, {**data, field: value})
        capsys.readouterr()
        assert main(solve + ["--resume"]) == EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert f"'{field}' must be" in err and "Traceback" not in err


def test_a_forged_checkpoint_says_so_in_the_result_and_check_re_proves_it(tmp_path):
    """A forger who recomputes the digest (it is no signature) can drop the boxes that
    hold the solutions: the resumed search then answers "infeasible" for a feasible task.
    The result says that part of the proof came from the checkpoint, and ``check``
    re-proves it from the initial box and finds the claim false."""
    task = pincer_task(30.0)  # feasible
    form = build_system(task)
    lower, upper = form.system.lower, form.system.upper
    corner = (lower.copy(), lower + 1e-3 * (upper - lower), 0)  # a box that holds no solution
    forged = tmp_path / "forged.json"
    save_state(forged, SearchState(deque([corner]), boxes=5, lps=10), search_fingerprint(form, NO_PAIR))
    resumed = solve_complete(task, NO_PAIR, checkpoint=forged, resume=True)
    assert resumed.status == Status.INFEASIBLE  # what the forged checkpoint makes it say ...
    assert f"resumed from checkpoint {forged}: 5 of these boxes were pruned" in resumed.message  # ... and says why
    data = result_to_dict(resumed, quality_entries(resumed), approach_entries_of(resumed))
    assert data["stats"]["resumed"]["checkpoint"] == str(forged)
    restated = verify_result(data, reprove=False)
    assert "resumed from checkpoint" in restated.findings[-1].detail and not restated.infeasibility_reproved
    checked = verify_result(data, time_limit_s=120)
    assert not checked.holds
    assert [f.detail for f in checked.failures] == ["FALSE: the complete solver finds a verified solution of the embedded task"]


def test_a_resumed_infeasibility_is_re_proved_and_names_its_checkpoint(resumed):
    data = result_to_dict(resumed, quality_entries(resumed), approach_entries_of(resumed))
    checked = verify_result(data, time_limit_s=120)
    assert checked.holds and checked.infeasibility_reproved
    assert "resumed from checkpoint" in checked.findings[-1].detail and "does not read it" in checked.findings[-1].detail
    # an untampered checkpoint resumes to the answer of one run: the re-proof's counts are the resumed search's
    assert (checked.reproof.stats["boxes"], checked.reproof.stats["lps"]) == (resumed.stats["boxes"], resumed.stats["lps"])
    assert np.isfinite(resumed.stats["best_residual"]["contact_mm"])
