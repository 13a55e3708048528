"""prehension: grasp configurations of multi-fingered hands with specified contact regions.

The data flow is ``hand + object + contacts -> Task -> solver -> configuration``; every
configuration is judged by one residual function, :func:`evaluate`.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from .errors import (
    DegeneratePatch,
    InvalidConfiguration,
    InvalidGeometry,
    InvalidHand,
    InvalidObject,
    InvalidTask,
    PrehensionError,
    WorldFileError,
)
from .geometry.bezier import BezierPatch
from .geometry.regions import BezierRegion, PointRegion, Region, SphereCap
from .hands.kinematics import HandPose, forward_kinematics
from .hands.model import Capsule, Coupling, Finger, Hand, HandRegion, Joint, Link
from .hands.sa_hand import schunk_sa_hand
from .hands.files import load_hand_file
from .hands.mjcf import hand_from_mjcf
from .hands.urdf import hand_from_urdf
from .best import BestOptions, solve_best
from .objects.mesh_io import load_mesh
from .objects.model import GraspObject
from .objects.pick import PickedRegion, region_from_mesh
from .objects.solid import MeshFileSolid, PrimitiveSolid
from .quality import GraspQuality, QualityOptions, grasp_quality
from .results import Solution, SolveResult, Status, make_solution, read_result, write_result
from .solve import solve
from .tasks.cuik_import import import_world
from .tasks.library import builtin_task_names, load_builtin_task, resolve_task
from .tasks.model import Configuration, Contact, Task
from .tasks.residuals import ResidualReport, Tolerances, evaluate
from .tasks.variants import move_object_region, turn_object_region
from .tasks.yaml_io import dump_task, dumps_task, load_task, loads_task

try:
    __version__ = version("prehension")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+local"

__all__ = [
    "__version__",
    # errors
    "PrehensionError", "InvalidGeometry", "DegeneratePatch", "InvalidHand", "InvalidObject",
    "InvalidTask", "InvalidConfiguration", "WorldFileError",
    # geometry and regions
    "BezierPatch", "Region", "BezierRegion", "SphereCap", "PointRegion",
    # hands
    "Hand", "Joint", "Link", "Capsule", "Coupling", "Finger", "HandRegion", "HandPose",
    "forward_kinematics", "schunk_sa_hand", "hand_from_urdf", "hand_from_mjcf", "load_hand_file",
    # objects and tasks
    "GraspObject", "MeshFileSolid", "PrimitiveSolid", "load_mesh", "region_from_mesh", "PickedRegion",
    "Task", "Contact", "Configuration",
    "evaluate", "Tolerances", "ResidualReport",
    "load_task", "loads_task", "dump_task", "dumps_task", "import_world",
    "builtin_task_names", "load_builtin_task", "resolve_task", "move_object_region", "turn_object_region",
    # solving and results
    "solve", "SolveResult", "Solution", "Status", "make_solution", "write_result", "read_result",
    # does the grasp hold? (the physics test: prehension.sim, extra "sim")
    "grasp_quality", "QualityOptions", "GraspQuality", "solve_best", "BestOptions",
]  # fmt: skip
