"""Hands whose link meshes are GLB, GLTF, PLY, OFF (and DAE with pycollada), read through
trimesh (issue 31 item 2): a scene is flattened with its node transforms, the file's
``scale`` applies, the fitted capsule encloses the mesh, and a file that cannot be read is
named with the formats that are."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from prehension.cli import main
from prehension.errors import InvalidHand, InvalidObject
from prehension.hands import link_cache
from prehension.hands.enclosure import capsule_gaps
from prehension.hands.mjcf import hand_from_mjcf
from prehension.hands.shapes import read_mesh_vertices
from prehension.hands.urdf import hand_from_urdf, load_urdf_hand
from prehension.objects.mesh_io import read_triangles

HAVE_COLLADA = importlib.util.find_spec("collada") is not None
SEEDS = range(6)


def _pose(rng) -> np.ndarray:
    """A random rigid transform (4, 4) [m]: any rotation, a translation of a few cm."""
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.uniform(-0.03, 0.03, 3)
    return T


def _moved(points, T) -> np.ndarray:
    return np.asarray(points, dtype=float) @ T[:3, :3].T + T[:3, 3]


def _scene_file(path, rng, parts: int = 2):
    """A scene of ``parts`` random boxes, each in its own node at a random pose (GLB, GLTF,
    DAE; a PLY or OFF holds one mesh: the boxes posed and joined); returns the file and
    every vertex where the scene puts it (n, 3) [m]."""
    scene, where = trimesh.Scene(), []
    for k in range(parts):
        box = trimesh.creation.box(extents=rng.uniform(0.005, 0.04, 3))
        T = _pose(rng)
        scene.add_geometry(box, node_name=f"part{k}", geom_name=f"part{k}", transform=T)
        where.append(_moved(box.vertices, T))
    if path.suffix in (".ply", ".off"):
        trimesh.util.concatenate(scene.dump()).export(str(path))
    else:
        scene.export(str(path))
    return path, np.concatenate(where)


def _urdf(path, filename: str, scale: str = "1 1 1", role: str = "collision") -> None:
    path.write_text(f"<robot name='m'><link name='palm'><{role}><origin xyz='0.01 0 0' rpy='0 0 0.5'/><geometry>"
                    f"<mesh filename='{filename}' scale='{scale}'/></geometry></{role}></link></robot>")  # fmt: skip


def _in_link(points_m, scale) -> np.ndarray:
    """Mesh points [m] as the URDF above places them in the palm frame [mm]."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", 0.5).as_matrix()
    T[:3, 3] = [0.01, 0.0, 0.0]
    return 1000.0 * _moved(np.asarray(points_m) * scale, T)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_urdf_hand_with_scene_meshes_encloses_every_node(tmp_path, seed, suffix):
    rng = np.random.default_rng(seed)
    mesh, points = _scene_file(tmp_path / f"link{suffix}", rng)
    scale = rng.uniform(0.5, 2.0, 3)
    _urdf(tmp_path / "h.urdf", mesh.name, " ".join(map(repr, scale.tolist())))
    hand, warnings = load_urdf_hand(tmp_path / "h.urdf")
    assert warnings == [] and not any("skipped" in n for n in hand.notes)
    caps = hand.links[0].collision
    stored = read_mesh_vertices(mesh)  # GLB stores float32: the scene's corners within 1e-8 m
    np.testing.assert_allclose(stored, np.unique(points, axis=0), rtol=0, atol=1e-8)  # node transforms applied
    assert capsule_gaps(_in_link(stored, scale), caps).max() <= 1e-6  # every corner of every node inside
    assert capsule_gaps(_in_link(points, scale), caps).max() <= 1e-4  # the scene as drawn, to float32
    assert hand.links[0].fit.miss_mm == 0.0


def test_node_transforms_are_applied(tmp_path):
    """A long thin box turned 90 degrees about z by its node: the capsule lies along y."""
    scene = trimesh.Scene()
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    T[:3, 3] = [0.0, 0.0, 0.05]
    scene.add_geometry(trimesh.creation.box(extents=(0.06, 0.01, 0.01)), node_name="finger", transform=T)
    scene.export(str(tmp_path / "m.glb"))
    (tmp_path / "h.urdf").write_text("<robot name='m'><link name='palm'><collision><geometry>"
                                     "<mesh filename='m.glb'/></geometry></collision></link></robot>")  # fmt: skip
    (cap,) = hand_from_urdf(tmp_path / "h.urdf").links[0].collision
    axis = (cap.b - cap.a) / np.linalg.norm(cap.b - cap.a)
    assert abs(axis[1]) == pytest.approx(1.0, abs=1e-3)
    np.testing.assert_allclose((cap.a + cap.b) / 2, [0.0, 0.0, 50.0], atol=1e-6)


