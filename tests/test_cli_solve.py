"""prehension solve / check: exit codes, result files, bad input."""

from __future__ import annotations

import json

import pytest

from prehension.pregrasp import approach_entries_of
from prehension.cli import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK, main
from prehension.tasks.yaml_io import dumps_task, task_to_dict
from tiny_tasks import pincer_task


@pytest.fixture
def pincer_file(tmp_path):
    def write(d: float):
        path = tmp_path / f"pincer-{d:g}.yaml"
        path.write_text(dumps_task(pincer_task(d)))
        return path

    return write


def test_solve_writes_a_result_that_check_verifies(pincer_file, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", str(pincer_file(30.0)), "--method", "complete", "-o", str(out)]) == EXIT_OK
    assert "solved" in capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["prehension"] == "result/1" and data["status"] == "solved"
    sol = data["solutions"][0]
    assert set(sol["link_poses"]) == {"palm", "prox", "dist"}  # every link's pose
    assert len(sol["T_palm_object"]) == 4 and len(sol["contacts"]) == 2
    assert {"hand_point", "hand_normal", "object_point", "object_normal", "hand_params"} <= set(sol["contacts"][0])
    assert main(["check", str(out)]) == EXIT_OK
    assert "holds" in capsys.readouterr().out


def test_solve_keeps_an_older_result(pincer_file, tmp_path, capsys):
    out = tmp_path / "r.json"
    args = ["solve", str(pincer_file(30.0)), "--method", "complete", "-o", str(out), "--quiet"]
    assert main(args) == EXIT_OK
    first = out.read_text()
    assert main(args) == EXIT_OK
    assert (tmp_path / "r.json.~1~").read_text() == first


def test_infeasible_and_gave_up_exit_codes(pincer_file, tmp_path):
    assert main(["solve", str(pincer_file(60.0)), "--method", "complete", "-o", str(tmp_path / "a.json"), "--quiet"]) == EXIT_INFEASIBLE
    assert json.loads((tmp_path / "a.json").read_text())["status"] == "infeasible"
    code = main(["solve", str(pincer_file(50.0)), "--method", "complete", "--time-limit", "1e-6", "-o", str(tmp_path / "b.json"), "--quiet"])
    assert code == EXIT_GAVE_UP


def test_json_summary(pincer_file, tmp_path, capsys):
    code = main(["solve", str(pincer_file(30.0)), "--method", "complete", "-o", str(tmp_path / "r.json"), "--json"])
    assert code == EXIT_OK
    summary = json.loads(capsys.readouterr().out)
    assert summary["status"] == "solved" and summary["result_file"].endswith("r.json")
    assert set(summary["joint_angles_deg"]) == {"j1", "j2"}


def test_bad_input_exit_code(capsys, tmp_path):
    assert main(["solve", "no-such-task", "--method", "complete"]) == EXIT_BAD_INPUT
    assert "neither a built-in task" in capsys.readouterr().err
    assert main(["solve", "teapot-lid-lifting", "--sigma", "2", "--method", "complete"]) == EXIT_BAD_INPUT
    assert "sigma must lie in (0, 1)" in capsys.readouterr().err
    # with auto too, before any solving, although the complete solver's options are made only if it runs
    assert main(["solve", "teapot-lid-lifting", "--sigma", "1", "-o", str(tmp_path / "n.json")]) == EXIT_BAD_INPUT
    assert "sigma must lie in (0, 1)" in capsys.readouterr().err and not (tmp_path / "n.json").exists()
    bad = tmp_path / "x.json"
    bad.write_text("{not json")
    assert main(["check", str(bad)]) == EXIT_BAD_INPUT
    assert "not a result file" in capsys.readouterr().err


def test_check_refuses_a_result_of_another_task(pincer_file, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", str(pincer_file(30.0)), "--method", "complete", "-o", str(out), "--quiet"]) == EXIT_OK
    data = json.loads(out.read_text())
    data["task"] = task_to_dict(pincer_task(44.0))  # the stored solution belongs to d = 30
    out.write_text(json.dumps(data))
    assert main(["check", str(out)]) == EXIT_CHECK_FAILED
    assert "DOES NOT HOLD" in capsys.readouterr().out


def test_solve_writes_the_view_with_html(pincer_file, tmp_path, capsys):
    out, html = tmp_path / "r.json", tmp_path / "grasp.html"
    assert main(["solve", str(pincer_file(30.0)), "-o", str(out), "--html", str(html)]) == EXIT_OK
    assert "3-D view written" in capsys.readouterr().out
    page = html.read_text()
    assert page.startswith("<!DOCTYPE html>") and "pincer-30" in page
    # an infeasible task still gets a view: the task alone, saying so
    assert main(["solve", str(pincer_file(60.0)), "--method", "complete", "-o", str(out), "--html", str(html)]) == EXIT_INFEASIBLE
    assert "infeasible" in html.read_text()


def test_error_messages_keep_square_brackets(capsys):
    assert main(["solve", "no-such-task[1]"]) == EXIT_BAD_INPUT
    assert "no-such-task[1]" in capsys.readouterr().err


def test_check_reverifies_every_record_of_a_batch_output(tmp_path, capsys):
    from prehension.results import result_to_dict
    from prehension.quality import quality_entries
    from prehension.solve import SolveOptions, solve

    result = solve(pincer_task(30.0), "complete")
    good = result_to_dict(result, quality_entries(result), approach_entries_of(result))
    records = [{"id": "a", "status": "solved", "result": good}, {"id": "b", "status": "invalid", "result": None}]
    out = tmp_path / "results.jsonl"
    out.write_text("".join(json.dumps(r) + "\n" for r in records))
    assert main(["check", str(out)]) == EXIT_OK
    assert "holds" in capsys.readouterr().out
    tampered = json.loads(json.dumps(good))
    tampered["solutions"][0]["joint_angles_rad"]["j1"] += 0.1
    out.write_text(json.dumps({"id": "c", "status": "solved", "result": tampered}) + "\n")
    assert main(["check", str(out)]) == EXIT_CHECK_FAILED
    out.write_text("{not json\n")
    assert main(["check", str(out)]) == EXIT_BAD_INPUT
    assert "results.jsonl:1: not valid JSON" in capsys.readouterr().err


def test_auto_makes_the_complete_solvers_options_only_when_it_falls_back():
    """``SolveOptions(complete_options=callable)``: called only if the complete solver runs (the
    command line passes one, so that ``auto`` does not import the complete solver when
    the local one succeeds)."""
    from prehension.solve import SolveOptions, solve
    from prehension.solvers.complete.search import BranchAndPruneOptions

    def never():
        raise AssertionError("the complete solver's options were made")

    assert solve(pincer_task(30.0), SolveOptions(complete_options=never)).status == "solved"  # the local solver answered
    made = []

    def options():
        made.append(True)
        return BranchAndPruneOptions(sigma=0.05)

    result = solve(pincer_task(60.0), SolveOptions(complete_options=options))  # the local solver fails; the complete one proves
    assert made == [True] and result.status == "infeasible"
