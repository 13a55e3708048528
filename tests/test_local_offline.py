"""The off-line sequence of initial poses (Claret & Suárez, sec. 3.2): search, files, PCA."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np
import pytest

from prehension.errors import PrehensionError
from prehension.solvers.local import PAPER_TABLE1, InitialPoseSequence, LocalOptions, default_sequence
from prehension.solvers.local.offline import OfflineSearch, compare_with_paper, grid_values, offline_sequence
from prehension.solvers.local.sequence import SEQUENCE_TAG, pose_space, principal_directions, sample_poses, shipped_sequence


def test_a_tiny_offline_search_runs_and_round_trips(tmp_path, sa_hand):
    calls = []
    search = OfflineSearch(M=12, N=3, imax=2, seed=1, n_samples=300, options=LocalOptions(k_max=30))
    seq = offline_sequence(sa_hand, search, progress=lambda d, t, m: calls.append((d, t, m)))
    assert len(seq) == 2 and seq.lambdas.shape == (2, 2)
    assert set(np.round(seq.lambdas.ravel(), 12)) <= {0.0, 0.5, 1.0}
    assert len(seq.success) == 2 and all(s.shape == (3, 3) for s in seq.success)
    assert all(0.0 <= s.min() and s.max() <= 1.0 for s in seq.success)
    assert calls[-1][:2] == (2, 2) and calls[0][2] == "pose 1/2"
    assert seq.meta["M"] == 12 and seq.meta["N"] == 3 and seq.meta["seconds"] > 0
    assert len(seq.meta["estimated_cumulative_success"]) == 2
    path = tmp_path / "seq.json"
    seq.save(path)
    again = InitialPoseSequence.load(path)
    np.testing.assert_array_equal(again.lambdas, seq.lambdas)
    np.testing.assert_array_equal(again.mean, seq.mean)
    np.testing.assert_array_equal(again.components, seq.components)
    assert again.names == seq.names and again.hand == "schunk-sa"
    np.testing.assert_array_equal(again.success[1], seq.success[1])
    assert json.loads(path.read_text())["prehension"] == SEQUENCE_TAG
    assert not list(tmp_path.glob(".*.tmp"))  # written atomically, nothing left behind


def test_the_search_runs_on_an_executor_with_the_same_answer(sa_hand):
    search = OfflineSearch(M=8, N=2, imax=1, seed=3, n_samples=200, options=LocalOptions(k_max=20))
    inline = offline_sequence(sa_hand, search)
    with ThreadPoolExecutor(max_workers=2) as ex:
        pooled = offline_sequence(sa_hand, replace(search, chunks_per_step=3), executor=ex)
    np.testing.assert_array_equal(inline.lambdas, pooled.lambdas)
    np.testing.assert_array_equal(inline.success[0], pooled.success[0])


def test_poses_follow_eq_11():
    names = ("a", "b", "c")
    seq = InitialPoseSequence("h", names, [1.0, 2.0, 3.0], [[1, 0, 0], [0, 1, 0]], [0.5, 0.25], [[0.5, 0.5], [1.0, 0.0]])
    np.testing.assert_allclose(seq.pose(0), [1.0, 2.0, 3.0])
    np.testing.assert_allclose(seq.pose(1), [1.0 + 1.5, 2.0 - 0.75, 3.0])


def test_pose_space_of_the_sa_hand(sa_hand):
    names, free, tips = pose_space(sa_hand)
    assert len(free) == 13 and len(tips) == 4 and len(names) == 21  # the paper's 25 less 4 coupled
    assert "ring_dip" not in names and "thumb.tip.alpha" in names
    names, samples = sample_poses(sa_hand, 50, np.random.default_rng(0))
    assert samples.shape == (50, 21)
    mean, comps, sig = principal_directions(samples)
    np.testing.assert_allclose(comps @ comps.T, np.eye(2), atol=1e-12)
    assert sig[0] >= sig[1] > 0


def test_the_sa_hand_ships_its_sequence(sa_hand):
    seq = shipped_sequence(sa_hand)
    assert seq is not None and len(seq) == 12 and seq.hand == "schunk-sa"
    assert default_sequence(sa_hand) is default_sequence(sa_hand)  # cached
    assert "M" in seq.meta and "N" in seq.meta


def test_comparison_with_table1():
    seq = InitialPoseSequence("h", ("a",), [0.0], [[1.0], [1.0]], [1.0, 1.0], [[0.1, 0.2]])
    rows = compare_with_paper(seq)
    assert len(rows) == 12
    assert rows[0] == (1, (0.1, 0.2), tuple(PAPER_TABLE1[0]))
    assert rows[1][1] is None
    np.testing.assert_allclose(grid_values(30)[[15, 14, 23, 1]], [0.517, 0.483, 0.793, 0.034], atol=5e-4)  # Table 1's grid


def test_bad_inputs_are_reported(tmp_path, sa_hand):
    with pytest.raises(PrehensionError, match="M must be an integer >= 1"):
        OfflineSearch(M=0)
    with pytest.raises(PrehensionError, match="N >= 2"):
        grid_values(1)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(PrehensionError, match="not an initial-pose sequence"):
        InitialPoseSequence.load(bad)
    bad.write_text("{")
    with pytest.raises(PrehensionError, match="invalid JSON"):
        InitialPoseSequence.load(bad)
    with pytest.raises(PrehensionError, match=r"lambda must lie in \[0, 1\]"):
        InitialPoseSequence("h", ("a",), [0.0], [[1.0], [1.0]], [1.0, 1.0], [[1.5, 0.2]])


def test_cli_offline_writes_the_file_and_prints_table1(tmp_path):
    import io

    from rich.console import Console

    from prehension.cli.offline import cli_offline

    out = tmp_path / "sa.json"
    buf = io.StringIO()
    seq = cli_offline("schunk-sa", out, OfflineSearch(M=6, N=2, imax=1), console=Console(file=buf, width=120))
    assert out.is_file() and InitialPoseSequence.load(out).lambdas.shape == (1, 2)
    text = buf.getvalue()
    assert "Table 1" in text and "0.517" in text and f"wrote {out}" in text
    with pytest.raises(PrehensionError, match="already exists"):
        cli_offline("schunk-sa", out, OfflineSearch(M=6, N=2, imax=1), console=Console(file=buf))
    with pytest.raises(PrehensionError, match="'allegro' is neither a built-in hand"):
        cli_offline("allegro", tmp_path / "x.json", console=Console(file=buf))
    assert len(seq) == 1