@pytest.mark.parametrize("suffix", [".ply", ".off", ".stl", ".obj"])
def test_single_mesh_formats_give_the_same_capsule(tmp_path, suffix):
    """One random closed mesh (a hull of seeded random points) saved in each format gives
    the capsule the vertices give (STL stores float32, the others the digits written)."""
    pts = np.random.default_rng(11).normal(size=(60, 3)) * [0.02, 0.01, 0.005]
    hull = trimesh.convex.convex_hull(pts)
    hull.export(str(tmp_path / f"m{suffix}"))
    read = read_mesh_vertices(tmp_path / f"m{suffix}")
    np.testing.assert_allclose(read, np.unique(hull.vertices, axis=0), rtol=0, atol=1e-8)
    _urdf(tmp_path / "h.urdf", f"m{suffix}")
    hand, warnings = load_urdf_hand(tmp_path / "h.urdf")
    assert warnings == []
    assert capsule_gaps(_in_link(read, 1.0), hand.links[0].collision).max() <= 1e-6


def test_visual_glb_meshes_give_the_fingertip_points(tmp_path):
    """A link with a GLB visual only (dex-urdf's layout) is read without a warning."""
    _scene_file(tmp_path / "v.glb", np.random.default_rng(2), parts=1)
    _urdf(tmp_path / "h.urdf", "v.glb", role="visual")
    hand, warnings = load_urdf_hand(tmp_path / "h.urdf")
    assert not any("v.glb" in w for w in warnings) and not any("skipped" in n for n in hand.notes)


def test_mesh_vertices_are_those_of_the_triangles(tmp_path):
    """A PLY keeps vertices no face uses; they are not part of the surface and are left out."""
    (tmp_path / "m.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n5 5 5\n0 1 0\n3 0 1 2\n"
    )
    assert len(read_triangles(tmp_path / "m.ply")[0]) == 5
    np.testing.assert_array_equal(read_mesh_vertices(tmp_path / "m.ply"), [[0, 0, 0], [0, 1, 0], [1, 0, 0]])


# -- bad files: a warning (URDF) or an error (MJCF) naming the file and the formats read --------
def _bad_files(tmp_path) -> dict[str, str]:
    rng = np.random.default_rng(5)
    (tmp_path / "garbage.glb").write_bytes(rng.integers(0, 256, 400, dtype=np.uint8).tobytes())
    (tmp_path / "garbage.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\nend_header\nnonsense\n")
    (tmp_path / "empty.gltf").write_bytes(b"")
    (tmp_path / "m.3ds").write_bytes(b"MM\0\0")
    (tmp_path / "beyond.ply").write_text(  # a face naming vertex 7 of 3
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"
    )
    return {"garbage.glb": "not a readable mesh", "garbage.ply": "not a readable mesh|holds no triangles",
            "empty.gltf": r"the file is empty", "m.3ds": "unsupported mesh format .3ds",
            "beyond.ply": r"faces index vertices 0..2, got 0..7"}  # fmt: skip


def test_a_bad_mesh_file_is_skipped_with_a_warning_naming_it(tmp_path):
    for name, problem in _bad_files(tmp_path).items():
        _urdf(tmp_path / "h.urdf", name)
        hand, warnings = load_urdf_hand(tmp_path / "h.urdf")
        warning = warnings[0]  # (then, for a file of a format read: the link has no collision shape)
        assert str(tmp_path / name) in warning and warning.endswith("; skipped")
        assert any(p in warning for p in problem.split("|")), warning
        if name in ("garbage.glb", "garbage.ply", "m.3ds"):  # the format's fault, maybe: say which are read
            assert "mesh files are read from .obj, .stl, .ply, .off, .glb, .gltf" in warning
        assert hand.links[0].collision == ()


@pytest.mark.skipif(HAVE_COLLADA, reason="pycollada is installed: DAE files are read")
def test_dae_without_pycollada_says_what_to_install(tmp_path):
    (tmp_path / "m.dae").write_text("<COLLADA/>")
    needs = r"m\.dae: reading DAE files needs the optional module collada \(pip install pycollada\)"
    with pytest.raises(InvalidObject, match=needs):
        read_triangles(tmp_path / "m.dae")
    _urdf(tmp_path / "h.urdf", "m.dae")
    (warning,) = load_urdf_hand(tmp_path / "h.urdf")[1]
    assert "pip install pycollada" in warning and warning.endswith("; skipped")


@pytest.mark.skipif(not HAVE_COLLADA, reason="reading DAE needs pycollada")
def test_a_dae_mesh_is_read_with_pycollada(tmp_path):  # pragma: no cover - without pycollada
    mesh, points = _scene_file(tmp_path / "m.dae", np.random.default_rng(4))
    _urdf(tmp_path / "h.urdf", mesh.name)
    hand, warnings = load_urdf_hand(tmp_path / "h.urdf")
    assert warnings == []
    assert capsule_gaps(_in_link(points, 1.0), hand.links[0].collision).max() <= 1e-6


