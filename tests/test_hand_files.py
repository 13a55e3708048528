"""Hands named by file in task files ({urdf: ...}, {mjcf: ...}, {file: ...}): reading,
fingertip overrides, writing the reference back, result files that stand alone."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from conftest import HANDS_DIR, random_angles
from prehension.pregrasp import approach_entries_of
from prehension.errors import InvalidHand, InvalidTask
from prehension.hands.kinematics import forward_kinematics
from prehension.tasks.format.tasks import resolve_hand
from prehension.tasks.yaml_io import dumps_task, load_task, loads_task, task_to_dict

ALLEGRO = HANDS_DIR / "allegro_hand" / "allegro_hand_right.urdf"
SVH = HANDS_DIR / "schunk_hand" / "schunk_svh_hand_right.urdf"
COUPLED = Path(__file__).resolve().parent / "data" / "coupled_hand.xml"
requires_hands = pytest.mark.skipif(not HANDS_DIR.is_dir(), reason="shared/hands not present beside the checkout")

TASK = """prehension: task/1
name: pinch
hand: {HAND}
object:
  name: ball
  regions:
    ball: {{sphere_cap: {{center: [70, 20, 100], radius: 25, axis: [1, 0, 0], half_angle_deg: 180}}}}
contacts:
  - {{hand: thumb_tip, object: ball}}
  - {{hand: index_tip, object: ball}}
