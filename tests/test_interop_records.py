"""Grasp records out and in (DexGraspBench, DexGraspNet, json-m): round trips, layouts, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import random_angles
from prehension.pregrasp import approach_entries_of
from prehension.errors import InvalidConfiguration, InvalidTask
from prehension.interop.dexgraspbench import read_dexgraspbench, record_from_dict, write_dexgraspbench
from prehension.interop.dexgraspnet import read_dexgraspnet, write_dexgraspnet
from prehension.interop.json_m import read_json_m, write_json_m
from prehension.interop.npy import load_npy, save_npy
from prehension.hands.qpos import base_from_transform
from prehension.interop.readers import read_records
from prehension.interop.records import GraspRecord
from test_interop_qpos import random_pose

WRITERS = {"dexgraspbench": write_dexgraspbench, "dexgraspnet": write_dexgraspnet, "json-m": write_json_m}
READERS = {"dexgraspbench": read_dexgraspbench, "dexgraspnet": read_dexgraspnet, "json-m": read_json_m}
SUFFIX = {"dexgraspbench": ".npy", "dexgraspnet": ".npy", "json-m": ".json"}


def random_records(hand, rng, n: int) -> list[GraspRecord]:
    qs = random_angles(hand, rng, 3 * n)
    names = hand.dof_names
    scale = 1000.0 * rng.uniform(0.05, 0.2)  # one object, as in one result file
    return [
        GraspRecord(random_pose(rng), dict(zip(names, qs[3 * k])), dict(zip(names, qs[3 * k + 1])),
                    dict(zip(names, qs[3 * k + 2])), "/data/box.obj", scale)
        for k in range(n)
    ]  # fmt: skip


def assert_same(a: GraspRecord, b: GraspRecord, hand, stages=("joint_angles", "pregrasp", "squeeze")) -> None:
    assert np.max(np.abs(a.T_palm_object[:3, 3] - b.T_palm_object[:3, 3])) <= 1e-9  # mm
    assert np.max(np.abs(a.T_palm_object[:3, :3] - b.T_palm_object[:3, :3])) <= 1e-12
    for stage in stages:
        x, y = getattr(a, stage), getattr(b, stage)
        assert max(abs(x[d] - y[d]) for d in hand.dof_names) <= 1e-9, stage
    assert a.object_scale_mm == pytest.approx(b.object_scale_mm, rel=1e-12)


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_every_format_round_trips_seeded_random_grasps(fmt, sa_hand, rng, tmp_path):
    records = random_records(sa_hand, rng, 20)
    out = tmp_path / ("grasps" if fmt == "dexgraspbench" else f"grasps{SUFFIX[fmt]}")
    WRITERS[fmt](records, sa_hand, out)
    if fmt == "dexgraspbench":  # one file per grasp
        back = [r for k in range(len(records)) for r in READERS[fmt](out / f"{k}.npy", sa_hand)]
    else:
        back = READERS[fmt](out, sa_hand)
    assert len(back) == len(records)
    stages = ("joint_angles",) if fmt == "dexgraspnet" else ("joint_angles", "pregrasp", "squeeze")  # DexGraspNet: grasp only
    for a, b in zip(records, back):
        assert_same(a, b, sa_hand, stages)


def test_a_dexgraspbench_dict_has_the_benchmarks_keys(sa_hand, rng, tmp_path):
    record = random_records(sa_hand, rng, 1)[0]
    write_dexgraspbench([record], sa_hand, tmp_path / "g.npy")
    data = np.load(tmp_path / "g.npy", allow_pickle=True).item()  # as DexGraspBench reads it
    for key in ("pregrasp_qpos", "grasp_qpos", "squeeze_qpos"):
        assert data[key].shape == (7 + sa_hand.n_dof,)
    np.testing.assert_array_equal(data["obj_pose"], [0, 0, 0, 1, 0, 0, 0])
    assert data["obj_scale"] == pytest.approx(record.object_scale_mm / 1000.0) and data["obj_path"] == "/data/box.obj"
    np.testing.assert_allclose(data["grasp_qpos"][:7], base_from_transform(record.T_palm_object))


def test_a_dexgraspbench_grasp_in_a_world_frame_is_taken_into_the_object_frame(sa_hand, rng, tmp_path):
    """obj_pose not the identity, and the older layout (grasp_pose apart from grasp_qpos)."""
    record = random_records(sa_hand, rng, 1)[0]
    T_world_object = random_pose(rng)
    T_world_palm = T_world_object @ np.linalg.inv(record.T_palm_object)
    palm = base_from_transform(np.linalg.inv(T_world_palm))  # the palm's pose in the world
    obj = base_from_transform(np.linalg.inv(T_world_object))
    joints = [record.joint_angles[d] for d in sa_hand.dof_names]
    for data in ({"grasp_qpos": np.concatenate([palm, joints]), "obj_pose": obj},
                 {"grasp_pose": palm, "grasp_qpos": np.array(joints), "obj_pose": obj}):  # fmt: skip
        back = record_from_dict(data, sa_hand, "test")
        assert np.max(np.abs(back.T_palm_object - record.T_palm_object)) <= 1e-6
        assert back.pregrasp is None and back.squeeze is None


def test_a_dexgraspbench_file_is_read_in_the_joint_order_it_names(sa_hand, rng, tmp_path):
    record = random_records(sa_hand, rng, 1)[0]
    write_dexgraspbench([record], sa_hand, tmp_path / "g.npy")
    data = np.load(tmp_path / "g.npy", allow_pickle=True).item()
    perm = rng.permutation(sa_hand.n_dof)
    shuffled = {**data, "joint_names": data["joint_names"][perm]}
    for key in ("pregrasp_qpos", "grasp_qpos", "squeeze_qpos"):
        shuffled[key] = np.concatenate([data[key][:7], data[key][7:][perm]])
    assert_same(record_from_dict(shuffled, sa_hand, "g.npy"), record, sa_hand)
    with pytest.raises(InvalidTask, match="are not the joints of hand 'schunk-sa'"):
        record_from_dict({**data, "joint_names": np.array(["a"] * sa_hand.n_dof)}, sa_hand, "g.npy")


def test_dexgraspnet_euler_angles_are_static_xyz(sa_hand, tmp_path):
    """WRJRx, y, z: R = Rz(c) Ry(b) Rx(a) (transforms3d 'sxyz'), the palm in the object frame."""
    a, b, c = 0.3, -0.7, 1.9
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    qpos = {"WRJTx": 0.01, "WRJTy": -0.02, "WRJTz": 0.15, "WRJRx": a, "WRJRy": b, "WRJRz": c}
    qpos.update({d: 0.1 for d in sa_hand.dof_names})
    save_npy(tmp_path / "obj.npy", [{"scale": 0.08, "qpos": qpos, "energy": 1.0}])
    (record,) = read_dexgraspnet(tmp_path / "obj.npy", sa_hand)
    T_object_palm = np.linalg.inv(record.T_palm_object)
    np.testing.assert_allclose(T_object_palm[:3, :3], Rz @ Ry @ Rx, atol=1e-12)
    np.testing.assert_allclose(T_object_palm[:3, 3], [10.0, -20.0, 150.0], atol=1e-9)
    assert record.object_scale_mm == pytest.approx(80.0)


def test_formats_are_told_apart_by_content(sa_hand, rng, tmp_path):
    records = random_records(sa_hand, rng, 2)
    write_dexgraspbench(records[:1], sa_hand, tmp_path / "bench.npy")
    write_dexgraspnet(records, sa_hand, tmp_path / "net.npy")
    write_json_m(records, sa_hand, tmp_path / "m.json")
    assert read_records(tmp_path / "bench.npy", sa_hand)[0] == "dexgraspbench"
    assert read_records(tmp_path / "net.npy", sa_hand)[0] == "dexgraspnet"
    fmt, back = read_records(tmp_path / "m.json", sa_hand)
    assert fmt == "json-m" and len(back) == 2


class _Boom:
    def __reduce__(self):
        return (print, ("the pickle ran",))


def test_a_pickle_naming_anything_but_arrays_is_refused_unrun(tmp_path, capsys):
    path = tmp_path / "evil.npy"
    np.save(path, np.array({"grasp_qpos": _Boom()}, dtype=object), allow_pickle=True)
    with pytest.raises(InvalidTask, match="refused.*builtins.print"):
        load_npy(path)
    assert "the pickle ran" not in capsys.readouterr().out
    path.write_bytes(b"not a numpy file")
    with pytest.raises(InvalidTask, match="not a numpy .npy file"):
        load_npy(path)
    with pytest.raises(InvalidTask, match="not found"):
        load_npy(tmp_path / "missing.npy")


def test_plain_numeric_arrays_load_without_pickle(tmp_path):
    np.save(tmp_path / "a.npy", np.arange(5.0))
    np.testing.assert_array_equal(load_npy(tmp_path / "a.npy"), np.arange(5.0))


def test_bad_records_are_named(sa_hand, rng, tmp_path):
    record = random_records(sa_hand, rng, 1)[0]
    write_dexgraspbench([record], sa_hand, tmp_path / "g.npy")
    data = np.load(tmp_path / "g.npy", allow_pickle=True).item()
    with pytest.raises(InvalidTask, match="no 'grasp_qpos'.*expected grasp_qpos"):
        record_from_dict({k: v for k, v in data.items() if k != "grasp_qpos"}, sa_hand, "g.npy")
    with pytest.raises(InvalidConfiguration, match="23 numbers.*24.*another hand"):
        record_from_dict({**data, "grasp_qpos": data["grasp_qpos"][:-1]}, sa_hand, "g.npy")
    xyzw = data["grasp_qpos"].copy()
    xyzw[3:7] = 2 * xyzw[3:7]
    with pytest.raises(InvalidConfiguration, match="not unit"):
        record_from_dict({**data, "grasp_qpos": xyzw}, sa_hand, "g.npy")
    with pytest.raises(InvalidTask, match="expected a dict"):
        record_from_dict([1, 2], sa_hand, "g.npy")
    in_mm = data["grasp_qpos"].copy()
    in_mm[:3] = in_mm[:3] * 1000.0 + [11.0, 0.0, 0.0]  # millimetres where metres belong
    with pytest.raises(InvalidTask, match="palm stands .* m from the object.*millimetres"):
        record_from_dict({**data, "grasp_qpos": in_mm}, sa_hand, "g.npy")
    save_npy(tmp_path / "net.npy", [{"scale": 0.1, "qpos": {"WRJTx": 0.0, "robot0:FFJ3": 0.1}}])
    with pytest.raises(InvalidTask, match="does not fit hand 'schunk-sa'.*missing.*WRJTy.*robot0:FFJ3"):
        read_dexgraspnet(tmp_path / "net.npy", sa_hand)


def test_json_m_refuses_millimetres_and_another_hands_joints(sa_hand, rng, tmp_path):
    record = random_records(sa_hand, rng, 1)[0]
    write_json_m([record], sa_hand, tmp_path / "m.json")
    data = json.loads((tmp_path / "m.json").read_text())
    mm = json.loads(json.dumps(data))
    mm["grasps"][0]["grasp_qpos"][:3] = [v * 1000.0 + 11.0 for v in mm["grasps"][0]["grasp_qpos"][:3]]
    (tmp_path / "mm.json").write_text(json.dumps(mm))
    with pytest.raises(InvalidTask, match="lengths are metres.*millimetres"):
        read_json_m(tmp_path / "mm.json", sa_hand)
    other = {**data, "joint_order": list(reversed(data["joint_order"]))}
    (tmp_path / "other.json").write_text(json.dumps(other))
    with pytest.raises(InvalidTask, match="written for joints"):
        read_json_m(tmp_path / "other.json", sa_hand)
    (tmp_path / "no.json").write_text(json.dumps({"prehension": "result/1"}))
    with pytest.raises(InvalidTask, match="not a json-m grasp file"):
        read_json_m(tmp_path / "no.json", sa_hand)


@pytest.mark.parametrize("name", ["scalpel-handling", "guitar-holding"])
def test_seeded_built_in_solutions_come_back_solved_through_every_format(name, tmp_path):
    """Solve (local, seeds 0-2), export in every format, read back, judge: the same
    configuration (1e-9 rad, 1e-6 mm), strictly solved, and check re-derives the record."""
    from prehension import SolveOptions, load_builtin_task, quality_entries, solve
    from prehension.interop.imported import imported_result
    from prehension.interop.records import records_from_result
    from prehension.results import result_to_dict
    from prehension.verification import verify_result

    task = load_builtin_task(name)
    solved = 0
    for seed in range(3):
        result = solve(task, SolveOptions(method="local", seed=seed))
        if not result.success:
            continue
        solved += 1
        (record,) = records_from_result(task, result_to_dict(result, quality_entries(result), approach_entries_of(result)), 0)
        for fmt, writer in WRITERS.items():
            out = tmp_path / f"{name}-{seed}{SUFFIX[fmt]}"
            writer([record], task.hand, out)
            (back,) = READERS[fmt](out, task.hand)
            stages = ("joint_angles",) if fmt == "dexgraspnet" else ("joint_angles", "pregrasp", "squeeze")
            assert_same(record, back, task.hand, stages)
            data = imported_result(task, back, format_name=fmt)
            assert data["status"] == "solved", data["message"]
            assert verify_result(data, reprove=False).holds
    assert solved >= 1  # the test is not vacuous


def test_corrupt_values_are_named_never_a_traceback(sa_hand, rng, tmp_path):
    """Every field of each format replaced by junk (a string, None, NaN, a nested dict):
    a PrehensionError naming the file, never another exception."""
    from prehension.errors import PrehensionError

    record = random_records(sa_hand, rng, 1)[0]
    write_dexgraspbench([record], sa_hand, tmp_path / "b.npy")
    write_dexgraspnet([record], sa_hand, tmp_path / "n.npy")
    write_json_m([record], sa_hand, tmp_path / "m.json")
    bench = np.load(tmp_path / "b.npy", allow_pickle=True).item()
    net = np.load(tmp_path / "n.npy", allow_pickle=True)[0]
    m = json.loads((tmp_path / "m.json").read_text())
    junk = ("x", None, float("nan"), {"a": 1}, [1.0, "y"])
    cases = [("b.npy", {**bench, key: j}) for key in ("grasp_qpos", "pregrasp_qpos", "obj_pose", "obj_scale") for j in junk]
    cases += [("n.npy", [{**net, "qpos": {**net["qpos"], "WRJRx": j}}]) for j in junk]
    cases += [("n.npy", [{**net, "scale": j}]) for j in junk]
    for k, (name, value) in enumerate(cases):
        path = tmp_path / f"{k}-{name}"
        save_npy(path, value)
        with pytest.raises(PrehensionError, match=str(k)):
            read_records(path, sa_hand)
    for k, j in enumerate(junk):
        for where in ("grasp", "object", "grasps"):
            bad = json.loads(json.dumps(m))
            if where == "grasp":
                bad["grasps"][0]["grasp_qpos"] = j
            elif where == "object":
                bad["object"] = {"path": "", "scale_m_per_unit": j}
            else:
                bad["grasps"] = j
            path = tmp_path / f"m{k}{where}.json"
            path.write_text(json.dumps(bad, allow_nan=True))
            with pytest.raises(PrehensionError, match=path.name):
                read_records(path, sa_hand)


def test_dexgraspbench_files_are_named_by_solution_number(tmp_path):
    from prehension.interop.dexgraspbench import grasp_files

    assert [p.name for p in grasp_files(tmp_path / "d", 2, 3)] == ["3.npy", "4.npy"]
    assert grasp_files(tmp_path / "one.npy", 1, 5) == [tmp_path / "one.npy"]
    with pytest.raises(InvalidTask, match="2 grasps do not fit one .npy file"):
        grasp_files(tmp_path / "one.npy", 2)
