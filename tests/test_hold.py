"""solve --hold: the first candidate that holds in the physics test; the verdict stored and re-checked."""

from __future__ import annotations

import io
import itertools
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

pytest.importorskip("mujoco")

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main  # noqa: E402
from prehension.cli.codes import EXIT_CHECK_FAILED, EXIT_DROPPED  # noqa: E402
from prehension.hold import AIMED_SOURCE, closure_model, hold_first, margin_of  # noqa: E402
from prehension.region_closure import AIMED_KEPT  # noqa: E402
from prehension.results import SolveResult, write_result  # noqa: E402
from prehension.cli.best import best_table  # noqa: E402
from prehension.quality import QualityOptions, grasp_quality, quality_entries  # noqa: E402
from prehension.sim import SimOptions  # noqa: E402
from prehension.pregrasp import approach_entries_of
from prehension.verification import verify_result_file  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def test_the_first_candidate_that_holds_is_the_answer(four, one_face):
    """Candidates: a grasp that drops (every contact on one face), then one that holds; each
    tried one's push margin is recorded beside its verdict (the one that drops: 0)."""
    task, holds = four
    _, drops = one_face
    result = SolveResult(task, "local", "solved", "two candidates", (drops, holds))
    out = hold_first(result)
    assert out.held and out.result.solutions == (holds,)
    assert out.physics[0]["success"] and len(out.physics) == 1
    tried = out.result.stats["hold"]["tried"]
    assert [t["success"] for t in tried] == [False, True] and tried[0]["why"].startswith("dropped")
    assert tried[0]["push_margin"] == 0.0 and tried[1]["push_margin"] == margin_of(task, holds, SimOptions()) > 1.0
    assert "candidate 2 of 2 holds" in out.result.message


def test_when_none_holds_the_answer_says_so_with_every_candidate(one_face):
    task, drops = one_face
    result = SolveResult(task, "local", "solved", "one candidate", (drops,))
    out = hold_first(result)
    assert not out.held and out.result.solutions == (drops,)
    assert out.physics[0]["success"] is False and "no candidate holds" in out.result.message


def test_the_stored_verdict_is_re_run_by_check(tmp_path, four, one_face, monkeypatch):
    task, holds = four
    out = hold_first(SolveResult(task, "local", "solved", "one", (holds,)))
    path = tmp_path / "held.result.json"
    write_result(out.result, path, quality_entries(out.result), approach_entries_of(out.result), physics=out.physics)
    checked = verify_result_file(path)
    physics = [f for f in checked.findings if "physics verdict" in f.what]
    assert checked.holds and len(physics) == 1 and physics[0].detail.startswith("re-run: holds")
    data = json.loads(path.read_text())  # a verdict that lies: one push said dropped
    data["solutions"][0]["physics"]["pushes"][2]["held"] = False
    data["solutions"][0]["physics"]["success"] = False
    path.write_text(json.dumps(data))
    assert not verify_result_file(path).holds
    assert main(["check", str(path)]) == EXIT_CHECK_FAILED
    monkeypatch.setitem(sys.modules, "mujoco", None)  # without MuJoCo: said, not re-run
    skipped = [f for f in verify_result_file(path).findings if "physics verdict" in f.what]
    assert skipped[0].ok and "MuJoCo is not installed" in skipped[0].detail


def test_solve_hold_on_the_command_line(tmp_path, capsys):
    held = tmp_path / "four.result.json"
    task = str(ROOT / "examples" / "quality" / "box-four-fingers.yaml")
    assert main(["solve", task, "--hold", "--best", "2", "--starts", "10", "-o", str(held)]) == EXIT_OK
    data = json.loads(held.read_text())
    assert data["stats"]["hold"]["held"] and data["solutions"][0]["physics"]["success"]
    assert "holds in the physics test" in capsys.readouterr().out
    dropped = tmp_path / "one.result.json"
    task = str(ROOT / "examples" / "quality" / "box-one-face.yaml")
    assert main(["solve", task, "--hold", "--best", "2", "--starts", "10", "-o", str(dropped)]) == EXIT_DROPPED
    data = json.loads(dropped.read_text())
    assert data["status"] == "solved" and not data["stats"]["hold"]["held"]
    assert all(s["physics"]["success"] is False for s in data["solutions"])
    held_counts = [s["physics"]["held"] for s in data["solutions"]]
    assert held_counts == sorted(held_counts, reverse=True)
    printed = capsys.readouterr().out
    assert "no candidate holds" in printed and "no grasp in these regions is force closure" in printed
    assert data["stats"]["hold"]["closure"]["status"] == "infeasible"


