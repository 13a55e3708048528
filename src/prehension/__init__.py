"""prehension: grasp configurations of multi-fingered hands with specified contact regions.

The data flow is ``hand + object + contacts -> Task -> solver -> configuration``; every
configuration is judged by one residual function, :func:`evaluate`.
"""

from __future__ import annotations

from importlib import import_module

from .errors import (
    DegeneratePatch,
    InvalidConfiguration,
    InvalidGeometry,
    InvalidHand,
    InvalidObject,
    InvalidTask,
    PrehensionError,
    SamplingError,
    WorldFileError,
)

# Where each public name lives.  They are imported on first use (PEP 562 ``__getattr__``),
# so that ``import prehension.cli`` (or any submodule) does not pay for scipy.spatial,
# trimesh, the quality measures or the solvers it does not touch: the command line
# starts in a fraction of the time.  ``from prehension import X`` and ``prehension.X``
# work as with eager imports; ``dir(prehension)`` lists every name.
_SOURCES = {
    ".assignment": ("OpenContact", "OpenTask", "Assignment", "AssignmentOptions", "AssignmentReport", "search_assignments"),
    ".geometry.bezier": ("BezierPatch",),
    ".geometry.regions": ("BezierRegion", "PointRegion", "Region", "SphereCap"),
    ".hands.kinematics": ("HandPose", "forward_kinematics"),
    ".hands.model": ("Capsule", "Coupling", "Finger", "Hand", "HandRegion", "Joint", "Link"),
    ".hands.sa_hand": ("schunk_sa_hand",),
    ".hands.files": ("load_hand_file",),
    ".hands.mjcf": ("hand_from_mjcf",),
    ".hands.urdf": ("hand_from_urdf",),
    ".interop": ("solution_qpos", "qpos_configuration"),
    ".best": ("BestOptions", "solve_best"),
    ".objects.mesh_io": ("load_mesh",),
    ".objects.model": ("GraspObject",),
    ".objects.pick": ("PickedRegion", "region_from_mesh"),
    ".objects.solid": ("MeshFileSolid", "PrimitiveSolid"),
    ".quality": ("GraspQuality", "QualityOptions", "grasp_quality", "quality_entries"),
    ".pregrasp": ("approach_entries_of",),
    ".results": ("Solution", "SolveResult", "Status", "make_solution", "read_result", "write_result"),
    ".tasks.cuik_import": ("import_world",),
    ".tasks.library": ("builtin_task_names", "load_builtin_task", "resolve_task"),
    ".tasks.model": ("Configuration", "Contact", "Task"),
    ".verification.residuals": ("ResidualReport", "Tolerances", "evaluate"),
    ".tasks.variants": ("move_object_region", "turn_object_region"),
    ".tasks.yaml_io": ("dump_task", "dumps_task", "load_task", "loads_task", "load_open_task"),
}
_MODULE_OF = {name: module for module, names in _SOURCES.items() for name in names}

# ``solve`` is both a submodule and the function it defines: imported now, so that
# ``prehension.solve`` is the function whichever of them is imported first.
from .solve import SolveOptions, solve  # noqa: E402


__all__ = [
    "__version__",
    # errors
    "PrehensionError", "InvalidGeometry", "DegeneratePatch", "InvalidHand", "InvalidObject",
    "InvalidTask", "InvalidConfiguration", "WorldFileError", "SamplingError",
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
    "solve", "SolveOptions", "SolveResult", "Solution", "Status", "make_solution", "write_result", "read_result",
    # does the grasp hold? (the physics test: prehension.sim, extra "sim")
    "grasp_quality", "QualityOptions", "GraspQuality", "quality_entries", "approach_entries_of", "solve_best", "BestOptions",
    # which finger goes where: the assignment search (docs/assignment.md)
    "OpenContact", "OpenTask", "Assignment", "AssignmentOptions", "AssignmentReport", "search_assignments", "load_open_task",
]  # fmt: skip


def _version() -> str:
    """The installed distribution's version (``0.0.0+local`` in a source tree without
    installation).  Read on first use of ``prehension.__version__``: asking the package
    metadata costs ~10 ms, which every command would otherwise pay at start-up."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("prehension")
    except PackageNotFoundError:
        return "0.0.0+local"


def __getattr__(name: str):
    """A public name, imported from its module on first use (then kept in the package);
    ``__version__`` read from the package metadata on first use."""
    if name == "__version__":
        globals()[name] = value = _version()
        return value
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'prehension' has no attribute {name!r}")
    value = getattr(import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_MODULE_OF) | {"__version__"})
