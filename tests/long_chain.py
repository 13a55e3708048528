"""A hand with 100 revolute joints: two long planar chains that fold onto themselves.

Issue 28, item 2: on such a hand almost every random joint vector is in self-collision,
so sampling by rejection never ends unless it is bounded.  :func:`chain_urdf` writes the
hand as URDF text (capsule-like cylinders on every link, a sphere at each tip, so
the import fits fingertip caps); :func:`chain_task_yaml` a task of two fingertips on two
points of an object.
"""

from __future__ import annotations

from pathlib import Path


def chain_urdf(joints_per_finger: int = 50, link_mm: float = 10.0, name: str = "long-chain", limit_rad: float = 2.6) -> str:
    """Two fingers of ``joints_per_finger`` revolute joints each (limits +-``limit_rad``, about
    y), links ``link_mm`` long with a 4 mm cylinder, 20 mm apart at the palm."""
    m = link_mm / 1000.0
    parts = [f"<robot name='{name}'><link name='palm'><collision><geometry><box size='0.06 0.04 0.01'/></geometry></collision></link>"]
    for finger, y in (("a", 0.01), ("b", -0.01)):
        parent = "palm"
        for i in range(joints_per_finger):
            link = f"{finger}{i}"
            tip = "<collision><origin xyz='0 0 %g'/><geometry><sphere radius='0.005'/></geometry></collision>" % m
            geom = (f"<collision><origin xyz='0 0 {m / 2}'/><geometry><cylinder radius='0.004' length='{m}'/></geometry>"
                    f"</collision>{tip if i == joints_per_finger - 1 else ''}")  # fmt: skip
            parts.append(f"<link name='{link}'>{geom}</link>")
            origin = f"0 {y} 0.01" if parent == "palm" else f"0 0 {m}"
            parts.append(
                f"<joint name='j{link}' type='revolute'><parent link='{parent}'/><child link='{link}'/>"
                f"<origin xyz='{origin}'/><axis xyz='0 1 0'/><limit lower='{-limit_rad}' upper='{limit_rad}'/></joint>"
            )
            parent = link
    parts.append("</robot>")
    return "".join(parts)


def write_chain_hand(folder: Path, joints_per_finger: int = 50, limit_rad: float = 2.6, name: str = "chain.urdf") -> Path:
    path = Path(folder) / name
    path.write_text(chain_urdf(joints_per_finger, limit_rad=limit_rad))
    return path


def chain_task_yaml(hand_file: Path, name: str = "chain-pinch", apart_mm: float = 30.0) -> str:
    """Both fingertips on two points ``apart_mm`` apart, normals facing away from each other
    (a task file; hand by relative path).  900 mm apart: far beyond what the solvers settle
    in a few seconds on this hand."""
    return (
        f"prehension: task/1\nname: {name}\nhand: {{urdf: {Path(hand_file).name}}}\n"
        "object:\n  name: two-points\n  regions:\n"
        f"    A: {{point: [0, 0, 0], normal: [0, 1, 0]}}\n    B: {{point: [0, {-apart_mm:g}, 0], normal: [0, {-1 if apart_mm < 100 else 1}, 0]}}\n"
        "contacts:\n  - {hand: a0_tip, object: A}\n  - {hand: b0_tip, object: B}\nfingers: [a0, b0]\n"
    )