def test_solve_hold_without_mujoco_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    task = str(ROOT / "examples" / "quality" / "box-four-fingers.yaml")
    assert main(["solve", task, "--hold", "-o", str(tmp_path / "r.json")]) == EXIT_BAD_INPUT
    assert 'pip install "prehension[sim]"' in capsys.readouterr().err
    assert not (tmp_path / "r.json").exists()


def test_solve_hold_says_what_it_cannot_be_combined_with(tmp_path, capsys):
    task = str(ROOT / "examples" / "quality" / "box-one-face.yaml")
    assert main(["solve", task, "--hold", "--require", "force-closure", "-o", str(tmp_path / "r.json")]) == EXIT_BAD_INPUT
    assert "--hold runs the candidates of --best 5" in capsys.readouterr().err


def test_when_no_points_of_the_regions_are_force_closure_the_proof_without_the_hand_is_stored_and_re_derived(tmp_path, one_face, four):
    """Every contact on one face: the search over the object regions' points alone proves that
    none is force closure (the physics test's friction and torsion), the complete solver is
    not asked; check derives it again (with or without --no-reprove: it is cheap), and the
    same claim for a task whose regions do admit force closure is caught."""
    task, drops = one_face
    out = hold_first(SolveResult(task, "local", "solved", "one candidate", (drops,)))
    closure = out.result.stats["hold"]["closure"]
    assert not out.held and out.proven_none and closure["status"] == "infeasible" and closure["method"] == "regions"
    assert closure["quality"]["torsion_mm"] == 20.0 and closure["closure_pruned"] == closure["boxes"] >= 1
    assert "no grasp in these regions is force closure (proven without the hand" in out.result.message
    path = tmp_path / "none.result.json"
    write_result(out.result, path, quality_entries(out.result), approach_entries_of(out.result), physics=out.physics)
    for reprove in (True, False):
        found = [f for f in verify_result_file(path, reprove=reprove).findings if f.what.startswith("--hold")]
        assert len(found) == 1 and found[0].ok and "re-proved" in found[0].what
    found = _claimed_for_the_four_finger_task(four, closure, path)
    assert len(found) == 1 and not found[0].ok and "some points of the object regions are force closure" in found[0].detail


def _claimed_for_the_four_finger_task(four, closure: dict, path) -> list:
    """check's findings on ``closure`` claimed for the four-finger task, whose regions do admit force closure."""
    task4, holds = four
    lie = hold_first(SolveResult(task4, "local", "solved", "one", (holds,)))
    lie = replace(lie.result, stats={**lie.result.stats, "hold": {**lie.result.stats["hold"], "closure": closure}})
    write_result(lie, path, quality_entries(lie), approach_entries_of(lie))
    return [f for f in verify_result_file(path).findings if f.what.startswith("--hold")]


def _undecided_regions(monkeypatch):
    """The search without the hand gives up at once: the complete solver is asked."""
    import prehension.hold as hold_module
    from prehension.region_closure import RegionClosure

    monkeypatch.setattr(hold_module, "regions_closure", lambda task, quality, time_s: RegionClosure("gave_up", 0, 0, 0.0, None, "no time"))


def test_when_no_candidate_is_force_closure_a_proof_that_none_exists_is_stored_and_re_proved(tmp_path, one_face, four, monkeypatch):
    """Every contact on one face, the search without the hand undecided: the complete solver
    proves that no grasp of these regions is force closure (the physics test's friction and
    torsion); check re-proves it, and a proof claimed for a task that has a force-closure
    grasp is caught."""
    _undecided_regions(monkeypatch)
    task, drops = one_face
    out = hold_first(SolveResult(task, "local", "solved", "one candidate", (drops,)))
    closure = out.result.stats["hold"]["closure"]
    assert not out.held and out.proven_none and closure["status"] == "infeasible" and closure["closure_pruned"] >= 1
    assert closure["quality"]["torsion_mm"] == 20.0 and closure["options"]["require"] == "force-closure"
    assert closure["regions"]["status"] == "gave_up" and "method" not in closure
    assert "no grasp in these regions is force closure (proven by the complete solver" in out.result.message
    path = tmp_path / "none.result.json"
    write_result(out.result, path, quality_entries(out.result), approach_entries_of(out.result), physics=out.physics)
    found = [f for f in verify_result_file(path).findings if f.what.startswith("--hold")]
    assert len(found) == 1 and found[0].ok and "re-proved" in found[0].what
    assert [f.ok for f in verify_result_file(path, reprove=False).findings if f.what.startswith("--hold")] == [True]
    found = _claimed_for_the_four_finger_task(four, closure, path)
    assert len(found) == 1 and not found[0].ok and "FALSE" in found[0].detail