def test_show_prints_the_warning_not_a_traceback(tmp_path, capsys):
    _bad_files(tmp_path)
    _urdf(tmp_path / "h.urdf", "garbage.glb")
    assert main(["show", str(tmp_path / "h.urdf")]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    assert "garbage.glb: not a readable mesh" in captured.out + captured.err


# -- the link cache ----------------------------------------------------------------------------
def test_the_cache_key_changes_with_its_version(monkeypatch):
    link_cache._fingerprint.cache_clear()
    key = link_cache.link_key([], [])
    monkeypatch.setattr(link_cache, "VERSION", link_cache.VERSION + 1)
    link_cache._fingerprint.cache_clear()
    try:
        assert link_cache.link_key([], []) != key
    finally:
        monkeypatch.undo()
        link_cache._fingerprint.cache_clear()


# -- MJCF -------------------------------------------------------------------------------------
needs_mujoco = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason='needs "prehension[mjcf]"')

MJCF = """<mujoco model='meshy'>
  <compiler meshdir='assets'/>
  <default><default class='big'><mesh scale='{scale}'/></default></default>
  <asset>
    <mesh name='palm' file='palm.obj'/>
    <mesh name='finger' class='big' file='finger{suffix}'/>
  </asset>
  <worldbody>
    <body name='palm'>
      <geom type='mesh' mesh='palm'/>
      <body name='finger' pos='0 0 0.05' quat='0.9238795 0 0.3826834 0'>
        <joint name='j' type='hinge' axis='1 0 0' range='-1 1'/>
        <geom type='mesh' mesh='finger'/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def _mjcf_hand(tmp_path, seed: int, suffix: str):
    """An MJCF hand (Menagerie layout: meshdir, a default class scaling the mesh) whose
    finger is a random scene of boxes; returns the file and the finger's points [m] as the
    file places them in the finger's body frame, scale applied."""
    rng = np.random.default_rng(seed)
    (tmp_path / "assets").mkdir(exist_ok=True)
    trimesh.creation.box(extents=(0.08, 0.08, 0.02)).export(str(tmp_path / "assets" / "palm.obj"))
    mesh, points = _scene_file(tmp_path / "assets" / f"finger{suffix}", rng)
    scale = rng.uniform(0.5, 2.0, 3)
    path = tmp_path / "hand.xml"
    path.write_text(MJCF.format(scale=" ".join(map(repr, scale.tolist())), suffix=suffix))
    return path, points * scale


@needs_mujoco
@pytest.mark.parametrize("seed", SEEDS[:3])
@pytest.mark.parametrize("suffix", [".glb", ".gltf", ".ply"])
def test_an_mjcf_hand_with_scene_meshes_encloses_them(tmp_path, seed, suffix):
    path, points = _mjcf_hand(tmp_path, seed, suffix)
    hand = hand_from_mjcf(path)
    assert not any(n.startswith("warning: ") for n in hand.notes), hand.notes
    finger = hand.links[hand.link_index("finger")]
    # MuJoCo keeps compiled vertices in float32 (metres): the capsule holds those exactly
    assert capsule_gaps(1000.0 * points, finger.collision).max() <= 1e-4
    assert finger.fit.miss_mm == 0.0


@needs_mujoco
def test_an_mjcf_glb_mesh_gives_the_capsule_of_the_same_mesh_as_obj(tmp_path):
    """The GLB finger read through trimesh and the same triangles written as OBJ (read by
    MuJoCo itself) give the same capsule: MuJoCo scales and centres both alike."""
    glb, _ = _mjcf_hand(tmp_path, 7, ".glb")
    vertices, faces = read_triangles(tmp_path / "assets" / "finger.glb")
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices.tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces.tolist()]
    (tmp_path / "assets" / "finger.obj").write_text("\n".join(lines) + "\n")
    obj = tmp_path / "hand_obj.xml"
    obj.write_text(glb.read_text().replace("finger.glb", "finger.obj"))
    a = hand_from_mjcf(glb).links[1].collision
    b = hand_from_mjcf(obj).links[1].collision
    for ca, cb in zip(a, b, strict=True):
        np.testing.assert_allclose([*ca.a, *ca.b, ca.radius], [*cb.a, *cb.b, cb.radius], atol=1e-6)


@needs_mujoco
def test_a_bad_mjcf_mesh_is_an_error_naming_mesh_file_and_formats(tmp_path):
    path, _ = _mjcf_hand(tmp_path, 0, ".glb")
    for name, problem in _bad_files(tmp_path / "assets").items():
        path.write_text(MJCF.format(scale="1 1 1", suffix=".glb").replace("finger.glb", name))
        with pytest.raises(InvalidHand, match=rf"hand\.xml: mesh 'finger': .*({problem})") as info:
            hand_from_mjcf(path)
        assert name in str(info.value)
        if name in ("garbage.glb", "garbage.ply", "m.3ds"):
            assert ".obj, .stl, .ply, .off, .glb, .gltf" in str(info.value)


@needs_mujoco
def test_the_qpos_joint_order_of_an_mjcf_hand_with_glb_meshes_is_mujocos(tmp_path):
    """The interop records take an MJCF hand's joint order from MuJoCo's compile of the file;
    with a GLB finger that compile must go through the hand reader's (it used to fail and
    fall back, silently, to the hand's own order)."""
    from prehension.hands.qpos import _mjcf_joint_names

    path, _ = _mjcf_hand(tmp_path, 3, ".glb")
    assert _mjcf_joint_names(str(path), "glb-finger") == ("j",)
