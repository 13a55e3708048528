"""The whole CuikSuite world language (issue 31, item 4): every construct parses into its
record, what prehension can model imports (and moves as written), the rest is refused
naming the construct, the line and why.  Small snippets written here; nothing of
CuikSuite is copied."""

from __future__ import annotations

import math

import numpy as np
import pytest

from prehension import evaluate, solve
from prehension.cli import EXIT_BAD_INPUT, main
from prehension.errors import WorldFileError
from prehension.hands.kinematics import forward_kinematics
from prehension.solve import SolveOptions
from prehension.tasks.cuik_import import hand_from_world, task_from_world
from prehension.tasks.cuik_parser import evaluate_expression, parse_world, read_world

LINKS = "[LINKS]\nbase: box (0,0,0) (1,2,3)\narm: sphere 2 (4,5,6) cylinder 1 (0,0,0) (0,0,9)\n"


def _hand(text):
    return hand_from_world(parse_world(text, path="h.world"))


def _couplings(hand):
    return [(c.dof, c.source, c.ratio) for c in hand.couplings]


def _poses(hand, q):
    return forward_kinematics(hand, np.atleast_2d(q)).T_palm_link


# --------------------------------------------------------------------------- lexical, expressions


def test_all_three_line_comments_and_block_comments():
    world = parse_world("[CONSTANTS]\n% one\n# two\n// three\na := 1 // four\n/* five\n six */ b := a+1 # six\n")
    assert dict(world.constants) == {"a": 1.0, "b": 2.0}
    assert world.constant_lines["b"] == 7


def test_scoped_names_read_as_cuiksuite_spells_them():
    world = parse_world("[CONSTANTS]\nrobot::len := 3\nx := 2*robot::len\n")
    assert world.constants["robot__len"] == 3.0 and world.constants["x"] == 6.0


@pytest.mark.parametrize("text, value", [
    ("1+2 == 3", 1.0), ("2 != 2", 0.0), ("1 <= 1", 1.0), ("3 >= 4", 0.0), ("1 < 2", 1.0), ("1 > 2", 0.0),
    ("2*3 > 5", 1.0), ("(1 < 2 ? 10 : 20)", 10.0), ("(0 ? 10 : 20) + 1", 21.0), ("(a > 1 ? a : -a)", 0.5),
])
def test_comparisons_and_the_conditional(text, value):
    assert evaluate_expression(text, {"a": -0.5}) == value


def test_parameter_is_refused_with_the_reason():
    with pytest.raises(WorldFileError, match=r"line 2: PARAMETER\(\.\.\.\) reads CuikSuite's solver parameter file"):
        parse_world("[CONSTANTS]\nx := PARAMETER(DELTA)\n")


def test_print_is_accepted_and_needs_a_defined_constant(capsys):
    world = parse_world("[CONSTANTS]\nx := 1\nPRINT x\n")
    assert dict(world.constants) == {"x": 1.0} and capsys.readouterr().out == ""
    with pytest.raises(WorldFileError, match="line 2: undefined constant 'y'"):
        parse_world("[CONSTANTS]\nprint y\n")


# --------------------------------------------------------------------------- links and bodies


@pytest.mark.parametrize("colour, rgb", [
    ("0.75*red", (0.75, 0.0, 0.0)), ("red+blue", (1.0, 0.0, 1.0)), ("0.5*red+0.5*white", (1.0, 0.5, 0.5)),
    ("2*0.5*grey", (0.7, 0.7, 0.7)), ("0.5*color(0.2,0.4,1)", (0.1, 0.2, 0.5)),
])
def test_colour_arithmetic(colour, rgb):
    world = parse_world(f"[LINKS]\nl: {colour} box (0,0,0) (1,1,1) {colour}\n")
    (link,) = world.links
    assert link.color == pytest.approx(rgb) and link.bodies[0].color == pytest.approx(rgb)


def test_every_body_shape():
    world = parse_world(
        "[LINKS]\nl: line (0,0,0) +(1,0,0) red\n"
        "   prism (0,0,0) (1,0,0) (0,1,0) 5 hidden\n"
        "   segments (0,0,0; 1,0,0; 1,1,0) blue\n"
        "   body \"m.off\" green granularity 3 decoration\n"
    )
    line, prism, segments, body = world.links[0].bodies
    assert (line.kind, line.points, line.color) == ("line", ((0, 0, 0), (1, 0, 0)), "red")
    assert (prism.kind, prism.points, prism.radius, prism.status) == (
        "prism", ((0, 0, 0), (1, 0, 0), (0, 1, 0)), 5.0, "hidden")
    assert (segments.kind, segments.points, segments.color) == ("segments", ((0, 0, 0), (1, 0, 0), (1, 1, 0)), "blue")
    assert (body.kind, body.path, body.granularity, body.status) == ("off", "m.off", 3, "decoration")


