"""The complete solver: never loses a solution, proves infeasibility only when true."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np
import pytest

from fk_tasks import build_fk_case
from prehension.errors import PrehensionError
from prehension.results import Status, make_solution
from prehension.system.embedding import embed
from prehension.system.formulation import build_system
from prehension.solvers.complete.search import BranchAndPruneOptions, solve_complete
from prehension.solvers.complete.rotation_cuts import rotation_structure
from prehension.solvers.complete.shrink import ShrinkOptions, shrink_box
from prehension.verification.residuals import Tolerances
from prehension.solvers.local.verifier import LocalVerifier
from tiny_tasks import FEASIBLE_UP_TO_MM, pincer_task

FAST = BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=120)


@pytest.mark.parametrize("d", [30.0, 44.0])
def test_small_feasible_task_is_solved(d):
    result = solve_complete(pincer_task(d), FAST)
    assert result.status == Status.SOLVED and result.success
    solution = result.solutions[0]
    assert solution.report.ok  # verified with the strict default tolerances
    assert make_solution(result.task, solution.configuration()) is not None


@pytest.mark.parametrize("d", [55.0, 60.0, 120.0])
def test_small_infeasible_task_is_certified(d):
    assert d > FEASIBLE_UP_TO_MM
    result = solve_complete(pincer_task(d), FAST)
    assert result.status == Status.INFEASIBLE and not result.solutions
    assert result.stats["boxes"] >= 1 and "pruned" in result.message


def test_boundary_task_is_never_called_solved_or_infeasible_wrongly():
    """1 mm past the boundary: the solver may prove it or leave small unverified boxes,
    but must never return a solution; just inside, it must find one."""
    outside = solve_complete(pincer_task(FEASIBLE_UP_TO_MM + 1.0), FAST)
    assert outside.status in (Status.INFEASIBLE, Status.GAVE_UP) and not outside.solutions
    if outside.status == Status.GAVE_UP:
        assert outside.unverified_boxes and "narrower than sigma" in outside.message
    inside = solve_complete(pincer_task(FEASIBLE_UP_TO_MM - 1.0), FAST)
    assert inside.status == Status.SOLVED


@pytest.mark.parametrize("seed", range(4))
def test_fk_generated_tasks_are_solved(sa_hand, seed):
    """Never loses a solution: tasks built around a known configuration are solved."""
    case = build_fk_case(sa_hand, np.random.default_rng(1000 + seed), palm=False, kinds=None)
    tol = Tolerances(penetration_mm=float("inf"))  # random poses may self-collide
    result = solve_complete(case.task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=300, tolerances=tol))
    assert result.status == Status.SOLVED
    assert result.solutions[0].report.ok


@pytest.mark.parametrize("seed", [0, 1, 5] + [pytest.param(s, marks=pytest.mark.slow) for s in (2, 3, 4)])  # 2-4: ~20 s each
def test_shrinking_a_box_around_a_known_solution_keeps_it(sa_hand, seed):
    rng = np.random.default_rng(2000 + seed)
    case = build_fk_case(sa_hand, rng)
    form = build_system(case.task)
    x = embed(form, case.config)
    system = form.system
    width = system.upper - system.lower
    lower = np.maximum(system.lower, x - rng.uniform(0.001, 0.3, system.n) * width)
    upper = np.minimum(system.upper, x + rng.uniform(0.001, 0.3, system.n) * width)
    base = tuple(sorted(form.base_keys))  # as the search shrinks them
    shrunk = shrink_box(system, lower, upper, ShrinkOptions(variables=base, max_passes=1))
    assert not shrunk.empty and shrunk.n_lps > 0
    assert np.all(shrunk.lower <= x + 1e-9) and np.all(x <= shrunk.upper + 1e-9)
    # with the rotation and limit rows, and a second pass with cuts at the first pass's optima
    options = ShrinkOptions(variables=base, max_passes=2, size="sum", rho=1.0, rotation_cuts=True, limit_cuts=True)
    shrunk = shrink_box(system, lower, upper, options, rotations=rotation_structure(form))
    assert not shrunk.empty and shrunk.n_passes == 2
    assert np.all(shrunk.lower <= x + 1e-9) and np.all(x <= shrunk.upper + 1e-9)


def test_time_limit_gives_up_and_checkpoint_resumes(tmp_path):
    task = pincer_task(50.0)  # infeasible, needs tens of boxes (without the pair test, which proves it at once)
    ckpt = tmp_path / "search.json"
    first = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=3, pair_test_boxes=0), checkpoint=ckpt)
    assert first.status == Status.GAVE_UP and "box limit" in first.message and str(ckpt) in first.message
    saved = json.loads(ckpt.read_text())
    assert saved["open"] and saved["boxes"] == 3
    # the open share: sum 2^-depth over the open boxes, at most 1, the same after a resume
    assert 0.0 < first.stats["open_share"] <= 1.0
    assert first.stats["open_share"] == sum(2.0 ** -box["depth"] for box in saved["open"])
    assert saved["search"]["task"] and saved["search"]["options"]  # bound to its task and options
    resumed = solve_complete(task, replace(FAST, pair_test_boxes=0), checkpoint=ckpt, resume=True)
    assert resumed.status == Status.INFEASIBLE and resumed.stats["open_share"] == 0.0
    assert resumed.stats["boxes"] > 3  # counted from where the first run stopped


def test_boxes_on_an_executor_give_the_same_answer():
    with ThreadPoolExecutor(max_workers=2) as pool:
        infeasible = solve_complete(pincer_task(55.0), FAST, executor=pool, workers=2)
        feasible = solve_complete(pincer_task(30.0), FAST, executor=pool, workers=2)
    assert infeasible.status == Status.INFEASIBLE
    assert feasible.status == Status.SOLVED


def test_builtin_task_first_solution(capsys):
    from prehension.tasks.library import load_builtin_task

    result = solve_complete(load_builtin_task("scalpel-upholding"), BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=300))
    assert result.status == Status.SOLVED
    assert result.solutions[0].report.worst("contact_distance") < 1e-6


SOLUTION_SET = dict(sigma=0.3, order="breadth", all_solutions=True)


@pytest.fixture(scope="module")
def solution_set():
    """The whole description of the 30 mm pincer's solution set (shared: it takes seconds)."""
    return solve_complete(pincer_task(30.0), BranchAndPruneOptions(verifier=LocalVerifier(), **SOLUTION_SET))


