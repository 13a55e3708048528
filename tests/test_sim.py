"""The physics test: the MuJoCo scene matches the model, a four-finger box grasp holds, a
grasp with every contact on one face drops, and the runs are deterministic."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from prehension.cli import EXIT_BAD_INPUT, EXIT_OK, main
from prehension.cli.simulate import EXIT_DROPPED
from prehension.errors import PrehensionError
from prehension.hands.kinematics import forward_kinematics
from prehension.objects.model import GraspObject
from prehension.quality import mass_properties, object_solid
from prehension.results import SolveResult, write_result
from prehension.quality import quality_entries
from prehension.pregrasp import approach_entries_of
from prehension.sim import SimOptions, convex_pieces, require_mujoco, scene_for, simulate_grasp, squeeze_targets

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "quality" / "box_grasps.py"
_spec = importlib.util.spec_from_file_location("box_grasps", EXAMPLE)
box_grasps = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(box_grasps)


@pytest.fixture(scope="module")
def four():
    return box_grasps.four_finger_grasp()


@pytest.fixture(scope="module")
def one_face():
    return box_grasps.one_face_grasp()


def _model(task, grasp, **kw):
    scene = scene_for(task, grasp, SimOptions(**kw))
    model = mujoco.MjModel.from_xml_string(scene.xml)
    data = mujoco.MjData(model)
    adr = [model.joint(f"dof:{d}").qposadr[0] for d in scene.dof_names]
    data.qpos[adr] = grasp.q
    mujoco.mj_forward(model, data)
    return model, data


# -- the scene ------------------------------------------------------------------------------
def test_the_scene_places_every_link_and_the_object_as_the_model_does(four):
    task, grasp = four
    model, data = _model(task, grasp)
    for name, T in grasp.link_poses.items():
        body = model.body(f"link:{name}").id
        assert np.allclose(data.xpos[body] * 1000, T[:3, 3], atol=1e-8)
        assert np.allclose(data.xmat[body].reshape(3, 3), T[:3, :3], atol=1e-10)
    obj = model.body("object").id
    assert np.allclose(data.xpos[obj] * 1000, grasp.T_palm_object[:3, 3], atol=1e-8)
    assert np.allclose(data.xmat[obj].reshape(3, 3), grasp.T_palm_object[:3, :3], atol=1e-10)
    props = mass_properties(object_solid(task.object))
    assert model.body_mass[obj] == pytest.approx(0.1)
    centre = grasp.T_palm_object[:3, :3] @ props.centroid_mm + grasp.T_palm_object[:3, 3]
    assert np.allclose(data.xipos[obj] * 1000, centre, atol=1e-8)
    box_inertia = 0.1 / 12 * np.array([100**2 + 100**2, 50**2 + 100**2, 50**2 + 100**2]) * 1e-6  # kg m^2
    assert np.allclose(np.sort(model.body_inertia[obj]), np.sort(box_inertia), rtol=1e-6)


def test_universal_joints_turn_in_the_models_order(sa_hand, rng):
    """Random angles of every dof (both angles of the universal joints) give the model's link poses."""
    task, grasp = box_grasps.four_finger_grasp()
    scene = scene_for(task, grasp)
    model = mujoco.MjModel.from_xml_string(scene.xml)
    data = mujoco.MjData(model)
    adr = [model.joint(f"dof:{d}").qposadr[0] for d in scene.dof_names]
    q = rng.uniform(sa_hand.lower, sa_hand.upper, size=(5, sa_hand.n_dof))
    for qi in q:
        data.qpos[adr] = qi
        mujoco.mj_kinematics(model, data)
        T = forward_kinematics(sa_hand, qi).T_palm_link[0]
        for k, name in enumerate(sa_hand.link_names):
            body = model.body(f"link:{name}").id
            assert np.allclose(data.xpos[body] * 1000, T[k, :3, 3], atol=1e-8)


def test_the_grasp_touches_without_penetrating(four):
    task, grasp = four
    model, data = _model(task, grasp)
    dists = [data.contact[i].dist for i in range(data.ncon)]
    assert max(0.0, -min(dists, default=0.0)) < 1e-6  # metres: the box grasp starts touching, not inside