def test_link_dynamics_and_the_end_effector_separator():
    world = parse_world(
        "[LINKS]\nbase\ntool - box (0,0,0) (1,1,1)\n  mass 2.5\n  inertia matrix 1,0,0,1,0,1\n"
        "  inertial frame Tx(1)*Rz(pi)\narm: cylinder 1 (0,0,0) (0,0,1) mass 1 inertia matrix solid cylinder_z 1, 2\n"
        "leg: sphere 1 (0,0,0) inertia matrix rod_x 3\n"
    )
    base, tool, arm, leg = world.links
    assert not base.end_effector and tool.end_effector and not arm.end_effector
    assert (tool.mass, arm.mass, leg.mass) == (2.5, 1.0, None)


# --------------------------------------------------------------------------- joints


def test_every_joint_kind_parses_with_its_options():
    world = parse_world(LINKS + "c: body \"c.off\"\nd\n[JOINTS]\n"
        "revolute: base (0,0,0)+(0,0,1) arm (0,0,0)+(0,0,1) range [0,1] +(1,0,0) +(1,0,0)\n"
        "          avoid limits 2 velocity 3 torque 4\n"
        "crevolute: arm (0,0,0)+(0,0,1) c (0,0,0)+(0,0,1) range [0,1] +(1,0,0) +(1,0,0)\n"
        "prismatic: base (0,0,0)+(1,0,0) d (0,0,0)+(1,0,0) range [0,5] cost 2 friction 0.1 damping 0.2\n"
        "fix: base c Txyz(1,2,3)\n"
        "sph_sph bar: base (0,0,0) d (1,0,0) length 4 radius 0.1 granularity 5 red mass 1\n"
        "sph_prs_sph leg: base (0,0,0) d (1,0,0) range [1,2] radius 0.1 blue\n"
        "spring s: base (0,0,0) d (1,0,0) range [1,2] radius 0.1 rest 1.5 stiffness 10\n"
        "xyspring t: base (0,0,0) d (1,0,0) range [1,2] radius 0.1\n"
        "c_cable k: base (0,0,0) d (1,0,0) radius 0.1 black rest 1\n"
        "c_spring m: base (0,0,0) d (1,0,0) radius 0.1\nc_leg n: base (0,0,0) d (1,0,0) radius 0.1\n")
    kinds = [j.kind for j in world.joints]
    assert kinds == ["revolute", "crevolute", "prismatic", "fix", "sph_sph", "sph_prs_sph", "spring", "xyspring",
                     "c_cable", "c_spring", "c_leg"]
    rev, _, pri, fix, bar, leg, spring, *_ = world.joints
    assert dict(rev.properties) == {"velocity": 3.0, "effort": 4.0} and rev.avoid_limits_weight == 2.0
    assert pri.ranges == ((0.0, 5.0),) and dict(pri.properties) == {"cost": 2.0, "friction": 0.1, "damping": 0.2}
    assert fix.transform[0][3] == 1.0 and fix.transform[2][3] == 3.0
    assert (bar.name, dict(bar.properties)) == ("bar", {"length": 4.0, "radius": 0.1})
    assert leg.ranges == ((1.0, 2.0),) and dict(spring.properties) == {"radius": 0.1, "rest": 1.5, "stiffness": 10.0}