def test_all_solutions_mode_reports_each_solution_in_its_own_box(solution_set):
    result = solution_set
    assert result.status == Status.SOLVED and len(result.solutions) >= 1
    assert result.stats["boxes"] > 1  # a verified point does not end the description of the set
    assert "solution box(es)" in result.message
    for solution in result.solutions:
        assert make_solution(result.task, solution.configuration()) is not None


def test_all_solutions_mode_stops_at_its_default_box_budget_with_a_cover(monkeypatch):
    from prehension.solvers.complete import search

    monkeypatch.setattr(search, "ALL_SOLUTIONS_MAX_BOXES", 12)
    options = BranchAndPruneOptions(verifier=LocalVerifier(), sigma=0.3, order="breadth", all_solutions=True)
    result = solve_complete(pincer_task(30.0), options)
    assert result.stats["boxes"] == 12 and result.stats["open_boxes"] > 0
    assert "partial description" in result.message and "default of the solution-set mode" in result.message
    assert result.stats["open_box_solutions"] <= result.stats["open_boxes"]
    for solution in result.solutions:
        assert make_solution(result.task, solution.configuration()) is not None
    explicit = solve_complete(pincer_task(30.0), replace(options, max_boxes=20))  # an explicit limit wins
    assert explicit.stats["boxes"] == 20
    timed = solve_complete(pincer_task(30.0), replace(options, time_limit_s=600.0))  # as the CLI's default limit
    assert timed.stats["boxes"] == 12  # a time limit does not lift the box budget


def test_workers_visit_the_same_boxes_as_one_process():
    """Outcomes are taken in one-process order: any executor gives the same search."""
    task = pincer_task(50.0)
    alone = solve_complete(task, FAST)
    with ThreadPoolExecutor(max_workers=3) as pool:
        shared = solve_complete(task, FAST, executor=pool, workers=3)
    assert (alone.status, alone.stats["boxes"], alone.stats["lps"]) == (shared.status, shared.stats["boxes"], shared.stats["lps"])


def test_regions_just_beyond_reach_are_certified_and_just_within_are_solved():
    from prehension.tasks.library import load_builtin_task
    from prehension.tasks.variants import move_object_region

    lid = load_builtin_task("teapot-lid-lifting")
    beyond = solve_complete(move_object_region(lid, "knob_back", (0, 0, 180)), FAST)
    assert beyond.status == Status.INFEASIBLE
    within = solve_complete(move_object_region(lid, "knob_back", (0, 0, 150)), FAST)
    assert within.status == Status.SOLVED


def test_solutions_found_before_a_stop_survive_the_resume(tmp_path, solution_set):
    options, whole = SOLUTION_SET, solution_set
    ckpt = tmp_path / "all.json"
    first = solve_complete(pincer_task(30.0), BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=12, **options), checkpoint=ckpt)
    assert first.solutions and first.stats["open_boxes"] > 0  # stopped with a solution in hand
    assert len(first.solutions) - first.stats["open_box_solutions"] < len(whole.solutions)
    resumed = solve_complete(pincer_task(30.0), BranchAndPruneOptions(verifier=LocalVerifier(), **options), checkpoint=ckpt, resume=True)
    assert resumed.stats["boxes"] == whole.stats["boxes"]
    assert len(resumed.solutions) == len(whole.solutions) >= 1
    for a, b in zip(resumed.solutions, whole.solutions):
        np.testing.assert_allclose(a.q, b.q, atol=1e-12)