def test_force_closure_grasps_aimed_at_force_closure_points_are_the_next_candidates(four):
    """No candidate: the regions have force-closure points, and the local iterations aimed at
    them reach force-closure grasps (the physics test's contact model), tried in the physics
    test before the complete solver is asked (it is not)."""
    task, _ = four
    best = {"requested": 5, "rank": "q1", "candidates": 0, "distinct": 0, "quality_options": QualityOptions().to_dict(),
            "sources": [], "epsilon": [], "force_closure": [], "ascent": []}  # fmt: skip
    out = hold_first(SolveResult(task, "local", "gave_up", "no candidate", (), 0.0, {"best": best}))
    assert out.closure["status"] == "solved" and out.closure["method"] == "aimed" and out.closure["regions"]["status"] == "witness"
    assert "options" not in out.closure  # the complete solver was not asked
    tried = out.result.stats["hold"]["tried"]
    assert 1 <= len(tried) <= AIMED_KEPT and out.held == tried[-1]["success"]
    listed = out.result.stats["best"]
    assert set(listed["sources"]) == {AIMED_SOURCE} and len(listed["sources"]) == len(out.result.solutions)
    for solution in out.result.solutions:
        assert grasp_quality(task, solution, closure_model(SimOptions())).force_closure
    assert "aimed at force-closure points of the regions found force-closure grasps" in out.result.message


def test_a_force_closure_grasp_of_the_complete_solver_is_the_next_candidate(four, monkeypatch):
    """No candidate (none force closure), none from the aimed starts: the complete solver's
    force-closure grasp is tried in the physics test, and its quality is the physics test's
    contact model's."""
    import prehension.hold as hold_module

    monkeypatch.setattr(hold_module, "aimed_grasps", lambda task, quality, seed, witness: [])
    task, _ = four
    best = {"requested": 5, "rank": "q1", "candidates": 0, "distinct": 0, "quality_options": QualityOptions().to_dict(),
            "sources": [], "epsilon": [], "force_closure": [], "ascent": []}  # fmt: skip
    out = hold_first(SolveResult(task, "local", "gave_up", "no candidate", (), 0.0, {"best": best}))
    assert out.closure["status"] == "solved" and len(out.result.solutions) == 1
    listed = out.result.stats["best"]  # solve --best's per-solution lists follow, the ranking's friction model
    assert listed["sources"] == ["complete solver (force closure required, --hold)"] and listed["ascent"] == [None]
    assert listed["epsilon"][0] == grasp_quality(task, out.result.solutions[0], QualityOptions()).epsilon
    console = Console(width=200, record=True, file=io.StringIO())
    console.print(best_table(out.result))
    assert "complete solver (force closure required, --hold)" in console.export_text()
    assert out.result.stats["hold"]["tried"][0]["candidate"] == 0 and out.physics[0] is not None
    assert grasp_quality(task, out.result.solutions[0], closure_model(SimOptions())).force_closure
    assert "the complete solver found a force-closure grasp" in out.result.message
    assert hold_first(SolveResult(task, "local", "gave_up", "none", ()), closure_time_s=0).closure is None


def _turned(task, grasp, dq: float):
    """The grasp with every moving joint turned by ``dq`` [rad] (a distinct grasp for the bookkeeping; not verified)."""
    q = np.where(task.active_mask, grasp.q + dq, grasp.q)
    return replace(grasp, joint_angles=dict(zip(task.hand.dof_names, q.tolist())))