def test_the_squeeze_moves_each_contact_into_the_object(four):
    task, grasp = four
    q1 = squeeze_targets(task, grasp.q, grasp.contacts, 0.2)
    for c in task.hand.couplings:
        assert q1[task.hand.dof_index(c.dof)] == pytest.approx(q1[task.hand.dof_index(c.source)])
    pose = forward_kinematics(task.hand, q1)
    for contact, state in zip(task.contacts, grasp.contacts):
        region = task.hand.region(contact.hand_region)
        start = state.hand_params[None]
        p_link, _ = region.region.evaluate(start)
        moved = pose.points(task.hand.link_index(region.link), p_link[0])[0] - state.hand_point
        assert moved @ -state.object_normal == pytest.approx(0.2, rel=0.01)


# -- the protocol ---------------------------------------------------------------------------
def test_a_four_finger_grasp_of_a_box_holds(four):
    task, grasp = four
    report = simulate_grasp(task, grasp)
    assert report.success and not report.rejected and report.held == 6
    for p in report.pushes:
        assert p.shift_mm < 50.0 and p.turn_deg < 15.0 and p.initial_penetration_mm < 1e-3
    assert [p.direction for p in report.pushes] == ["-x", "+x", "-y", "+y", "-z", "+z"]


def test_a_grasp_with_every_contact_on_one_face_drops(one_face):
    task, grasp = one_face
    report = simulate_grasp(task, grasp)
    assert not report.success and not report.rejected
    assert report.held == 0 and min(p.shift_mm for p in report.pushes) > 50.0


def test_the_physics_test_is_deterministic_for_a_seed(four):
    task, grasp = four
    a, b = simulate_grasp(task, grasp), simulate_grasp(task, grasp)
    assert a.to_dict() == b.to_dict()
    jittered = SimOptions(jitter_mm=2.0, jitter_deg=2.0)
    c1, c2 = simulate_grasp(task, grasp, jittered, seed=5), simulate_grasp(task, grasp, jittered, seed=5)
    other = simulate_grasp(task, grasp, jittered, seed=6)
    assert c1.to_dict() == c2.to_dict()
    assert [p.shift_mm for p in other.pushes] != [p.shift_mm for p in c1.pushes]


def test_a_grasp_that_starts_deep_inside_the_object_is_rejected(four):
    task, grasp = four
    T = grasp.T_palm_object.copy()
    T[:3, 3] += 15.0 * grasp.contacts[0].object_normal  # towards the fingers: they sink 15 mm into the box
    report = simulate_grasp(task, SimpleNamespace(q=grasp.q, T_palm_object=T, contacts=grasp.contacts))
    assert report.rejected and not report.success and report.pushes == ()
    assert report.initial_penetration_mm == pytest.approx(15.0, abs=1.0)
    assert "rejected" in report.describe()


def test_a_concave_mesh_is_decomposed_into_convex_pieces(tmp_path):
    """An L of two 10 mm cubes (joined along an edge of faces): CoACD cuts it into convex pieces."""
    v = np.array([(x, y, z) for x in (0, 20) for y in (0, 10) for z in (0, 10)] +
                 [(x, y, z) for x in (0, 10) for y in (0, 10) for z in (10, 20)], float)  # fmt: skip
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [q for q in quads] + [tuple(i + 8 for i in q) for q in quads]
    lines = ["OFF", f"16 {len(faces)} 0"] + [" ".join(map(str, p)) for p in v] + [f"4 {a} {b} {c} {d}" for a, b, c, d in faces]
    (tmp_path / "l.off").write_text("\n".join(lines))
    obj = GraspObject("L", {}, (), str(tmp_path / "l.off"))
    pieces = convex_pieces(obj)
    assert len(pieces) >= 2
    from prehension.quality.solid import Solid

    volume = mass_properties(Solid(pieces, (True,) * len(pieces), "pieces")).volume_mm3
    assert volume == pytest.approx(3000.0, rel=0.15)


@pytest.mark.parametrize("kwargs, message", [
    ({"mass_kg": 0}, "mass_kg must be a positive number"),
    ({"friction": -1}, "friction must be a number >= 0"),
    ({"timestep_s": 0.1}, "timestep_s must be at most 0.05 s"),
    ({"jitter_mm": float("nan")}, "jitter_mm must be a number >= 0"),
])  # fmt: skip
def test_bad_simulation_options_are_refused_by_name(kwargs, message):
    with pytest.raises(PrehensionError, match=message):
        SimOptions(**kwargs)


