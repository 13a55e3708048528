"""The local solver: Jacobian iterations from an off-line sequence of initial poses (Claret & Suárez).

Public API:

* :func:`solve_local` -- one task -> :class:`~prehension.results.SolveResult` (method ``"local"``);
* :func:`solve_local_batch` -- many problems of one hand in one call -> :class:`LocalBatch`;
* :class:`LocalOptions` -- the paper's parameters (``i_max``, ``k_max``, ``d_min``...) and ours;
* :class:`PointProblems`, :func:`random_point_problems` -- the compact batch form and the
  paper's random feasible problems;
* :class:`InitialPoseSequence`, :func:`default_sequence`, :func:`offline_sequence` (with
  :class:`OfflineSearch`) -- sec. 3.2;
* :func:`compile_pending`, :func:`warm_up` -- the first run compiles the kernel once.

See ``docs/local-solver.md``.
"""

from .options import LocalOptions
from .problems import PointProblems, random_point_problems
from .sequence import PAPER_TABLE1, InitialPoseSequence, default_sequence
from .solver import LocalBatch, LocalRecord, Refinement, refine_local, solve_local, solve_local_batch
from .warmup import COMPILING_MESSAGE, compile_pending, warm_up

__all__ = [
    "LocalOptions",
    "solve_local",
    "solve_local_batch",
    "refine_local",
    "Refinement",
    "LocalBatch",
    "LocalRecord",
    "PointProblems",
    "random_point_problems",
    "InitialPoseSequence",
    "default_sequence",
    "offline_sequence",
    "OfflineSearch",
    "PAPER_TABLE1",
    "compile_pending",
    "warm_up",
    "COMPILING_MESSAGE",
]


def __getattr__(name):  # the off-line search loads only when asked for
    if name in ("offline_sequence", "OfflineSearch"):
        from . import offline

        return getattr(offline, name)
    raise AttributeError(name)