def test_fix_transforms_compose_left_to_right_and_tr_inverts():
    world = parse_world("[LINKS]\na\nb\nc\n[JOINTS]\nfix: a b Tx(10)*Rz(pi/2)\n"
                        "fix: a c TR(0,-1,0,10; 1,0,0,0; 0,0,1,0)^-1\n")
    t1, t2 = (np.array(j.transform) for j in world.joints)
    expected = np.array([[0, -1, 0, 10], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)
    assert t1 == pytest.approx(expected) and t2 == pytest.approx(np.linalg.inv(expected))


def test_body_vertex_references(tmp_path):
    (tmp_path / "tri.off").write_text("OFF\n3 1 0\n0 0 0\n7 8 9\n1 0 0\n3 0 1 2\n")
    (tmp_path / "v.world").write_text(
        "[LINKS]\nbase: box (0,0,0) (1,2,3) sphere 1 (4,5,6)\narm: body \"tri.off\"\n[JOINTS]\n"
        "revolute: base 6 +(0,0,1) arm 1 +(0,0,1)\nspherical: base 1:0 arm 0\n"
    )
    rev, sph = read_world(tmp_path / "v.world").joints
    assert rev.point1 == (1.0, 2.0, 3.0) and rev.point2 == (7.0, 8.0, 9.0)  # box corner 6: (hi, hi, hi)
    assert sph.point1 == (4.0, 5.0, 6.0) and sph.point2 == (0.0, 0.0, 0.0)


def test_body_vertex_reference_out_of_range_names_the_line():
    with pytest.raises(WorldFileError, match="line 6: body 0 of 'base' has 8 defining points; there is no point 8"):
        parse_world(LINKS + "[JOINTS]\n\nrevolute: base 8 +(0,0,1) arm 0 +(0,0,1)\n")


# --------------------------------------------------------------------------- sections


def test_obstacles_collisions_and_equations():
    world = parse_world(LINKS + "[OBSTACLES]\nwall: box (0,0,0) (1,1,1) 0.5*grey\nball: sphere 1 (0,0,0)\n"
                        "[COLLISIONS]\ncheck: all\ndo not check: connected\ncheck: arm, wall\n"
                        "do not check: base\n[EQUATIONS]\neqfile: \"extra.cuik\"\n")
    assert [o.name for o in world.obstacles] == ["wall", "ball"]
    assert world.obstacles[0].bodies[0].color == pytest.approx((0.35, 0.35, 0.35))
    assert [(c.check, c.what) for c in world.collisions] == [
        (True, ("all",)), (False, ("connected",)), (True, ("arm", "wall")), (False, ("base",))]
    assert world.equations == (("extra.cuik", 13),)


def test_include_prefixes_the_names_and_an_error_names_the_included_file(tmp_path):
    (tmp_path / "arm.world").write_text("[CONSTANTS]\nL := 5\n[LINKS]\nup\nfore\n[JOINTS]\n"
                                        "revolute: up (0,0,L)+(0,1,0) fore (0,0,0)+(0,1,0)\n")
    (tmp_path / "main.world").write_text("[LINKS]\nground\n[INCLUDE]\nright: \"arm.world\"\n"
                                         "[JOINTS]\nrevolute: ground (0,0,0)+(0,0,1) right__up (0,0,0)+(0,0,1)\n")
    world = read_world(tmp_path / "main.world")
    assert [link.name for link in world.links] == ["ground", "right__up", "right__fore"]
    assert world.constants["right__L"] == 5.0 and world.joints[0].point1 == (0.0, 0.0, 5.0)
    hand = import_hand(tmp_path / "main.world")
    assert hand.n_dof == 2
    (tmp_path / "arm.world").write_text("[LINKS]\nup\n[JOINTS]\nrevolute: up (0,0,)+(0,1,0)\n")
    with pytest.raises(WorldFileError, match=r"arm.world:4: expected a number"):
        read_world(tmp_path / "main.world")


def import_hand(path):
    return hand_from_world(read_world(path))


# --------------------------------------------------------------------------- import: folding, turning, coupling

_FOLDED = ("[LINKS]\npalm\nmount\nfinger\n[JOINTS]\nfix: palm mount Tx(10)*Rz(pi/2)\n"
           "revolute: mount (1,2,3)+(0,0,1) finger (0,0,0)+(0,0,1) range [-1,1] +(1,0,0) +(1,0,0)\n")
_UNFOLDED = ("[LINKS]\npalm\nfinger\n[JOINTS]\n"
             "revolute: palm (8,1,3)+(0,0,1) finger (0,0,0)+(0,0,1) range [-1,1] +(0,1,0) +(1,0,0)\n")


def test_a_fix_joint_folds_its_link_into_the_parent_and_moves_the_same():
    folded, unfolded = _hand(_FOLDED), _hand(_UNFOLDED)
    assert [link.name for link in folded.links] == ["palm", "finger"]
    q = np.random.default_rng(7).uniform(-1, 1, size=(16, 1))
    assert _poses(folded, q) == pytest.approx(_poses(unfolded, q), abs=1e-9)
    assert _poses(folded, [0.0])[0, 1, :3, 3] == pytest.approx([8.0, 1.0, 3.0])


def test_a_fix_joint_onto_the_ground_link_folds_the_other_way():
    text = _FOLDED.replace("fix: palm mount Tx(10)*Rz(pi/2)", "fix: mount palm (Tx(10)*Rz(pi/2))^-1")
    text = text.replace("(Tx(10)*Rz(pi/2))^-1", "Rz(-pi/2)*Tx(-10)")
    q = np.random.default_rng(8).uniform(-1, 1, size=(8, 1))
    assert _poses(_hand(text), q) == pytest.approx(_poses(_hand(_UNFOLDED), q), abs=1e-9)


_FORWARD = ("[LINKS]\npalm\na\nb\n[JOINTS]\n"
            "revolute: palm (0,0,10)+(0,1,0) a (0,0,0)+(0,1,0) range [0,1] +(0,0,1) +(1,0,0)\n"
            "revolute: a (30,0,0)+(0,1,0) b (0,2,0)+(0,1,0) range [-0.5,1.2] +(1,0,0) +(0,0,1)\n")


def test_a_revolute_joint_written_backwards_is_turned_round_with_its_range():
    backwards = _FORWARD.replace("revolute: a (30,0,0)+(0,1,0) b (0,2,0)+(0,1,0) range [-0.5,1.2] +(1,0,0) +(0,0,1)",
                                 "revolute: b (0,2,0)+(0,1,0) a (30,0,0)+(0,1,0) range [-1.2,0.5] +(0,0,1) +(1,0,0)")
    forward, turned = _hand(_FORWARD), _hand(backwards)
    assert turned.joints[1].parent == "a" and turned.joints[1].child == "b"
    assert (turned.joints[1].lower, turned.joints[1].upper) == ((-0.5,), (1.2,))
    q = np.random.default_rng(9).uniform([0, -0.5], [1, 1.2], size=(16, 2))
    assert _poses(turned, q) == pytest.approx(_poses(forward, q), abs=1e-9)


def test_crevolute_couples_to_the_previous_revolute_joint():
    text = _FORWARD.replace("revolute: a (30", "crevolute: a (30")
    hand = _hand(text)
    assert _couplings(hand) == [("b", "a", 1.0)]
    turned = _hand(text.replace("crevolute: a (30,0,0)+(0,1,0) b (0,2,0)+(0,1,0) range [-0.5,1.2] +(1,0,0) +(0,0,1)",
                                "crevolute: b (0,2,0)+(0,1,0) a (30,0,0)+(0,1,0) range [-1.2,0.5] +(0,0,1) +(1,0,0)"))
    assert _couplings(turned) == [("b", "a", -1.0)]


def test_a_link_no_joint_names_is_left_out_of_a_hand_and_said_so():
    hand = _hand(_FORWARD.replace("b\n[JOINTS]", "b\ncan - body \"can.off\" red\n[JOINTS]"))
    assert [link.name for link in hand.links] == ["palm", "a", "b"]
    assert "left out: link(s) can" in hand.notes[-1]


def test_a_range_of_a_whole_turn_or_more_is_unlimited():
    hand = _hand(_FORWARD.replace("range [0,1]", "range [-2*pi,2*pi]"))
    assert (hand.joints[0].lower, hand.joints[0].upper) == ((-math.pi,), (math.pi,))


def test_a_task_with_fix_and_crevolute_joints_imports_and_solves():
    text = ("[CONSTANTS]\nr := 10\n[LINKS]\npalm: 0.8*white\nmount\nf1\nf2\nX_1\nobj: red\n[JOINTS]\n"
            "fix: palm mount Tz(100)*Rz(pi/2)\n"
            "revolute: mount (0,0,0)+(0,1,0) f1 (0,0,0)+(0,1,0) range [0,pi/2] +(0,0,1) +(1,0,0)\n"
            "crevolute: f1 (50,0,0)+(0,1,0) f2 (0,0,0)+(0,1,0) range [0,pi/2] +(1,0,0) +(1,0,0)\n"
            "SPHERICAL: f2 (30,0,0) X_1 (0,0,-r) range [pi/3] +(0,0,1) +(0,0,1)\n"
            "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n"
            "[COLLISIONS]\ndo not check: all\n")
    task = task_from_world(parse_world(text, path="t.world"))
    assert _couplings(task.hand) == [("f2", "f1", 1.0)]
    assert "[COLLISIONS] statements are not read" in task.description
    result = solve(task, SolveOptions(time_limit_s=60))
    assert result.status == "solved"
    assert evaluate(task, result.solutions[0].configuration()).ok


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize("joint, line, message", [
    ("prismatic: palm (0,0,0)+(1,0,0) a (0,0,0)+(1,0,0) range [0,1]", 10, "prismatic joint between 'palm' and 'a': "
     "prehension's hands have revolute and universal joints only"),
    ("sph_sph bar: palm (0,0,0) b (1,0,0) length 2 radius 1", 10, "sph_sph joint 'bar' between 'palm' and 'b': a "
     "bar/leg/spring/cable between two bodies closes a kinematic loop"),
    ("revolute: b (0,0,0)+(0,1,0) palm (0,0,0)+(0,1,0)", 10, "revolute joint to 'b' closes a kinematic loop: 'b' is "
     "already placed \\(the joint at line 9"),
    ("spherical: a (0,0,0) b (0,0,0)", 10, "spherical joint between 'a' and 'b' that is no fingertip contact"),
    ("universal: b (0,0,0)+(1,0,0) c (0,0,0)+(0,1,0)\nuniversal: a (0,0,0)+(1,0,0) c (0,0,0)+(0,1,0)", 11,
     "universal joint to 'c' closes a kinematic loop: 'c' is already placed \\(the joint at line 10"),
])
def test_what_prehension_cannot_model_is_refused_naming_line_and_reason(joint, line, message):
    text = _FORWARD.replace("[LINKS]\npalm\na\nb\n", "[LINKS]\npalm\na\nb\nc\nd\n") + joint + "\n"
    with pytest.raises(WorldFileError, match=f"h.world:{line}: {message}"):
        _hand(text)


def test_equations_and_avoided_obstacles_are_refused():
    with pytest.raises(WorldFileError, match=r"h.world:9: \[EQUATIONS\] adds the equations of 'x.cuik'"):
        _hand(_FORWARD + "[EQUATIONS]\neqfile: \"x.cuik\"\n")
    task = ("[LINKS]\npalm\nf1\nX_1\nobj\n[JOINTS]\nrevolute: palm (0,0,0)+(0,1,0) f1 (0,0,0)+(0,1,0)\n"
            "SPHERICAL: f1 (50,0,0) X_1 (0,0,-1) range [pi/3] +(0,0,1) +(0,0,1)\n"
            "in_patch: X_1 (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n"
            "[OBSTACLES]\nwall: box (0,0,0) (1,1,1)\n")
    assert "1 obstacle(s) display only" in task_from_world(parse_world(task, path="t.world")).description
    with pytest.raises(WorldFileError, match="t.world:11: obstacle 'wall' must be avoided"):
        task_from_world(parse_world(task + "[COLLISIONS]\ncheck: all\n", path="t.world"))


def test_a_universal_joint_written_backwards_is_refused():
    text = _FORWARD.replace("revolute: a (30", "universal: b (0,2,0)+(0,1,0) a (30,0,0)+(1,0,0)\n% ")
    with pytest.raises(WorldFileError, match="h.world:7: universal joint written from 'b' .* to 'a'"):
        _hand(text)


def test_a_task_file_is_not_a_hand_and_a_hand_file_is_not_a_task():
    with pytest.raises(WorldFileError, match="the file states no contact"):
        task_from_world(parse_world(_FORWARD, path="h.world"))
    task = _FORWARD + ("[LINKS]\nX\nobj\n[JOINTS]\nSPHERICAL: b (5,0,0) X (0,0,-1) range [1] +(0,0,1) +(0,0,1)\n"
                       "in_patch: X (0,0,0) (0,0,1) obj (0,0,0) (0,10,0) (10,0,0) (10,10,0)\n")
    with pytest.raises(WorldFileError, match="states contacts \\(in_patch\\): it is a grasp task"):
        _hand(task)


# --------------------------------------------------------------------------- seeded random draws


def _elementary(kind, values):
    """The test's own 4x4 of one CuikSuite transform (independent of the parser's)."""
    t = np.eye(4)
    if kind.startswith("T"):
        t[:3, 3] = values if kind == "Txyz" else np.eye(3)["xyz".index(kind[1])] * values[0]
    else:
        c, s = math.cos(values[0]), math.sin(values[0])
        i, j = {"Rx": (1, 2), "Ry": (2, 0), "Rz": (0, 1)}[kind]
        t[i, i], t[i, j], t[j, i], t[j, j] = c, -s, s, c
    return t


def _vec(v):
    return "(" + ",".join(repr(float(x)) for x in v) + ")"


def _unit_and_perpendicular(rng):
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    a = np.cross(d, rng.normal(size=3))
    return d, a / np.linalg.norm(a)


@pytest.mark.parametrize("seed", range(8))
def test_random_fix_chains_fold_into_the_same_motion(seed):
    """A random chain of transforms on a fix joint, then a random revolute joint: the folded
    hand moves as the hand written with the joint already in the palm frame."""
    rng = np.random.default_rng(seed)
    kinds = rng.choice(["Tx", "Ty", "Tz", "Txyz", "Rx", "Ry", "Rz"], size=rng.integers(1, 5))
    text, T = [], np.eye(4)
    for kind in kinds:
        values = rng.uniform(-50, 50, size=3) if kind == "Txyz" else rng.uniform(-3, 3, size=1)
        text.append(f"{kind}({','.join(repr(float(v)) for v in values)})")
        T = T @ _elementary(kind, values)
    p, q = rng.uniform(-30, 30, size=(2, 3))
    (d, a), (e, b) = _unit_and_perpendicular(rng), _unit_and_perpendicular(rng)
    R, t = T[:3, :3], T[:3, 3]
    joint = "revolute: {} {}+{} finger {}+{} range [-1,1] +{} +{}\n"
    folded = _hand("[LINKS]\npalm\nmount\nfinger\n[JOINTS]\nfix: palm mount " + "*".join(text) + "\n"
                   + joint.format("mount", _vec(p), _vec(d), _vec(q), _vec(e), _vec(a), _vec(b)))
    direct = _hand("[LINKS]\npalm\nfinger\n[JOINTS]\n"
                   + joint.format("palm", _vec(R @ p + t), _vec(R @ d), _vec(q), _vec(e), _vec(R @ a), _vec(b)))
    angles = rng.uniform(-1, 1, size=(16, 1))
    assert _poses(folded, angles) == pytest.approx(_poses(direct, angles), abs=1e-8)


@pytest.mark.parametrize("seed", range(8))
def test_random_backwards_revolute_joints_move_as_written_forwards(seed):
    rng = np.random.default_rng(100 + seed)
    p1, q1, p2, q2 = rng.uniform(-30, 30, size=(4, 3))
    (d1, a1), (e1, b1), (d2, a2), (e2, b2) = (_unit_and_perpendicular(rng) for _ in range(4))
    lo, hi = (float(x) for x in np.sort(rng.uniform(-3, 3, size=2)))
    first = f"revolute: palm {_vec(p1)}+{_vec(d1)} a {_vec(q1)}+{_vec(e1)} range [-1,1] +{_vec(a1)} +{_vec(b1)}\n"
    forward = f"revolute: a {_vec(p2)}+{_vec(d2)} b {_vec(q2)}+{_vec(e2)} range [{lo!r},{hi!r}] +{_vec(a2)} +{_vec(b2)}\n"
    backward = f"revolute: b {_vec(q2)}+{_vec(e2)} a {_vec(p2)}+{_vec(d2)} range [{-hi!r},{-lo!r}] +{_vec(b2)} +{_vec(a2)}\n"
    head = "[LINKS]\npalm\na\nb\n[JOINTS]\n"
    one, other = _hand(head + first + forward), _hand(head + first + backward)
    assert other.joints[1].lower + other.joints[1].upper == pytest.approx((lo, hi))
    angles = np.column_stack([rng.uniform(-1, 1, 16), rng.uniform(lo, hi, 16)])
    assert _poses(other, angles) == pytest.approx(_poses(one, angles), abs=1e-8)


# --------------------------------------------------------------------------- the command line


@pytest.mark.parametrize("command", ["import-cuik", "solve"])
@pytest.mark.parametrize("statement, message", [
    ("revolute: b (0,0,0)+(0,1,0) palm (0,0,0)+(0,1,0)", "revolute joint to 'b' closes a kinematic loop"),
    ("prismatic: palm (0,0,0)+(1,0,0) b (0,0,0)+(1,0,0) range [0,1]", "prismatic joint between 'palm' and 'b'"),
    ("", "the file states no contact"),
])
def test_the_command_line_names_the_refusal_without_a_traceback(tmp_path, capsys, command, statement, message):
    world = tmp_path / "w.world"
    world.write_text(_FORWARD + statement + "\n")
    argv = [command, str(world)] + (["-o", str(tmp_path / "t.yaml")] if command == "import-cuik" else [])
    assert main(argv) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert message in err and "w.world" in err and "Traceback" not in err
    assert not (tmp_path / "t.yaml").exists()
