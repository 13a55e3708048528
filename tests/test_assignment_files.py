"""Open task files and ``prehension solve`` on them: reading and writing, the search on the
command line, its journal (resume), ``check`` of every record (span proofs too), bad input."""

from __future__ import annotations

import json

import pytest

from prehension.assignment import OpenContact, OpenTask
from prehension.cli import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK, main
from prehension.errors import InvalidTask
from prehension.tasks.model import Contact
from prehension.tasks.yaml_io import dumps_task, load_open_task, load_task, loads_open_task, loads_task, task_to_dict
from tiny_tasks import pincer_task


def open_pincer(d: float, hands=(None, None), fingers=None) -> OpenTask:
    t = pincer_task(d)
    return OpenTask(f"open-pincer-{d:g}", t.hand, t.object, (OpenContact("A", hands[0]), OpenContact("B", hands[1])), fingers)


@pytest.fixture
def open_file(tmp_path):
    def write(d: float, **kw):
        path = tmp_path / f"open-{d:g}.yaml"
        path.write_text(dumps_task(open_pincer(d, **kw)))
        return path

    return write


# -- the file format ----------------------------------------------------------------------------
def test_open_tasks_round_trip():
    for task in (open_pincer(40.0), open_pincer(40.0, hands=(["pad", "tip"], None), fingers=("f",))):
        data = task_to_dict(task)
        assert data["contacts"][1]["hand"] == "any"
        assert ("fingers" in data) == (task.fingers is not None)
        again = loads_open_task(dumps_task(task))
        assert task_to_dict(again) == data
        assert [type(c) for c in again.contacts] == [OpenContact, OpenContact]
        assert again.contacts[0].hand_candidates == task.contacts[0].hand_candidates


def test_load_task_refuses_an_open_task_and_load_open_task_reads_a_closed_one(tmp_path):
    text = dumps_task(open_pincer(40.0))
    with pytest.raises(InvalidTask, match=r"contacts\.0\.hand: any leaves the hand region open.*prehension solve FILE"):
        loads_task(text, "open.yaml")
    closed = pincer_task(40.0)
    task = loads_open_task(dumps_task(closed))
    assert all(isinstance(c, Contact) for c in task.contacts) and task.fingers == ("f",)


def test_fingers_may_be_omitted_in_a_closed_task():
    data = task_to_dict(pincer_task(40.0))
    del data["fingers"]
    import yaml

    task = loads_task(yaml.safe_dump(data))
    assert task.fingers == ("f",)  # the finger of the tip's link


@pytest.mark.parametrize("hand, message", [
    ("[pad, nope]", r"contacts\.0\.hand\.1: hand region 'nope' not found; regions are: tip, pad"),
    ("[]", r"contacts\.0\.hand: .*expected a hand region name, 'any'"),
    ("[pad, pad]", r"contacts\.0\.hand: .*candidate hand regions repeat"),
    ("[any, pad]", r"contacts\.0\.hand: .*expected a hand region name, 'any'"),
])  # fmt: skip
def test_bad_candidates_name_the_field(hand, message):
    text = dumps_task(open_pincer(40.0)).replace("hand: any", f"hand: {hand}", 1)
    with pytest.raises(InvalidTask, match=message):
        loads_open_task(text, "open.yaml")


def test_more_contacts_than_regions_is_refused():
    t = pincer_task(40.0)
    contacts = tuple(OpenContact(o) for o in ("A", "B", "A"))
    with pytest.raises(InvalidTask, match="3 contacts but only 2 candidate hand region"):
        OpenTask("three", t.hand, t.object, contacts)


# -- the command line ---------------------------------------------------------------------------
def _records(path):
    lines = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return {r["id"]: r for r in lines if r["prehension"] == "batch/1"}


