"""Tests of the CuikSuite ``.world`` parser (syntax and constant evaluation only).

The six IJRR world files are GPL test data: they are read from ``../shared/cuik-ijrr``
at test time and never copied here.  Bad-input tests use small synthetic snippets.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from pathlib import Path

import pytest

from prehension.errors import PrehensionError, WorldFileError
from prehension.tasks.cuik_parser import (
    JOINT_KINDS,
    WorldBody,
    WorldFile,
    evaluate_expression,
    parse_world,
    read_world,
)

SHARED = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr"

# folder -> (world file name, number of links, joint-kind counts, spherical contacts' link1)
FILES = {
    "scalpel/2_contacts_index_thumb": (
        "SAHandplusScalpel.world", 17, {"revolute": 9, "universal": 4, "spherical": 2,
                                        "in_patch": 2},
        ("p34", "p44"),
    ),
    "scalpel/3_contacts_middle_thumb_palm": (
        "SAHandplusScalpel.world", 18, {"revolute": 9, "universal": 4, "spherical": 3,
                                        "in_patch": 3},
        ("p24", "p44", "palm"),
    ),
    "scalpel/4_contacts_middle_index_thumb_palm": (
        "SAHandplusScalpel.world", 19, {"revolute": 9, "universal": 4, "spherical": 4,
                                        "in_patch": 4},
        ("p24", "p34", "p44", "palm"),
    ),
    "teapot/2_contacts_index_thumb": (
        "SAHandplusTeapot.world", 17, {"revolute": 9, "universal": 4, "spherical": 2,
                                       "in_patch": 2},
        ("p34", "p44"),
    ),
    "teapot/3_contacts_middle_index_thumb": (
        "SAHandplusTeapot.world", 18, {"revolute": 9, "universal": 4, "spherical": 3,
                                       "in_patch": 3},
        ("p24", "p33", "p44"),
    ),
    "teapot/4_contacts_index_middle_ring_palm": (
        "SAHandplusTeapot.world", 19, {"revolute": 9, "universal": 4, "spherical": 4,
                                       "in_patch": 4},
        ("p14", "p24", "p34", "palm"),
    ),
}
HAND_LINKS = ("palm", "p12", "p13", "p14", "p22", "p23", "p24", "p32", "p33", "p34",
              "p40", "p42", "p43", "p44", "object")
PATCH_PREFIX = {"X_1": "b1", "X_2": "b2", "X_3": "b3", "X_4": "b4", "X_P": "bp"}

needs_shared = pytest.mark.skipif(
    not SHARED.is_dir(), reason=f"shared CuikSuite IJRR data not found at {SHARED}"
)


def world_path(folder: str) -> Path:
    return SHARED / folder / FILES[folder][0]


def load(folder: str) -> WorldFile:
    return read_world(world_path(folder))


def vec(constants, *names: str) -> tuple[float, float, float]:
    return tuple(constants[name] for name in names)  # type: ignore[return-value]


# --------------------------------------------------------------------------- shared files


@needs_shared
@pytest.mark.parametrize("folder", sorted(FILES))
def test_shared_file_structure(folder):
    world = load(folder)
    _, n_links, kinds, contact_links = FILES[folder]
    assert world.path == str(world_path(folder))
    assert len(world.links) == n_links
    assert world.ground == "palm"
    assert world.links[0].name == "palm"
    assert tuple(link.name for link in world.links[: len(HAND_LINKS)]) == HAND_LINKS
    assert Counter(joint.kind for joint in world.joints) == Counter(kinds)
    assert len(world.joints) == sum(kinds.values())
    # the 13 finger joints come first: 4 universal + 9 revolute, all between hand links
    finger = world.joints[:13]
    assert Counter(j.kind for j in finger) == Counter({"universal": 4, "revolute": 9})
    assert all(j.link1 in HAND_LINKS and j.link2 in HAND_LINKS for j in finger)
    spherical = [j for j in world.joints if j.kind == "spherical"]
    assert tuple(j.link1 for j in spherical) == contact_links


@needs_shared
@pytest.mark.parametrize("folder", sorted(FILES))
def test_shared_file_joint_lines_point_at_keywords(folder):
    lines = world_path(folder).read_text(encoding="utf-8").splitlines()
    world = load(folder)
    for joint in world.joints:
        text = lines[joint.line - 1].strip().lower()
        assert text.startswith(joint.kind + ":"), (joint.line, text)
    for link in world.links:
        assert lines[link.line - 1].strip().startswith(link.name + ":")
    for name, line in world.constant_lines.items():
        assert re.match(rf"\s*{re.escape(name)}\s*:=", lines[line - 1])


@needs_shared
@pytest.mark.parametrize("folder", sorted(FILES))
def test_shared_file_contacts_match_constants(folder):
    world = load(folder)
    c = world.constants
    joints = world.joints
    for index, joint in enumerate(joints):
        if joint.kind != "spherical":
            continue
        # the contact frame X_j: the sphere centre is rho below it; the next joint
        # puts X_j on a patch of the object
        assert joint.point2 == (0.0, 0.0, -c["rho"])
        assert joint.axis1 is None and joint.axis2 is None
        assert joint.ranges == ()
        assert joint.range_vectors[1] == (0.0, 0.0, 1.0)
        assert joint.avoid_limits is True
        patch_joint = joints[index + 1]
        assert patch_joint.kind == "in_patch"
        assert patch_joint.link1 == joint.link2
        assert patch_joint.link2 == "object"
        assert patch_joint.point1 == (0.0, 0.0, 0.0)
        assert patch_joint.axis1 == (0.0, 0.0, 1.0)
        assert patch_joint.point2 is None and patch_joint.axis2 is None
        prefix = PATCH_PREFIX[joint.link2]
        expected = tuple(
            vec(c, f"{prefix}_{ij}_x_o", f"{prefix}_{ij}_y_o", f"{prefix}_{ij}_z_o")
            for ij in ("00", "01", "10", "11")
        )
        assert patch_joint.patch == expected


@needs_shared
def test_teapot4_constants():
    c = load("teapot/4_contacts_index_middle_ring_palm").constants
    assert c["rho"] == 18.0
    assert c["qpx"] == pytest.approx(20.550 - 18)
    assert c["phi_3_1_max"] == pytest.approx(math.pi / 8)
    assert c["phi_3_1_min"] == pytest.approx(-math.pi / 8)
    assert c["beta_p"] == pytest.approx(math.pi / 3)
    assert c["q41z_0"] == -87.0
    assert c["b3_01_x_o"] == -34.95
    assert c["rc"] == 0.1
    with pytest.raises(TypeError):
        c["rho"] = 1.0  # type: ignore[index]


@needs_shared
def test_other_constants():
    assert load("teapot/2_contacts_index_thumb").constants["q35y_4"] == 10.0
    teapot3 = load("teapot/3_contacts_middle_index_thumb").constants
    assert teapot3["q34z_3_c"] == pytest.approx(12.859 - 13)
    assert teapot3["q25y_4"] == pytest.approx(-12.189 + 13)
    scalpel4 = load("scalpel/4_contacts_middle_index_thumb_palm").constants
    assert scalpel4["qpx"] == pytest.approx(7.312 - 0.707 * 13)
    assert scalpel4["qpy"] == pytest.approx(58.686 - 0.707 * 13)


@needs_shared
def test_teapot4_joints_in_detail():
    world = load("teapot/4_contacts_index_middle_ring_palm")
    c = world.constants
    first = world.joints[0]
    assert first.kind == "universal"
    assert (first.link1, first.link2) == ("palm", "p12")
    assert first.point1 == vec(c, "q11x", "q11y", "q11z")
    assert first.point2 == (0.0, 0.0, 0.0)
    assert first.axis1 == (1.0, 0.0, 0.0)
    assert first.axis2 == (0.0, 1.0, 0.0)
    assert first.ranges == ((-math.pi / 8, math.pi / 8), (0.0, math.pi / 2))
    assert first.range_vectors == ((0.0, -0.99941, 0.034301), (0.0, 0.0, 1.0))
    assert first.cone_angle is None and first.patch is None
    assert first.avoid_limits is True and first.avoid_limits_weight is None

    second = world.joints[1]
    assert second.kind == "revolute"
    assert (second.link1, second.link2) == ("p12", "p13")
    assert second.point1 == (67.8, 0.0, 0.0)
    assert second.axis1 == second.axis2 == (0.0, -1.0, 0.0)
    assert second.ranges == ((0.0, math.pi / 2),)
    assert second.range_vectors == ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0))

    # finger 4 (thumb) is held straight and its "avoid limits" are commented out
    thumb_base = world.joints[9]
    assert thumb_base.kind == "revolute"
    assert (thumb_base.link1, thumb_base.link2) == ("palm", "p40")
    assert thumb_base.axis1 == (0.0, 0.0, -1.0)
    assert thumb_base.axis2 == (-1.0, 0.0, 0.0)
    assert thumb_base.ranges == ((0.0, 0.0),)
    assert thumb_base.range_vectors == ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    assert [j.avoid_limits for j in world.joints[9:13]] == [False] * 4
    assert all(j.avoid_limits for j in world.joints[:9])
    thumb_universal = world.joints[10]
    assert thumb_universal.axis1 == (0.573580, 0.0, 0.81915)
    assert thumb_universal.ranges == ((0.0, 0.0), (0.0, 0.0))

    palm_contact = world.joints[-2]
    assert palm_contact.kind == "spherical"
    assert (palm_contact.link1, palm_contact.link2) == ("palm", "X_P")
    assert palm_contact.point1 == pytest.approx((20.550 - 18, -0.053, 117.348))
    assert palm_contact.cone_angle == pytest.approx(math.pi / 2)  # the file uses beta_1 here
    assert palm_contact.range_vectors == ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    index_contact = world.joints[13]
    assert index_contact.range_vectors[0] == vec(c, "m1x_4", "m1y_4", "m1z_4")
    assert index_contact.line == 423


@needs_shared
def test_teapot4_links():
    world = load("teapot/4_contacts_index_middle_ring_palm")
    palm = world.link("palm")
    assert palm.line == 283
    assert [b.path for b in palm.bodies] == [
        "bodies/palmSAH.off", "bodies/acs1palm.off", "bodies/acs2palm.off", "bodies/acs3palm.off",
    ]
    assert [b.color for b in palm.bodies] == ["white", "blue", "blue", None]
    assert all(b.kind == "off" and b.radius is None and b.points == () for b in palm.bodies)
    assert palm.color is None
    assert [b.path for b in world.link("p12").bodies] == [
        "bodies/p1.off", "bodies/p2.off", "bodies/b2.off",
    ]
    assert world.link("object").bodies == (
        WorldBody(kind="off", line=world.link("object").line, path="bodies/teapot.off",
                  color="red"),
    )
    x_p = world.link("X_P")
    assert x_p.color == "green"
    assert x_p.bodies == (
        WorldBody(kind="sphere", line=x_p.line, radius=0.1, points=((0.0, 0.0, 0.0),),
                  color="green"),
    )
    assert [link.name for link in world.links[15:]] == ["X_P", "X_1", "X_2", "X_3"]
    with pytest.raises(KeyError):
        world.link("X_4")


@needs_shared
def test_scalpel4_spherical_uses_beta_p_for_palm():
    world = load("scalpel/4_contacts_middle_index_thumb_palm")
    palm_contact = [j for j in world.joints if j.kind == "spherical" and j.link1 == "palm"]
    assert len(palm_contact) == 1
    assert palm_contact[0].cone_angle == pytest.approx(math.pi / 3)
    assert palm_contact[0].range_vectors[0] == (0.707, 0.707, 0.0)


# --------------------------------------------------------------------------- expressions


@pytest.mark.parametrize(
    "text, expected",
    [
        ("1 + 2 * 3", 7.0),
        ("(1 + 2) * 3", 9.0),
        ("10 - 4 - 3", 3.0),
        ("24 / 4 / 2", 3.0),
        ("(2 ^ 3) ^ 2", 64.0),
        ("-(2 ^ 2)", -4.0),
        ("(-2) ^ 2", 4.0),
        ("2 ^ -1", 0.5),
        ("-3 + 5", 2.0),
        ("- -3", 3.0),
        ("+4", 4.0),
        ("2 * -3", -6.0),
        ("((((1 + 1)) * (3 - (1))))", 4.0),
        ("1e3", 1000.0),
        ("2.5E-2", 0.025),
        ("1.5e+1", 15.0),
        (".5", 0.5),
        ("5.", 5.0),
        ("PI", math.pi),
        ("pi/2", math.pi / 2),
        ("sin(pi/2)", 1.0),
        ("COS(0)", 1.0),
        ("tan(pi/4)", pytest.approx(1.0)),
        ("asin(1)", math.pi / 2),
        ("acos(-1)", math.pi),
        ("atan(1)*4", math.pi),
        ("atan2(1, -1)", 3 * math.pi / 4),
        ("sqrt(16) + abs(-2)", 6.0),
        ("exp(0) + log(exp(2))", 3.0),
        ("sqrt(2)^2", pytest.approx(2.0)),
        ("2*3^2", 18.0),
        ("-sqrt(4)", -2.0),
    ],
)
def test_expressions(text, expected):
    assert evaluate_expression(text) == expected


def test_expression_with_constants():
    constants = {"rho": 18.0, "a_1": 2.0}
    assert evaluate_expression("20.550-1*rho", constants) == pytest.approx(2.55)
    assert evaluate_expression("a_1 ^ a_1 * rho", constants) == 72.0


@pytest.mark.parametrize(
    "text, message",
    [
        ("1/0", "division by zero"),
        ("2 ^ 3 ^ 2", r"'a\^b\^c' is ambiguous"),
        ("-2 ^ 2", r"'-a\^b' is ambiguous"),
        ("1 - -2 ^ 2", r"'-a\^b' is ambiguous"),
        ("sqrt(-1)", r"cannot evaluate sqrt\(-1\)"),
        ("log(0)", r"cannot evaluate log\(0\)"),
        ("asin(2)", r"cannot evaluate asin\(2\)"),
        ("(-8)^(1/3)", "cannot evaluate"),
        ("10^400", "cannot evaluate"),
        ("1e400", "cannot evaluate the number 1e400"),
        ("(1 + 2", r"expected '\)' to close the '\(' opened at line 1"),
        ("1 + ", "dangling '\\+': an operand must follow it"),
        ("1 2", "unexpected '2' after the expression"),
        ("atan2(1)", "takes 2 argument"),
        ("sin(1, 2)", "takes 1 argument"),
        ("foo + 1", "undefined constant 'foo'"),
        ("3 $ 4", r"unexpected character '\$'"),
    ],
)
def test_expression_errors(text, message):
    with pytest.raises(WorldFileError, match=message) as info:
        evaluate_expression(text)
    assert "line 1" in str(info.value)
    assert info.value.line == 1


def test_expression_never_uses_python_eval():
    with pytest.raises(WorldFileError):
        evaluate_expression("__import__('os')")


# --------------------------------------------------------------------------- synthetic worlds

MINI = """\
[CONSTANTS]
a := 1
[LINKS]
base: body "base.off"
arm: body "arm.off"
[JOINTS]
{joint}
"""
# line of the joint statement in MINI
JOINT_LINE = 7
REVOLUTE = "revolute: base (0,0,a)+(0,0,1) arm (0,0,0)+(0,0,1) range [-pi,pi] +(1,0,0) +(1,0,0)"


def mini(joint: str) -> str:
    return MINI.format(joint=joint)


def raises_at(text: str, line: int, match: str) -> WorldFileError:
    with pytest.raises(WorldFileError, match=match) as info:
        parse_world(text)
    assert f"line {line}:" in str(info.value)
    assert info.value.line == line
    return info.value


def test_minimal_world():
    world = parse_world(mini(REVOLUTE), path="mini.world")
    assert world.path == "mini.world"
    assert dict(world.constants) == {"a": 1.0}
    assert dict(world.constant_lines) == {"a": 2}
    assert [(link.name, link.line) for link in world.links] == [("base", 4), ("arm", 5)]
    (joint,) = world.joints
    assert joint.kind == "revolute" and joint.line == JOINT_LINE
    assert (joint.link1, joint.link2) == ("base", "arm")
    assert joint.point1 == (0.0, 0.0, 1.0) and joint.axis1 == (0.0, 0.0, 1.0)
    assert joint.point2 == (0.0, 0.0, 0.0) and joint.axis2 == (0.0, 0.0, 1.0)
    assert joint.ranges == ((-math.pi, math.pi),)
    assert joint.range_vectors == ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0))
    assert joint.avoid_limits is False
    assert {"revolute", "universal", "spherical", "in_patch", "crevolute", "fix", "prismatic"} <= set(JOINT_KINDS)


def test_comments_layout_and_case():
    text = """/** \\cond */
