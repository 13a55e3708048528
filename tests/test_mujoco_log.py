"""MuJoCo's warnings go to prehension's log, never to stdout or a file in the user's folder,
and a simulation that goes unstable is a drop, never a hold: MuJoCo resets its state when
it meets a NaN or huge acceleration, and the object then reads as unmoved."""

from __future__ import annotations

import logging

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from prehension import load_builtin_task  # noqa: E402
from prehension import mujoco_log  # noqa: E402
from prehension.sim import SimOptions, simulate_grasp  # noqa: E402
from prehension.sim.run import _Sim  # noqa: E402
from prehension.solve import solve  # noqa: E402

UNSTABLE = SimOptions(kp=1e9, timestep_s=0.02)  # stiff actuators, long steps: the integration blows up


@pytest.fixture(scope="module")
def grasp():
    task = load_builtin_task("scalpel-handling")
    result = solve(task, "local")
    assert result.success
    return task, result.solutions[0]


def test_an_unstable_simulation_drops_every_push_and_prints_nothing(grasp, tmp_path, monkeypatch, capfd, caplog):
    monkeypatch.chdir(tmp_path)
    task, solution = grasp
    with caplog.at_level(logging.WARNING, logger=mujoco_log.LOGGER_NAME):
        report = simulate_grasp(task, solution, UNSTABLE)
    assert not report.success and report.pushes
    assert all(p.unstable and not p.held for p in report.pushes)
    assert "went unstable in 6 of them" in report.describe()
    assert all(p["unstable"] for p in report.to_dict()["pushes"])
    out = capfd.readouterr()
    assert out.out == "" and "MuJoCo" not in out.err  # the logger has no handler here: caplog only
    assert not list(tmp_path.iterdir()), "MuJoCo must not leave MUJOCO_LOG.TXT in the working folder"
    assert any("unstable" in r.getMessage() for r in caplog.records if r.name == mujoco_log.LOGGER_NAME)


def test_the_verdict_reads_instability_not_the_distances_after_the_reset(grasp, monkeypatch):
    """What the counters change: read without them, the same blown-up pushes would all 'hold'
    (MuJoCo put the object back where it started)."""
    task, solution = grasp
    monkeypatch.setattr(_Sim, "_unstable", lambda self: False)
    blind = simulate_grasp(task, solution, UNSTABLE)
    assert blind.success and all(p.shift_mm < 1e-6 for p in blind.pushes)


def test_closing_from_the_pre_grasp_is_not_reached_when_unstable(grasp):
    task, solution = grasp
    report = simulate_grasp(task, solution, UNSTABLE, pregrasp_q=np.asarray(solution.q) - 0.05)
    assert report.closing is not None and report.closing.unstable and not report.closing.reached
    assert not report.success and "went unstable" in report.describe()


def test_a_stable_grasp_reports_no_instability(grasp):
    task, solution = grasp
    report = simulate_grasp(task, solution)
    assert report.pushes and not any(p.unstable for p in report.pushes)


def test_a_handler_the_program_installed_is_kept(monkeypatch):
    seen = []
    before = mujoco.get_mju_user_warning()
    monkeypatch.setattr(mujoco_log, "_installed", False)
    mujoco.set_mju_user_warning(seen.append)
    try:
        mujoco_log.import_mujoco()
        model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>')
        data = mujoco.MjData(model)
        data.qvel[:] = 1e300
        mujoco.mj_step(model, data)
        assert seen and "unstable" in seen[0]
    finally:
        mujoco.set_mju_user_warning(before)
