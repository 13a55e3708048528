"""Hands on the command line: show HAND, export-hand, offline HAND, solve/batch --sequence,
and the issue's acceptance test: a short task file naming a URDF or MJCF hand solves."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from conftest import HANDS_DIR
from fk_tasks import build_fk_case
from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.hands.files import load_hand_file

DATA = Path(__file__).resolve().parent / "data"
requires_hands = pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")
SHARED = {
    "svh": HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf",
    "allegro": HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf",
}


@pytest.fixture
def wide(monkeypatch):
    monkeypatch.setenv("COLUMNS", "250")  # rich tables unwrapped


def test_show_a_hand(capsys, wide):
    assert main(["show", "sa"]) == EXIT_OK
    out = capsys.readouterr().out
    assert "schunk-sa: palm 'palm', 14 links, 17 joint angles, 4 couplings" in out
    for text in ("thumb (opposes)", "index_tip on index_distal", "index_mcp_flex", "= 1 index_pip"):
        assert text in out


@requires_hands
def test_show_a_urdf_hand_lists_fingers_fits_and_notes(capsys, wide):
    assert main(["show", str(SHARED["allegro"])]) == EXIT_OK
    out = capsys.readouterr().out
    for text in ("allegro_right from", "palm 'base_link'", "thumb (opposes)", "index_tip on link_3.0", "rms 0.75",
                 "fingers named from the geometry", "link_3.0_tip (on link_3.0)"):
        assert text in out, text


def test_show_an_mjcf_hand(capsys, wide):
    pytest.importorskip("mujoco")
    assert main(["show", str(DATA / "coupled_hand.xml")]) == EXIT_OK
    out = capsys.readouterr().out
    assert "coupled-hand from" in out and "= 0.8 index_pip" in out and "cut off above it" in out


def test_export_hand(tmp_path, capsys):
    out = tmp_path / "sa.urdf"
    assert main(["export-hand", "sa", "-o", str(out)]) == EXIT_OK
    assert "wrote" in capsys.readouterr().out and out.read_text().startswith('<?xml version="1.0"?>\n<robot name="schunk-sa">')
    assert main(["export-hand", "sa", "-o", str(out)]) == EXIT_BAD_INPUT
    assert "already exists; pass --force" in capsys.readouterr().err
    assert main(["export-hand", "sa", "-o", str(tmp_path / "sa.obj")]) == EXIT_BAD_INPUT
    assert "give a .urdf (URDF) or .xml/.mjcf (MJCF) file" in capsys.readouterr().err
    assert main(["export-hand", "sa", "-o", str(tmp_path / "sa.xml")]) == EXIT_OK
    assert (tmp_path / "sa.xml").read_text().startswith('<mujoco model="schunk-sa">')


# -- the acceptance test of the issue ------------------------------------------------------------
def _short_task(hand_ref: str, hand, rng, fingers) -> str:
    """A task file naming ``hand_ref`` whose contacts hold at a forward-built configuration."""
    case = build_fk_case(hand, rng, fingers=fingers, palm=False, kinds=("point",) * len(fingers))
    lines = ["prehension: task/1", "name: fk", f"hand: {hand_ref}", "object:", "  name: points", "  regions:"]
    for name, region in case.task.object.regions.items():
        p, n = (", ".join(f"{x:.9g}" for x in v) for v in (region.point, region.normal))
        lines.append(f"    {name}: {{point: [{p}], normal: [{n}]}}")
    lines.append("contacts:")
    lines += [f"  - {{hand: {c.hand_region}, object: {c.object_region}}}" for c in case.task.contacts]
    lines.append(f"fingers: [{', '.join(fingers)}]")
    return "\n".join(lines) + "\n"


@requires_hands
@pytest.mark.parametrize("form", ["urdf", "mjcf"])
@pytest.mark.parametrize("which, fingers", [("svh", ("thumb", "index")), ("allegro", ("thumb", "index", "middle"))])
def test_a_short_task_file_naming_a_hand_file_solves(tmp_path, capsys, which, fingers, form):
    path = SHARED[which]
    if form == "mjcf":
        pytest.importorskip("mujoco")
        from prehension.hands.mjcf import urdf_to_mjcf

        path = urdf_to_mjcf(path, tmp_path / f"{which}.xml")
    rng = np.random.default_rng(7)
    text = _short_task(f"{{{form}: {path}}}", load_hand_file(path), rng, fingers)
    assert len(text.splitlines()) <= 20
    task = tmp_path / "task.yaml"
    task.write_text(text)
    result = tmp_path / "r.json"
    assert main(["solve", str(task), "-o", str(result), "--quiet"]) == EXIT_OK  # the default method (auto)
    assert json.loads(result.read_text())["status"] == "solved"
    assert main(["check", str(result)]) == EXIT_OK


# -- off-line sequences for any hand -------------------------------------------------------------
def test_offline_any_hand_and_solve_with_the_sequence(tmp_path, capsys):
    pytest.importorskip("mujoco")
    seq = tmp_path / "seq.json"
    hand_file = DATA / "coupled_hand.xml"
    args = ["offline", str(hand_file), "-o", str(seq), "--M", "8", "--N", "2", "--imax", "2"]
    assert main(args) == EXIT_OK
    assert "Initial poses of coupled-hand" in capsys.readouterr().out
    data = json.loads(seq.read_text())
    assert data["hand"] == "coupled-hand" and data["meta"]["hand_regions"] == ["thumb_tip", "index_tip", "middle_tip"]
    text = _short_task(f"{{mjcf: {hand_file}}}", load_hand_file(hand_file), np.random.default_rng(3), ("thumb", "index"))
    (tmp_path / "t.yaml").write_text(text)
    result = tmp_path / "r.json"
    assert main(["solve", str(tmp_path / "t.yaml"), "--method", "local", "--sequence", str(seq), "-o", str(result),
                 "--quiet"]) == EXIT_OK  # fmt: skip
    assert json.loads(result.read_text())["stats"]["sequence"].startswith("offline_sequence(M=8, N=2, imax=2")
    shipped = Path(__file__).resolve().parents[1] / "src/prehension/solvers/local/data/schunk-sa.json"
    assert main(["solve", str(tmp_path / "t.yaml"), "--sequence", str(shipped), "-o", str(result)]) == EXIT_BAD_INPUT
    assert "sequence was made for hand 'schunk-sa', not for the task's hand 'coupled-hand'" in capsys.readouterr().err
    assert main(["offline", "sa", "-o", str(tmp_path / "s.json"), "--regions", "thumb_tip,nope"]) == EXIT_BAD_INPUT
    assert "hand region 'nope' not found" in capsys.readouterr().err


def test_batch_uses_the_sequence_of_each_tasks_hand(sa_hand):
    from prehension.batch.solving import BatchOptions, solve_chunk
    from prehension.solvers.local import OfflineSearch, offline_sequence

    seq = offline_sequence(sa_hand, OfflineSearch(M=6, N=2, imax=1, seed=1))
    entry = {"id": "a", "name": "lid", "source": "x", "payload": {"kind": "builtin", "name": "teapot-lid-lifting"}}
    (record,) = [json.loads(r.line) for r in solve_chunk([entry], BatchOptions(method="local", sequences=(seq.to_dict(),))).records]
    assert record["result"]["stats"]["sequence"].startswith("offline_sequence(M=6, N=2, imax=1, seed=1)")
    (record,) = [json.loads(r.line) for r in solve_chunk([entry], BatchOptions(method="local")).records]
    assert record["result"]["stats"]["sequence"] != seq.meta["origin"]  # no sequence for the hand: its default
    with pytest.raises(Exception, match="one initial-pose sequence per hand"):
        BatchOptions(sequences=(seq.to_dict(), seq.to_dict()))


def test_batch_command_line_reads_the_sequence_files(tmp_path, sa_hand):
    from prehension.cli import build_parser
    from prehension.cli.batch import _sequences
    from prehension.solvers.local import OfflineSearch, offline_sequence

    path = tmp_path / "sa.json"
    offline_sequence(sa_hand, OfflineSearch(M=6, N=2, imax=1, seed=1)).save(path)
    args = build_parser().parse_args(["batch", "in.jsonl", "-o", "out.jsonl", "--sequence", str(path)])
    (data,) = _sequences(args.sequence)
    assert data["hand"] == "schunk-sa" and len(data["lambdas"]) == 1
    (tmp_path / "bad.json").write_text("{}")
    from prehension.errors import InvalidTask

    with pytest.raises(InvalidTask, match="not an initial-pose sequence"):
        _sequences([tmp_path / "bad.json"])