def test_without_mujoco_the_message_says_what_to_install(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(PrehensionError, match=r'pip install "prehension\[sim\]"'):
        require_mujoco()
    assert main(["simulate", str(tmp_path / "missing.json")]) == EXIT_BAD_INPUT
    assert 'pip install "prehension[sim]"' in capsys.readouterr().err


# -- the command ----------------------------------------------------------------------------
def _result_file(tmp_path, task, grasp, name):
    path = tmp_path / f"{name}.json"
    result = SolveResult(task, "local", "solved", "test", (grasp,))
    write_result(result, path, quality_entries(result), approach_entries_of(result))
    return path


def test_simulate_on_the_command_line(tmp_path, capsys, four, one_face):
    holds = _result_file(tmp_path, *four, "holds")
    assert main(["simulate", str(holds)]) == EXIT_OK
    assert "holds: held against 6 of 6 pushes" in capsys.readouterr().out
    drops = _result_file(tmp_path, *one_face, "drops")
    out = tmp_path / "physics.json"
    assert main(["simulate", str(drops), "-o", str(out), "--json"]) == EXIT_DROPPED
    data = json.loads(out.read_text())
    assert data["prehension"] == "physics/1" and data["grasps"][0]["success"] is False
    assert len(data["grasps"][0]["pushes"]) == 6 and json.loads(capsys.readouterr().out) == data


def test_every_squeeze_kind_on_the_command_line(tmp_path, capsys, four):
    """``--squeeze-kind``: push (the default), forces, balanced, uniform; each report says which."""
    holds = _result_file(tmp_path, *four, "holds")
    for kind in (None, "push", "forces", "balanced", "uniform"):
        out = tmp_path / f"physics-{kind}.json"
        args = ["simulate", str(holds), "-o", str(out)] + ([] if kind is None else ["--squeeze-kind", kind])
        assert main(args) in (EXIT_OK, EXIT_DROPPED)
        assert json.loads(out.read_text())["grasps"][0]["options"]["squeeze"] == (kind or "push")
    capsys.readouterr()
    with pytest.raises(SystemExit):  # argparse names the valid kinds
        main(["simulate", str(holds), "--squeeze-kind", "hard"])
    assert "choose from 'push', 'forces', 'balanced', 'uniform'" in capsys.readouterr().err


def test_simulate_refuses_what_it_cannot_trust(tmp_path, capsys, four):
    path = _result_file(tmp_path, *four, "r")
    assert main(["simulate", str(path), "--solution", "3"]) == EXIT_BAD_INPUT
    assert "--solution 3 is out of range" in capsys.readouterr().err
    data = json.loads(path.read_text())
    data["solutions"][0]["joint_angles_rad"]["index_pip"] += 0.1
    path.write_text(json.dumps(data))
    assert main(["simulate", str(path)]) == EXIT_BAD_INPUT
    assert "does not hold" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path / "r.json"), "--mass", "-1"]) == EXIT_BAD_INPUT
    assert "--mass must be a positive number" in capsys.readouterr().err


def test_every_kind_of_hand_region_becomes_a_solid(tmp_path):
    """A cap is its sphere, a point a 1 mm ball behind it, a patch the hull of itself and its
    copy 2 mm inside the link; the object of primitives is its convex pieces."""
    from prehension.geometry.bezier import BezierPatch
    from prehension.geometry.regions import BezierRegion, PointRegion
    from prehension.hands.model import HandRegion
    from prehension.objects.meshes import Box
    from prehension.tasks.model import Contact, Task
    from tiny_tasks import pincer_hand

    flat = BezierRegion(BezierPatch(np.array([[[0, -5, 60], [0, 5, 60]], [[0, -5, 70], [0, 5, 70]]], float)))
    hand = pincer_hand().with_regions({"patch": HandRegion("palm", flat)})
    obj = GraspObject("block", {"A": PointRegion((0, 0, 0), (-1, 0, 0)), "B": PointRegion((40, 0, 0), (-1, 0, 0)),
                                "C": PointRegion((0, 10, 0), (-1, 0, 0))}, (Box((20, 0, 0), (40, 30, 30)),))  # fmt: skip
    task = Task("kinds", hand, obj, (Contact("pad", "A"), Contact("tip", "B"), Contact("patch", "C")), ("f",))
    grasp = SimpleNamespace(q=np.zeros(2), T_palm_object=np.eye(4), contacts=())
    model = mujoco.MjModel.from_xml_string(scene_for(task, grasp).xml)
    palm, dist = model.body("link:palm").id, model.body("link:dist").id
    kinds = {(int(model.geom_bodyid[g]), int(model.geom_type[g])) for g in range(model.ngeom)}
    sphere, mesh = int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_MESH)
    assert {(palm, sphere), (palm, mesh), (dist, sphere)} <= kinds
    pad = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == palm and model.geom_type[g] == sphere)
    assert np.allclose(model.geom_pos[pad] * 1000, (9, 0, 100)) and model.geom_size[pad][0] == pytest.approx(1e-3)
    tip = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == dist and model.geom_type[g] == sphere)
    assert np.allclose(model.geom_pos[tip] * 1000, (0, 0, 30)) and model.geom_size[tip][0] == pytest.approx(8e-3)
    assert sum(model.geom_bodyid[g] == model.body("object").id for g in range(model.ngeom)) == 1  # one box


