"""Two grasps of a 50 x 100 x 100 mm box by the SA hand: one that holds, one that does not.

* ``box-four-fingers``: index, middle and ring fingertips on the box's +x face, the thumb
  on its -x face.  Force closure (epsilon 0.061 with the default friction model); in the
  physics test it holds against all six pushes.
* ``box-one-face``: the same hand pose with the thumb idle: every contact on the +x face.
  Not force closure (epsilon 0); the squeeze alone pushes the box out of the hand.

The four-finger grasp is the best-ranked of ``solve --best 40 --starts 300 --method local``
on ``box-four-fingers.yaml`` (seed 0) among those that hold in the physics test; the box
is a solid of the task, so the residual function also checks that no link passes through
it.  Its joint angles and object pose are stored below so that the pictures and the tests
do not depend on the local solver's version.
Both grasps are re-verified (:func:`prehension.make_solution`) when built.

Run ``python examples/quality/box_grasps.py`` to write the two task files and the two
result files beside this script, then::

    prehension simulate examples/quality/box-four-fingers.result.json
    prehension render examples/quality/box-four-fingers.result.json -o docs/img/box-holds.png
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from prehension.pregrasp import approach_entries_of
from prehension import (
    BezierPatch, BezierRegion, Configuration, Contact, GraspObject, SolveResult, Task, make_solution, schunk_sa_hand,
)  # fmt: skip
from prehension.objects.meshes import Box
from prehension.objects.solid import PrimitiveSolid

HERE = Path(__file__).resolve().parent
WIDTH_MM, SIDE_MM, PATCH_MM = 50.0, 100.0, 90.0

#: The four-finger grasp (SA hand dof order) [rad] and the box pose T_palm_object [mm].
FOUR_FINGER_ANGLES = (
    -0.2617991006841814, 0.4012765329017622, 0.2075574499213984, 0.2075574499213984,
    -0.23360672855239087, 0.6275837913117309, 0.22301171000479872, 0.22301171000479872,
    -0.18766221229241803, 0.8968276188151317, 0.14373329119053146, 0.14373329119053146,
    1.5707963267948966, -0.2617988618240031, -0.04498353932623203, 0.0753932735533535, 0.0753932735533535,
)  # fmt: skip
FOUR_FINGER_POSE = (
    (-0.7415982851547617, -0.6505071018701094, -0.16392831931081658, 107.14286371281395),
    (0.6168439315319558, -0.5651765043612881, -0.5477947453655934, -3.926322359775028),
    (0.2636959377535382, -0.5073618327530225, 0.8203952846511101, 231.34091072040937),
    (0.0, 0.0, 0.0, 1.0),
)


def _face(center, u, v, size: float) -> BezierRegion:
    """A square planar patch of side ``size`` [mm] centred at ``center``; normal ``u x v``."""
    c, u, v = (np.asarray(x, float) for x in (center, u, v))
    corners = [[c + (i - 0.5) * size * u + (j - 0.5) * size * v for j in (0, 1)] for i in (0, 1)]
    return BezierRegion(BezierPatch(np.array(corners)))


def box() -> GraspObject:
    """The box (object frame at its centre) with a contact patch on its +x and -x faces."""
    h = WIDTH_MM / 2
    regions = {
        "plus_x": _face((h, 0, 0), (0, 1, 0), (0, 0, 1), PATCH_MM),  # normal +x
        "minus_x": _face((-h, 0, 0), (0, 0, 1), (0, 1, 0), PATCH_MM),  # normal -x
    }
    solid = PrimitiveSolid((Box((0.0, 0.0, 0.0), (WIDTH_MM, SIDE_MM, SIDE_MM)),))
    return GraspObject("box", regions, solid=solid)  # a solid: the hand may not pass through it


def four_finger_task() -> Task:
    contacts = (Contact("index_tip", "plus_x"), Contact("middle_tip", "plus_x"), Contact("ring_tip", "plus_x"),
                Contact("thumb_tip", "minus_x"))  # fmt: skip
    return Task("box-four-fingers", schunk_sa_hand(), box(), contacts, ("index", "middle", "ring", "thumb"),
                description="Index, middle and ring fingertips on the +x face of a 50 mm box, the thumb on its -x face.")  # fmt: skip


def one_face_task() -> Task:
    contacts = (Contact("index_tip", "plus_x"), Contact("middle_tip", "plus_x"), Contact("ring_tip", "plus_x"))
    return Task("box-one-face", schunk_sa_hand(), box(), contacts, ("index", "middle", "ring"),
                description="Index, middle and ring fingertips on the +x face of a 50 mm box; nothing on the other side.")  # fmt: skip


def _grasp(task: Task):
    q = np.where(task.active_mask, FOUR_FINGER_ANGLES, task.idle_vector)
    solution = make_solution(task, Configuration(q, np.array(FOUR_FINGER_POSE)))
    if solution is None:
        raise RuntimeError(f"the stored grasp of {task.name} no longer satisfies its task (has the SA hand changed?)")
    return solution


def four_finger_grasp():
    """``(task, verified solution)`` of the grasp that holds."""
    task = four_finger_task()
    return task, _grasp(task)


def one_face_grasp():
    """``(task, verified solution)``: the same hand pose, thumb idle, every contact on one face."""
    task = one_face_task()
    return task, _grasp(task)


def write_files(folder: Path = HERE) -> list[Path]:
    """The two task files and the two result files (stored grasps, method 'local')."""
    from prehension import dump_task, write_result
    from prehension.quality import quality_entries

    written = []
    for task, solution in (four_finger_grasp(), one_face_grasp()):
        dump_task(task, folder / f"{task.name}.yaml")
        note = "the stored grasp of examples/quality/box_grasps.py, re-verified by make_solution"
        result = SolveResult(task, "local", "solved", note, (solution,))
        write_result(result, folder / f"{task.name}.result.json", quality_entries(result), approach_entries_of(result))
        written += [folder / f"{task.name}.yaml", folder / f"{task.name}.result.json"]
    return written


if __name__ == "__main__":
    for path in write_files():
        print(f"wrote {path}")