def test_further_rounds_of_aimed_starts_while_none_holds_and_the_budget_lasts(four, one_face, monkeypatch):
    """The first round's force-closure grasp drops; the second round reaches only grasps
    already tried (not tried again); the third reaches one that holds: it is the answer,
    and the record says three rounds, two grasps.  With no budget left after the first
    round, no second one."""
    import prehension.hold as hold_module
    import prehension.sim as sim_module

    task, grasp = four
    a, b = _turned(task, grasp, 0.2), _turned(task, grasp, -0.2)
    holds = sim_module.simulate_grasp(task, grasp, SimOptions())
    drops = sim_module.simulate_grasp(*one_face, SimOptions())
    assert holds.success and not drops.success
    monkeypatch.setattr(sim_module, "simulate_grasp", lambda task, s, options, seed=0, **_: holds if s is b else drops)
    rounds = {0: [a], 1: [_turned(task, grasp, 0.2)], 2: [b]}
    monkeypatch.setattr(hold_module, "aimed_grasps", lambda task, quality, seed, witness, aim=True: rounds.get(seed, []))
    out = hold_first(SolveResult(task, "local", "solved", "one candidate", (grasp,)))
    assert out.held and out.result.solutions == (b,)
    assert [t["candidate"] for t in out.result.stats["hold"]["tried"]] == [0, 1, 2]
    assert out.closure["method"] == "aimed" and out.closure["rounds"] == 3 and out.closure["grasps"] == 2
    assert "2 force-closure grasp(s)" in out.closure["message"] and "3 round(s)" in out.closure["message"]
    clock = itertools.chain([0.0], itertools.repeat(1e9))  # the search started at 0; every later reading is past its budget
    monkeypatch.setattr(hold_module.time, "perf_counter", lambda: next(clock))
    out = hold_first(SolveResult(task, "local", "solved", "one candidate", (grasp,)))
    assert not out.held and out.closure["rounds"] == 1 and len(out.result.solutions) == 2


def test_the_closure_budget_needs_hold(tmp_path, capsys):
    task = str(ROOT / "examples" / "quality" / "box-one-face.yaml")
    assert main(["solve", task, "--hold-closure-time", "5", "-o", str(tmp_path / "r.json")]) == EXIT_BAD_INPUT
    assert "--hold-closure-time is the budget of --hold" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:  # argparse: the usage and the reason
        main(["solve", task, "--hold", "--hold-closure-time", "-1", "-o", str(tmp_path / "r.json")])
    assert exc.value.code == EXIT_BAD_INPUT and "must be a number of seconds >= 0 (0: not asked)" in capsys.readouterr().err


def test_a_task_the_complete_solver_does_not_take_keeps_the_candidates_verdicts(one_face, monkeypatch):
    import prehension.hold as hold_module
    from prehension.errors import PrehensionError

    def refuse(task, options):
        raise PrehensionError("the complete solver does not take this region")

    task, drops = one_face
    _undecided_regions(monkeypatch)
    monkeypatch.setattr(hold_module, "solve", refuse)
    out = hold_first(SolveResult(task, "local", "solved", "one candidate", (drops,)))
    assert not out.held and out.result.solutions == (drops,) and out.physics[0]["success"] is False
    assert out.closure["status"] == "unavailable" and not out.proven_none
    assert "could not look for a force-closure grasp: the complete solver does not take this region" in out.result.message


def test_an_open_task_refuses_the_closure_budget_it_would_not_use(tmp_path, capsys):
    from prehension.assignment import OpenContact, OpenTask
    from prehension.tasks.yaml_io import dumps_task
    from tiny_tasks import pincer_task

    pincer = pincer_task(40.0)
    path = tmp_path / "open.yaml"  # either finger on either region: an open task
    path.write_text(dumps_task(OpenTask("open", pincer.hand, pincer.object, (OpenContact("A", None), OpenContact("B", None)))))
    assert main(["solve", str(path), "--hold", "--hold-closure-time", "5", "-o", str(tmp_path / "r.jsonl")]) == EXIT_BAD_INPUT
    assert "--hold-closure-time is not used by an open task's assignment search" in capsys.readouterr().err


def test_each_candidates_push_squeeze_is_computed_once_for_its_margin_and_its_test(four, one_face, monkeypatch):
    """The push squeeze's program runs once per tried candidate (the margin and the physics
    test share it), and the verdicts and margins are those of each computed on its own."""
    import prehension.sim.push as push_module
    from prehension.sim import simulate_grasp

    task, holds = four
    _, drops = one_face
    calls = []
    program = push_module.push_squeeze
    monkeypatch.setattr(push_module, "push_squeeze", lambda *a, **k: calls.append(1) or program(*a, **k))
    out = hold_first(SolveResult(task, "local", "solved", "two candidates", (drops, holds)), closure_time_s=0)
    assert len(calls) == 2  # one per candidate tried (it was two per candidate)
    monkeypatch.setattr(push_module, "push_squeeze", program)
    alone = [simulate_grasp(task, g, SimOptions(), 0) for g in (drops, holds)]
    assert [t["pushes_held"] for t in out.result.stats["hold"]["tried"]] == [r.held for r in alone]
    assert out.physics[0] == alone[1].to_dict()
    assert [t["push_margin"] for t in out.result.stats["hold"]["tried"]] == [margin_of(task, g, SimOptions()) for g in (drops, holds)]
