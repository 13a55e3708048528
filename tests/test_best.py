"""solve --best N: distinct verified solutions, ranked by quality."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from prehension.best import BestOptions, distinct, solve_best
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.errors import PrehensionError
from prehension.quality import QualityOptions, grasp_quality
from prehension.results import Status
from prehension.solve import SolveOptions
from prehension.solvers.complete.search import BranchAndPruneOptions
from prehension.tasks.library import load_builtin_task
from prehension.verification.residuals import evaluate
from tiny_tasks import pincer_task

SOFT = QualityOptions(torsion_mm=5.0)


@pytest.fixture(scope="module")
def lid():
    return load_builtin_task("teapot-lid-lifting")


@pytest.fixture(scope="module")
def best_lid(lid):
    return solve_best(lid, BestOptions(n=4, starts=40, quality=SOFT), SolveOptions(seed=3))


def test_the_best_are_verified_distinct_and_ranked_by_epsilon(lid, best_lid):
    result = best_lid
    assert result.status == Status.SOLVED and 2 <= len(result.solutions) <= 4
    for s in result.solutions:
        assert evaluate(lid, s.configuration()).ok  # strict tolerances
    for a, b in itertools.combinations(result.solutions, 2):
        assert distinct(a, b, lid, BestOptions())
    eps = [grasp_quality(lid, s, SOFT).epsilon for s in result.solutions]
    assert eps == sorted(eps, reverse=True) and eps[0] > 0
    best = result.stats["best"]
    assert best["epsilon"] == pytest.approx(eps, abs=1e-9)
    assert best["candidates"] >= best["distinct"] >= len(result.solutions)
    assert best["rank"] == "q1" and best["quality_options"]["torsion_mm"] == 5.0


def test_the_same_seed_gives_the_same_grasps(lid, best_lid):
    again = solve_best(lid, BestOptions(n=4, starts=40, quality=SOFT), SolveOptions(seed=3))
    assert [s.q.tolist() for s in again.solutions] == [s.q.tolist() for s in best_lid.solutions]


def test_other_rankings(lid):
    by_volume = solve_best(lid, BestOptions(n=3, starts=30, rank="volume", quality=SOFT), SolveOptions(seed=1))
    volumes = [grasp_quality(lid, s, SOFT).volume for s in by_volume.solutions]
    assert volumes == sorted(volumes, reverse=True)
    found = solve_best(lid, BestOptions(n=3, starts=30, rank="found", quality=SOFT), SolveOptions(seed=1))
    assert found.stats["best"]["sources"][0] == "local solver (off-line sequence)"


def test_a_looser_distinctness_keeps_fewer(lid):
    strict = solve_best(lid, BestOptions(n=50, starts=30), SolveOptions(seed=2))
    loose = solve_best(lid, BestOptions(n=50, starts=30, joint_deg=40.0, position_mm=80.0, rotation_deg=60.0), SolveOptions(seed=2))
    assert strict.stats["best"]["candidates"] == loose.stats["best"]["candidates"]
    assert len(loose.solutions) < len(strict.solutions)


def test_distinct_is_at_least_one_stated_distance(best_lid, lid):
    a = best_lid.solutions[0]
    assert not distinct(a, a, lid)
    moved = a.configuration()
    T = moved.T_palm_object.copy()
    T[0, 3] += 6.0
    from prehension.tasks.model import Configuration

    assert distinct(a, Configuration(a.q, T), lid)
    assert not distinct(a, Configuration(a.q, T), lid, BestOptions(position_mm=7.0))


def test_no_solution_is_proven_or_given_up():
    far = pincer_task(60.0)
    assert solve_best(far, BestOptions(n=3, starts=10)).status == Status.INFEASIBLE  # auto: the complete solver's proof
    local = solve_best(far, BestOptions(n=3, starts=10), "local")
    assert local.status == Status.GAVE_UP and "10 random starts" in local.message


def test_the_complete_solvers_solution_set():
    result = solve_best(pincer_task(40.0), BestOptions(n=3, starts=0, time_limit_s=12), SolveOptions(method="complete",
                        complete_options=BranchAndPruneOptions(sigma=0.5)))  # fmt: skip
    assert result.method == "complete" and result.solutions
    assert set(result.stats["best"]["sources"]) == {"complete solver (solution set)"}
    for s in result.solutions:
        assert evaluate(pincer_task(40.0), s.configuration()).ok


@pytest.mark.parametrize("kwargs, message", [
    ({"n": 0}, "n must be an integer >= 1"),
    ({"rank": "q2"}, "rank must be one of q1, volume, found"),
    ({"starts": -1}, "starts must be an integer >= 0"),
    ({"joint_deg": 0.0}, "joint_deg must be a positive number"),
    ({"time_limit_s": 0}, "time limit must be > 0 s"),
])  # fmt: skip
def test_bad_options_are_refused_by_name(kwargs, message):
    with pytest.raises(PrehensionError, match=message):
        BestOptions(**kwargs)


def test_solve_best_on_the_command_line(tmp_path, capsys):
    out = tmp_path / "best.json"
    code = main(["solve", "teapot-lid-lifting", "--method", "local", "--best", "3", "--starts", "20", "--torsion", "5",
                 "-o", str(out)])  # fmt: skip
    assert code == EXIT_OK
    text = capsys.readouterr().out
    assert "ranked by q1" in text and "force closure" in text
    data = json.loads(out.read_text())
    assert 1 <= len(data["solutions"]) <= 3
    eps = [s["quality"]["epsilon"] for s in data["solutions"]]
    assert eps == sorted(eps, reverse=True) and data["stats"]["best"]["requested"] == 3
    assert all(s["quality"]["options"]["torsion_mm"] == 5.0 for s in data["solutions"])
    assert main(["check", str(out)]) == EXIT_OK


@pytest.mark.parametrize("extra, message", [
    (["--all"], "cannot be combined with --all"),
    (["--approximate"], "cannot be combined with --approximate"),
    (["--starts", "-3"], "--starts must be an integer >= 0"),
    (["--distinct-mm", "0"], "--distinct-mm must be a positive number"),
    (["--ascent-steps", "-1"], "--ascent-steps must be an integer >= 0"),
    (["--require", "force-closure"], "cannot be combined with --require"),
    (["--friction", "-1"], "--friction must be a number >= 0"),
])  # fmt: skip
def test_bad_best_arguments_are_refused(tmp_path, capsys, extra, message):
    assert main(["solve", "teapot-lid-lifting", "--best", "2", "-o", str(tmp_path / "r.json"), *extra]) == EXIT_BAD_INPUT
    assert message in capsys.readouterr().err


def test_plain_solve_prints_and_stores_the_quality(tmp_path, capsys):
    out = tmp_path / "r.json"
    assert main(["solve", "teapot-lid-lifting", "--method", "local", "--friction", "0.4", "-o", str(out)]) == EXIT_OK
    assert "quality of solution 0: NOT force closure" in capsys.readouterr().out
    assert json.loads(out.read_text())["solutions"][0]["quality"]["options"]["friction"] == 0.4