[constants]
% a comment line with := and (unbalanced
x:=2   /* inline block
spanning lines */ y := x*
   3
z := /* between tokens */ -y
[Links]
base: body "b.off" white
      body "c.off"
   /* block */ tip
tip2 : color(1, 0.5, 0) cylinder x (0,0,0)+(0,0,10) granularity 8 hidden
       box (0,0,0) (1,2,3) decoration
[JOINTS]
   SPHERICAL : base (0,0,0)
      tip (0,0,-x)   % the sphere centre
      RANGE [pi/4] +(0,0,1) (0,0,1)
      AVOID LIMITS 0.5
   Revolute: tip (0,0,0) (0,0,2) tip2 (1,1,1)+(0,0,1)
      reference +(1,0,0) +(0,1,0)
   universal: base (0,0,0)+(1,0,0) tip2 (0,0,0)+(0,1,0)
   in_patch: tip (0,0,0) (0,0,1) tip2 (0,0,0) (0,1,0) (1,0,0) (1,1,0) avoid limits
/** \\endcond */
/** trailing doxygen block with [OBSTACLES] and prismatic: inside */
"""
    world = parse_world(text)
    assert dict(world.constants) == {"x": 2.0, "y": 6.0, "z": -6.0}
    assert world.constant_lines["y"] == 5
    assert world.constant_lines["z"] == 7
    base, tip, tip2 = world.links
    assert base.line == 9 and [b.line for b in base.bodies] == [9, 10]
    assert [b.color for b in base.bodies] == ["white", None]
    assert tip.line == 11 and tip.bodies == ()
    assert tip2.color == (1.0, 0.5, 0.0)
    cylinder, box = tip2.bodies
    assert cylinder == WorldBody(kind="cylinder", line=12, radius=2.0,
                                 points=((0.0, 0.0, 0.0), (0.0, 0.0, 10.0)),
                                 color=(1.0, 0.5, 0.0), granularity=8, status="hidden")
    assert box == WorldBody(kind="box", line=13, points=((0.0, 0.0, 0.0), (1.0, 2.0, 3.0)),
                            color=(1.0, 0.5, 0.0), status="decoration")
    spherical, revolute, universal, in_patch = world.joints
    assert [j.line for j in world.joints] == [15, 19, 21, 22]
    assert spherical.point1 == (0.0, 0.0, 0.0) and spherical.point2 == (0.0, 0.0, -2.0)
    assert spherical.cone_angle == pytest.approx(math.pi / 4)
    # an absolute reference point is stored relative to its joint point
    assert spherical.range_vectors == ((0.0, 0.0, 1.0), (0.0, 0.0, 3.0))
    assert spherical.avoid_limits is True and spherical.avoid_limits_weight == 0.5
    # an absolute second point is stored as its displacement from the first
    assert revolute.axis1 == (0.0, 0.0, 2.0)
    assert revolute.point2 == (1.0, 1.0, 1.0) and revolute.axis2 == (0.0, 0.0, 1.0)
    assert revolute.ranges == ()
    assert revolute.range_vectors == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    assert universal.ranges == () and universal.range_vectors == ()
    assert universal.avoid_limits is False
    assert in_patch.patch == ((0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (1.0, 1.0, 0.0))
    assert in_patch.axis1 == (0.0, 0.0, 1.0) and in_patch.avoid_limits is True


def test_error_names_path_and_line():
    with pytest.raises(WorldFileError, match=r"^bad\.world:2: undefined constant 'b'") as info:
        parse_world("[CONSTANTS]\na := b\n", path="bad.world")
    assert info.value.path == "bad.world"
    assert info.value.line == 2
    assert isinstance(info.value, PrehensionError)


def test_undefined_constant():
    error = raises_at("[CONSTANTS]\nx := 1\n\ny := x + later\nlater := 2\n", 4,
                      "undefined constant 'later'")
    assert "defined" in str(error) and "earlier" in str(error)


def test_undefined_constant_in_joint():
    raises_at(mini(REVOLUTE.replace("(0,0,a)", "(0,0,nope)")), JOINT_LINE,
              "undefined constant 'nope'")


def test_redefined_constant():
    error = raises_at("[CONSTANTS]\nx := 1\ny := 2\n\nx := 3\n", 5,
                      "constant 'x' is defined twice")
    assert "line 2" in str(error) and "line 5" in str(error)


def test_division_by_zero_in_constant():
    raises_at("[CONSTANTS]\nx := 0\n\ny := 1/x\n", 4, "division by zero")


def test_domain_error_in_constant():
    raises_at("[CONSTANTS]\nx := -1\ny :=\n  sqrt(x)\n", 4, r"cannot evaluate sqrt\(-1\)")


@pytest.mark.parametrize("keyword", ["cylindrical", "hinge"])
def test_unknown_joint_keyword(keyword):
    error = raises_at(mini(f"{keyword}: base (0,0,0)+(0,0,1) arm (0,0,0)+(0,0,1)"), JOINT_LINE,
                      "expected a joint statement")
    assert "joints: revolute, universal, spherical, in_patch, crevolute, fix, prismatic" in str(error)


def test_trailing_garbage_after_joint():
    raises_at(mini(REVOLUTE + "\n speed 3"), JOINT_LINE + 1,
              "expected a joint statement 'KIND: ...', found 'speed'")


def test_unbalanced_parenthesis_in_joint():
    error = raises_at(mini("revolute: base (0,0,0 arm (0,0,0)+(0,0,1)"), JOINT_LINE,
                      r"expected ',' or '\)' in the joint point on 'base' opened at line 7, "
                      r"found 'arm'")
    assert "revolute: LINK (x,y,z)+(dx,dy,dz)" in str(error)
    raises_at(mini("revolute: base (0,0,0+(0,0,1)\n arm (0,0,0)+(0,0,1)"), JOINT_LINE,
              r"expected '\)' to close the '\(' opened at line 7, found ','")
    raises_at(mini("revolute: base (0,0,0)+(0,0,1) arm (0,0,0)+(0,0,1)\n"
                   "  range [0,1) +(1,0,0) +(1,0,0)"),
              JOINT_LINE + 1, r"expected '\]' to close the range opened at line 8, found '\)' "
              r"\(in the revolute joint starting at line 7")


def test_unbalanced_parenthesis_in_constant():
    raises_at("[CONSTANTS]\nx := (1 + 2\ny := 3\n", 3,
              r"expected '\)' to close the '\(' opened at line 2")


def test_two_coordinate_point():
    error = raises_at(mini("revolute: base (0,0,0)+(0,0,1)\n  arm (0,0)+(0,0,1)"), JOINT_LINE + 1,
                      r"needs 3 coordinates \(x, y, z\), found 2")
    assert f"starting at line {JOINT_LINE}" in str(error)


def test_four_coordinate_patch_point():
    raises_at(mini("in_patch: base (0,0,0) (0,0,1) arm (0,0,0) (0,1,0) (1,0,0,0) (1,1,0)"),
              JOINT_LINE, "patch control point P2 needs 3 coordinates")


def test_missing_patch_point():
    raises_at(mini("in_patch: base (0,0,0) (0,0,1) arm (0,0,0) (0,1,0) (1,0,0)"), JOINT_LINE + 1,
              "expected '\\(' to start patch control point P3")


def test_unknown_link_in_joint():
    error = raises_at(mini("universal: base (0,0,0)+(1,0,0) finger (0,0,0)+(0,1,0)"), JOINT_LINE,
                      "unknown link 'finger'")
    assert "base, arm" in str(error)
    assert "expected 'universal: LINK" in str(error)


def test_joint_on_one_link():
    raises_at(mini("spherical: arm (0,0,0) arm (0,0,0)"), JOINT_LINE, "two different links")


def test_empty_range():
    raises_at(mini(REVOLUTE.replace("[-pi,pi]", "[1,0]")), JOINT_LINE, r"empty range \[1, 0\]")


@pytest.mark.parametrize("section", ["FOO", "OBSTACLE"])
def test_unknown_section(section):
    text = mini(REVOLUTE) + f"\n[{section}]\ncheck: all\n"
    error = raises_at(text, JOINT_LINE + 2, rf"unknown section \[{section}\]")
    assert "[CONSTANTS], [LINKS], [JOINTS], [OBSTACLES], [COLLISIONS], [INCLUDE], [EQUATIONS]" in str(error)


def test_statement_before_any_section():
    raises_at("% header\nx := 1\n", 2, r"expected a section header such as \[CONSTANTS\]")


def test_constant_keyword_name():
    raises_at("[CONSTANTS]\npi := 3\n", 2, "'pi' is a keyword")


def test_missing_assign():
    raises_at("[CONSTANTS]\nx = 1\n", 2, r"unexpected character '='")
    raises_at("[CONSTANTS]\nx : 1\n", 2, "expected ':=' after constant name 'x'")


def test_duplicate_link_and_link_named_like_constant():
    raises_at("[LINKS]\nl: body \"a.off\"\n\nl: body \"b.off\"\n", 4, "link 'l' is defined twice")
    world = parse_world("[CONSTANTS]\nl := 1\n[LINKS]\nl: body \"b.off\"\n")  # apart, as in CuikSuite
    assert world.constants["l"] == 1.0 and world.links[0].name == "l"


def test_unknown_body_shape():
    raises_at("[LINKS]\nl: body \"a.off\"\n   cone (0,0,0) (1,0,0) (0,1,0) 1\n", 3,
              "expected a link name, found '\\('")


def test_body_without_file_name():
    raises_at("[LINKS]\nl: body a_off\n", 2, "expected a quoted file name after 'body'")


def test_unterminated_string_and_comment():
    raises_at("[LINKS]\nl: body \"a.off\n", 2, "unterminated string")
    raises_at("[CONSTANTS]\nx := 1\n/* open\n\n", 3, "unterminated block comment")


def test_comment_only_world_is_empty_but_valid():
    world = parse_world("% nothing\n/* here */\n")
    assert world.links == () and world.joints == () and dict(world.constants) == {}
    assert world.ground is None


def test_parse_empty_text():
    with pytest.raises(WorldFileError, match="empty"):
        parse_world("  \n\t\n")


# --------------------------------------------------------------------------- read_world


def test_read_world_missing(tmp_path):
    missing = tmp_path / "none.world"
    with pytest.raises(WorldFileError, match="no such world file") as info:
        read_world(missing)
    assert str(missing) in str(info.value)


def test_read_world_not_utf8_is_read_as_latin1(tmp_path):
    path = tmp_path / "latin1.world"
    path.write_bytes("[CONSTANTS]\n% caf\u00e9\nx := 2\n".encode("latin-1"))
    assert dict(read_world(path).constants) == {"x": 2.0}


def test_read_world_empty(tmp_path):
    path = tmp_path / "empty.world"
    path.write_text("", encoding="utf-8")
    with pytest.raises(WorldFileError, match="empty") as info:
        read_world(path)
    assert info.value.path == str(path)


def test_read_world_directory(tmp_path):
    with pytest.raises(WorldFileError, match="directory"):
        read_world(tmp_path)


def test_read_world_reports_path_and_line(tmp_path):
    path = tmp_path / "bad.world"
    path.write_text(mini("prismatic: base (0,0,0)+(0,0,1) arm (0,0,0)+(0,0,1) range [0,1)"), encoding="utf-8")
    with pytest.raises(WorldFileError, match=rf"^{re.escape(str(path))}:{JOINT_LINE}: "):
        read_world(path)


def test_read_world_ok(tmp_path):
    path = tmp_path / "ok.world"
    path.write_text(mini(REVOLUTE), encoding="utf-8")
    world = read_world(path)
    assert world.path == str(path)
    assert world == parse_world(mini(REVOLUTE), path=str(path))