@pytest.mark.parametrize("how", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_simulate_interrupted_writes_the_grasps_it_finished(tmp_path, capsys, monkeypatch, four, how, default_signals):
    """The signal arrives while the second of three grasps runs: the first is written,
    atomically, marked interrupted; exit 4; the previous signal handlers come back."""
    import os
    import signal

    import prehension.sim
    from prehension.sim import PhysicsReport

    task, grasp = four
    path = tmp_path / "three.json"
    result = SolveResult(task, "local", "solved", "test", (grasp, grasp, grasp))
    write_result(result, path, quality_entries(result), approach_entries_of(result))
    calls = []

    def fake(task, solution, options, seed):
        calls.append(1)
        if len(calls) == 2:
            os.kill(os.getpid(), getattr(signal, how))
        return PhysicsReport(True, False, 0.0, (), seed, options, 0.0, 0.0, 1)

    monkeypatch.setattr(prehension.sim, "simulate_grasp", fake)
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGHUP)
    out = tmp_path / "physics.json"
    assert main(["simulate", str(path), "-o", str(out)]) == 4
    data = json.loads(out.read_text())
    assert data["interrupted"] is True and [g["solution"] for g in data["grasps"]] == [0]
    assert "interrupted after 1 of 3 grasp(s)" in capsys.readouterr().err
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGHUP)) == before
    assert not [p for p in tmp_path.iterdir() if p.name not in ("three.json", "physics.json")]  # no temporary left


def test_a_start_with_many_contacts_fits_mujocos_arena():
    """teapot-service's first answer: the start probe (3 mm margin) meets 325 contacts, whose
    1300 constraint rows overflowed MuJoCo's default arena (a FatalError, a traceback);
    the scene's arena (ARENA_MB) holds them, and the test runs to its verdict."""
    from prehension.solve import SolveOptions, solve
    from prehension.tasks.library import load_builtin_task

    task = load_builtin_task("teapot-service")
    solution = solve(task, SolveOptions(method="local", seed=0)).solutions[0]
    report = simulate_grasp(task, solution)
    assert len(report.pushes) == 6 or report.rejected
    assert 'memory="256M"' in scene_for(task, solution, SimOptions()).xml


def test_an_error_inside_mujoco_is_a_clear_error_not_a_traceback(four, monkeypatch):
    import prehension.sim.run as run

    def overflow(*args, **kwargs):
        raise mujoco.FatalError("mj_stackAlloc: out of memory\nmore")

    task, grasp = four
    monkeypatch.setattr(run, "_simulated", overflow)
    with pytest.raises(PrehensionError, match="stopped inside MuJoCo: mj_stackAlloc: out of memory$"):
        simulate_grasp(task, grasp)


def test_a_sliver_piece_of_the_object_is_simulated_and_a_scene_mujoco_refuses_is_a_clear_error(four):
    """A convex piece whose volume MuJoCo finds too small (CoACD can leave one) is accepted:
    the object's inertia is stated, the pieces' meshes are shells; a scene MuJoCo's compiler
    refuses all the same is a PrehensionError naming MuJoCo's reason."""
    from prehension.objects.meshes import Mesh
    from prehension.sim.start import posed

    task, grasp = four
    scene = scene_for(task, grasp, SimOptions())
    sliver = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1e-9]], float), np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]))
    from prehension.sim.scene import build_scene_xml

    xml = build_scene_xml(task, grasp.T_palm_object, tuple(scene.object_pieces) + (sliver,), SimOptions()).xml
    model, _ = posed(mujoco, xml, scene.dof_names, grasp.q)
    assert model.ngeom > 0
    with pytest.raises(PrehensionError, match="MuJoCo cannot build the physics test's scene: Error: mesh volume is too small"):
        posed(mujoco, xml.replace(' inertia="shell"', ""), scene.dof_names, grasp.q)