def test_progress_reports_boxes_open_depth_and_best_residual():
    seen = []
    result = solve_complete(pincer_task(50.0), FAST, progress=seen.append)
    after_box = [info for info in seen if "pair test" not in info]  # plus a notice when the pair test starts
    assert len(after_box) == result.stats["boxes"] and len(seen) - len(after_box) <= 2
    assert {"boxes", "open", "depth", "lps", "best residual"} <= set(seen[-1])
    assert seen[-1]["best residual"].endswith("deg")  # how close the closest verification came
    best = result.stats["best_residual"]
    assert best["contact_mm"] > 0 or best["normal_deg"] > 0  # infeasible: never zero


def test_a_checkpoint_of_another_task_is_refused(tmp_path):
    """Issue 10: resuming the +167 mm lid variant's checkpoint on the (feasible) lid task,
    whose system has the same number of variables, must not "prove" it infeasible."""
    from prehension.errors import PrehensionError
    from prehension.system import build_system
    from prehension.tasks.library import load_builtin_task
    from prehension.tasks.variants import move_object_region

    lid = load_builtin_task("teapot-lid-lifting")
    moved = move_object_region(lid, "knob_back", (0, 0, 167))
    assert build_system(moved).system.n == build_system(lid).system.n  # the count cannot tell them apart
    ckpt = tmp_path / "moved.json"
    # without the pair test (which proves this variant at its first box: nothing left to resume)
    first = solve_complete(moved, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=1, pair_test_boxes=0), checkpoint=ckpt)
    assert first.status == Status.GAVE_UP and ckpt.is_file()
    for other in (lid, load_builtin_task("guitar-tuning")):
        with pytest.raises(PrehensionError, match=r"belongs to another task \('teapot-lid-lifting \(knob_back"):
            solve_complete(other, FAST, checkpoint=ckpt, resume=True)


def test_a_checkpoint_resumed_with_other_options_is_refused_and_same_options_resume(tmp_path):
    from prehension.errors import PrehensionError

    task = pincer_task(50.0)  # searched box by box: without the pair test
    ckpt = tmp_path / "search.json"
    solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), max_boxes=2, pair_test_boxes=0), checkpoint=ckpt)
    with pytest.raises(PrehensionError, match=r"other search options \(sigma 0.1 -> 0.05\)"):
        solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), sigma=0.05, pair_test_boxes=0), checkpoint=ckpt, resume=True)
    with pytest.raises(PrehensionError, match=r"shrink.rho 0.9 -> 0.5; verify_starts 8 -> 2"):
        solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), shrink=ShrinkOptions(rho=0.5), verify_starts=2, pair_test_boxes=0),
                       checkpoint=ckpt, resume=True)  # fmt: skip
    with pytest.raises(PrehensionError, match=r"tolerances.contact_mm 1e-06 -> 0.001"):
        solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), tolerances=Tolerances(contact_mm=1e-3), pair_test_boxes=0), checkpoint=ckpt, resume=True)
    # stop-only options may change; the same task and options resume where they stopped
    resumed = solve_complete(task, BranchAndPruneOptions(verifier=LocalVerifier(), time_limit_s=100, pair_test_boxes=0), checkpoint=ckpt, resume=True)
    assert resumed.status == Status.INFEASIBLE and resumed.stats["boxes"] > 2


def test_a_checkpoint_without_fingerprint_or_not_json_is_refused(tmp_path):
    from prehension.errors import PrehensionError

    old = tmp_path / "old.json"
    old.write_text(json.dumps({"open": [], "boxes": 3, "lps": 0, "max_depth": 0, "small": [], "n_variables": 40}))
    with pytest.raises(PrehensionError, match="not written by this version of the complete solver"):
        solve_complete(pincer_task(50.0), FAST, checkpoint=old, resume=True)
    junk = tmp_path / "junk.json"
    junk.write_text("{not json")
    with pytest.raises(PrehensionError, match="is not a checkpoint file"):
        solve_complete(pincer_task(50.0), FAST, checkpoint=junk, resume=True)


def test_the_complete_solver_does_not_import_the_local_solver():
    """The complete solver verifies boxes through the verifier it is given (BranchAndPruneOptions.verifier):
    importing its search in a fresh interpreter loads no module of the local solver."""
    import subprocess
    import sys

    code = ("import sys, prehension.solvers.complete.search; "
            "print(sorted(m for m in sys.modules if m.startswith('prehension.solvers.local')))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_without_a_verifier_the_search_still_proves_but_verifies_nothing():
    """No verifier: an infeasible task is still proved infeasible; a feasible one ends with no
    verified solution (never a solution that was not verified)."""
    bare = replace(FAST, verifier=None)
    assert solve_complete(pincer_task(55.0), bare).status == Status.INFEASIBLE
    feasible = solve_complete(pincer_task(30.0), replace(bare, max_boxes=30))
    assert feasible.status != Status.SOLVED and not feasible.solutions
    with pytest.raises(PrehensionError, match="verifier must be a BoxVerifier"):
        BranchAndPruneOptions(verifier=lambda task, starts: None)