fingers: [thumb, index]
"""


def _copy_allegro(tmp_path) -> Path:
    """The Allegro URDF and its meshes copied beside a task (the task names it relatively)."""
    folder = tmp_path / "hands" / "allegro"
    shutil.copytree(ALLEGRO.parent, folder)
    return folder / ALLEGRO.name


def _task_file(tmp_path, hand: str, name: str = "task.yaml") -> Path:
    path = tmp_path / name
    path.write_text(TASK.format(HAND=hand))
    return path


@requires_hands
def test_urdf_task_file_reads_and_writes_the_reference(tmp_path, rng):
    _copy_allegro(tmp_path)
    path = _task_file(tmp_path, "{urdf: hands/allegro/allegro_hand_right.urdf}")
    assert len(path.read_text().splitlines()) <= 20
    task = load_task(path)
    hand = task.hand
    assert hand.source.format == "urdf" and hand.source.path == str((tmp_path / "hands/allegro/allegro_hand_right.urdf").resolve())
    assert {"thumb_tip", "index_tip"} <= set(hand.regions)
    data = task_to_dict(task, base_dir=tmp_path)
    assert data["hand"] == {"urdf": "hands/allegro/allegro_hand_right.urdf"}  # a reference, not the hand
    assert len(dumps_task(task, base_dir=tmp_path)) < 600
    again = loads_task(dumps_task(task, base_dir=tmp_path), base_dir=tmp_path)
    assert again.hand is hand  # the same file read with the same options: the same hand, from the cache


@requires_hands
def test_task_changes_are_written_as_differences(tmp_path):
    _copy_allegro(tmp_path)
    text = TASK.format(HAND="{urdf: hands/allegro/allegro_hand_right.urdf}")
    text += "hand_limits_deg: {joint_1.0: [0, 45]}\nhand_regions:\n"
    text += "  nail: {link: link_3.0, point: [10, 0, 30], normal: [1, 0, 0]}\n"
    task = loads_task(text, base_dir=tmp_path)
    data = task_to_dict(task, base_dir=tmp_path)
    assert data["hand"] == {"urdf": "hands/allegro/allegro_hand_right.urdf"}
    assert data["hand_limits_deg"] == {"joint_1.0": [0.0, 45.0]}
    assert list(data["hand_regions"]) == ["nail"]


@requires_hands
def test_fingertip_overrides_in_degrees(tmp_path):
    _copy_allegro(tmp_path)
    hand_value = (
        "{urdf: hands/allegro/allegro_hand_right.urdf, root: base_link, "
        "fingertips: {index: {radius: 13.5, half_angle_deg: 45}, "
        "thumb: {link: link_15.0, center: [0, 0, 40], radius: 11, axis: [1, 0, 0], half_angle_deg: 50}}}"
    )
    task = load_task(_task_file(tmp_path, hand_value))
    hand = task.hand
    index, fitted = hand.regions["index_tip"].region, hand.regions["middle_tip"].region
    assert index.radius == 13.5 and index.half_angle == pytest.approx(math.radians(45))
    np.testing.assert_allclose(index.center, fitted.center)  # not overridden: the fit's (same finger geometry)
    assert hand.tip_fits["index_tip"].overridden == ("radius", "half_angle_deg")
    thumb = hand.regions["thumb_tip"].region
    np.testing.assert_allclose(thumb.center, [0, 0, 40])
    assert hand.tip_fits["thumb_tip"].geometry == "override"
    written = task_to_dict(task, base_dir=tmp_path)["hand"]
    assert written["fingertips"]["index"] == {"radius": 13.5, "half_angle_deg": 45.0}
    assert written["root"] == "base_link"
    assert loads_task(dumps_task(task, base_dir=tmp_path), base_dir=tmp_path).hand is hand


@requires_hands
@pytest.mark.parametrize(
    "hand_value, pattern",
    [
        ("{urdf: nowhere.urdf}", r"hand\.urdf: hand file not found: .*nowhere\.urdf"),
        ("{urdf: a.urdf, mjcf: b.xml}", r"hand: give exactly one of urdf, mjcf"),
        ("{urdf: hands/allegro/allegro_hand_right.urdf, tips: {}}", r"hand: extra key 'tips' not allowed here; allowed keys: urdf, mjcf, root, name, fingertips"),
        ("{urdf: hands/allegro/allegro_hand_right.urdf, fingertips: {pinky: {radius: 3}}}",
         r"hand: .*fingertip given for unknown finger\(s\) \['pinky'\]; fingers are: index, middle, ring, thumb"),
        ("{urdf: hands/allegro/allegro_hand_right.urdf, fingertips: {index: {half_angle_deg: 200}}}",
         r"hand\.fingertips\.index\.half_angle_deg"),
        ("{urdf: hands/allegro/allegro_hand_right.urdf, root: nope}", r"hand: .*root link 'nope' not found"),
    ],
)  # fmt: skip
def test_bad_hand_references(tmp_path, hand_value, pattern):
    _copy_allegro(tmp_path)
    with pytest.raises(InvalidTask, match=pattern):
        load_task(_task_file(tmp_path, hand_value))


@requires_hands
def test_a_merged_frame_named_as_a_link_gets_a_hint(tmp_path):
    _copy_allegro(tmp_path)
    text = TASK.format(HAND="{urdf: hands/allegro/allegro_hand_right.urdf}")
    text += "hand_regions:\n  tip: {link: link_3.0_tip, point: [0, 0, 10], normal: [1, 0, 0]}\n"
    with pytest.raises(InvalidTask, match=r"hand_regions\.tip\.link: link 'link_3.0_tip' not found: it is a frame "
                                          r"fixed to link 'link_3.0'.*\[0, 0, 38.7\] mm.*name link 'link_3.0' instead"):
        loads_task(text, base_dir=tmp_path)


@requires_hands
def test_an_edited_hand_file_is_written_inline(tmp_path):
    urdf = _copy_allegro(tmp_path)
    task = load_task(_task_file(tmp_path, "{urdf: hands/allegro/allegro_hand_right.urdf}"))
    urdf.write_text(urdf.read_text().replace('upper="1.618"', 'upper="1.5"'))
    data = task_to_dict(task, base_dir=tmp_path)
    assert isinstance(data["hand"], dict) and "links" in data["hand"]  # no longer the file's hand: inline
    assert data["hand"]["source"]["sha256"] == task.hand.source.sha256


@requires_hands
def test_result_files_hold_the_hand_and_stand_alone(tmp_path, rng):
    from prehension.results import SolveResult, read_result, write_result
    from prehension.quality import quality_entries

    urdf = _copy_allegro(tmp_path)
    task = load_task(_task_file(tmp_path, "{urdf: hands/allegro/allegro_hand_right.urdf}"))
    result = SolveResult(task, "local", "gave_up", "test")
    write_result(result, tmp_path / "r.json", quality_entries(result), approach_entries_of(result))
    shutil.rmtree(urdf.parent)  # the hand file is gone: the result still reads
    again, data = read_result(tmp_path / "r.json")
    assert data["task"]["hand"]["source"]["path"] == str(urdf.resolve())
    assert again.hand.link_names == task.hand.link_names and again.hand.frames.keys() == task.hand.frames.keys()
    q = random_angles(task.hand, rng, 5)
    np.testing.assert_allclose(forward_kinematics(again.hand, q).T_palm_link, forward_kinematics(task.hand, q).T_palm_link,
                               atol=1e-12)  # fmt: skip
    for name, reg in task.hand.regions.items():
        np.testing.assert_allclose(again.hand.regions[name].region.center, reg.region.center)


def test_mjcf_task_file(tmp_path):
    pytest.importorskip("mujoco")
    shutil.copy(COUPLED, tmp_path / "hand.xml")
    task = load_task(_task_file(tmp_path, "{mjcf: hand.xml}"))
    assert task.hand.source.format == "mjcf" and task.hand.palm == "palm"
    assert task_to_dict(task, base_dir=tmp_path)["hand"] == {"mjcf": "hand.xml"}


# -- the command line's hand names ------------------------------------------------------------
def test_resolve_hand(tmp_path):
    assert resolve_hand("sa").name == resolve_hand("schunk-sa").name == "schunk-sa"
    with pytest.raises(InvalidHand, match=r"'nope' is neither a built-in hand \(schunk-sa, schunk-sa-enclosing; aliases: sa \(schunk-sa\)\)"):
        resolve_hand("nope")
    with pytest.raises(InvalidHand, match=r"hand file not found: .*x\.urdf"):
        resolve_hand(tmp_path / "x.urdf")
    task = tmp_path / "t.yaml"
    task.write_text(TASK.format(HAND="schunk-sa"))
    assert resolve_hand(task).name == "schunk-sa"  # a task file: its hand