def test_solve_open_task_writes_records_that_check_verifies(open_file, tmp_path, capsys):
    out = tmp_path / "out.jsonl"
    assert main(["solve", str(open_file(40.0)), "-o", str(out), "--assignment-time", "20"]) == EXIT_OK
    shown = capsys.readouterr().out
    assert "Feasible assignments" in shown and "2 assignments: 1 feasible" in shown
    records = _records(out)
    assert set(records) == {"pad->A, tip->B", "tip->A, pad->B"}
    good = records["pad->A, tip->B"]
    assert good["status"] == "solved" and good["assignment"] == {"hand_regions": ["pad", "tip"], "object_regions": ["A", "B"], "initial_poses": 64}
    assert good["result"]["solutions"][0]["quality"]
    assert main(["check", str(out)]) == EXIT_OK
    assert "DOES NOT HOLD" not in capsys.readouterr().out
    # resume: nothing left to decide, nothing written twice
    size = out.stat().st_size
    assert main(["solve", str(open_file(40.0)), "-o", str(out)]) == EXIT_OK
    assert out.stat().st_size == size
    assert "2 decided by an earlier run" in capsys.readouterr().out


def test_span_proofs_are_records_that_check_rederives(open_file, tmp_path, capsys):
    out = tmp_path / "far.jsonl"
    assert main(["solve", str(open_file(200.0)), "-o", str(out)]) == EXIT_INFEASIBLE
    assert "2 proven impossible (2 by the hand's span)" in capsys.readouterr().out
    records = _records(out)
    assert {r["method"] for r in records.values()} == {"span"}
    proof = records["pad->A, tip->B"]["result"]["stats"]["proof"]
    assert proof["gap_mm"] > proof["reach_mm"]
    assert main(["check", str(out)]) == EXIT_OK
    assert "holds" in capsys.readouterr().out
    # a proof moved to other contacts does not hold: its regions are not those of the task
    text = out.read_text().replace('"object_regions":["A","B"],"reach_mm"', '"object_regions":["B","A"],"reach_mm"')
    forged = tmp_path / "forged.jsonl"
    forged.write_text(text)
    assert main(["check", str(forged)]) == EXIT_CHECK_FAILED
    assert "span proof" in capsys.readouterr().out


def test_open_task_bad_options(open_file, tmp_path, capsys):
    path = open_file(40.0)
    assert main(["solve", str(path), "-o", str(tmp_path / "x.json")]) == EXIT_BAD_INPUT
    assert "one answer per assignment" in capsys.readouterr().err
    assert main(["solve", str(path), "--best", "3", "-o", str(tmp_path / "x.jsonl")]) == EXIT_BAD_INPUT
    assert "--best is an option of solving one task" in capsys.readouterr().err
    closed = tmp_path / "closed.yaml"
    closed.write_text(dumps_task(pincer_task(40.0)))
    assert main(["solve", str(closed), "--assignment-time", "3", "-o", str(tmp_path / "c.json")]) == EXIT_BAD_INPUT
    assert "not an open task" in capsys.readouterr().err
    assert main(["solve", str(closed), "--initial-poses", "4", "-o", str(tmp_path / "c.json")]) == EXIT_BAD_INPUT
    assert "--initial-poses is an option of the assignment search" in capsys.readouterr().err
    assert main(["solve", str(path), "--initial-poses", "4", "-o", str(tmp_path / "four.jsonl")]) == EXIT_OK
    assert " of 4 " in _records(tmp_path / "four.jsonl")["pad->A, tip->B"]["message"]  # initial pose k of 4


def test_local_only_leaves_the_rest_undecided(open_file, tmp_path, capsys):
    out = tmp_path / "local.jsonl"
    code = main(["solve", str(open_file(60.0)), "-o", str(out), "--method", "local"])
    shown = capsys.readouterr().out
    assert code == EXIT_GAVE_UP and "undecided" in shown
    assert {r["status"] for r in _records(out).values()} == {"gave_up"}
    assert main(["check", str(out)]) == EXIT_OK


def test_an_open_task_has_a_default_time_limit(open_file):
    """`solve OPEN.yaml` is bounded by default (60 s for the search; --time-limit 0: none),
    a closed task keeps solve's 300 s."""
    from prehension.cli import build_parser
    from prehension.cli.assign import DEFAULT_OPEN_TIME_LIMIT_S, _search_options

    path = str(open_file(40.0))
    parse = build_parser().parse_args
    assert _search_options(parse(["solve", path]), None).time_limit_s == DEFAULT_OPEN_TIME_LIMIT_S == 60.0
    assert _search_options(parse(["solve", path, "--time-limit", "7"]), None).time_limit_s == 7.0
    assert _search_options(parse(["solve", path, "--time-limit", "300"]), None).time_limit_s == 300.0
    assert _search_options(parse(["solve", path, "--time-limit", "0"]), None).time_limit_s is None
