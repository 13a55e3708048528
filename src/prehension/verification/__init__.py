"""Verification: the stage that judges every answer, apart from the solvers that make them.

* :mod:`.residuals` -- the one residual function, :func:`evaluate`: given a task and a
  configuration, every constraint's violation in physical units, each compared with a
  :class:`Tolerances` entry.  Every solver builds its solutions through it
  (:func:`prehension.results.make_solution`), and so do the tests and benchmarks;
* :mod:`.claims` -- re-deriving everything a result file claims (:func:`verify_result`,
  :func:`verify_result_file`): what ``prehension check`` runs, so that ``check`` never
  disagrees with ``solve``.

Imports flow into this stage from the solvers, results and the command line; the residual
function itself imports only the model (geometry, hands, tasks).  The names of
:mod:`.claims` are imported on first use: the result type (:mod:`prehension.results`)
imports the residual function, and the claims read result files.
"""

from __future__ import annotations

from importlib import import_module

from .residuals import (
    TOLERANCE_OF_KIND, Check, ContactState, ResidualReport, Tolerances, contact_residuals, coupling_violations, evaluate,
    limit_violations,
)  # fmt: skip

_CLAIMS = ("Finding", "Verification", "verify_result", "verify_result_file", "STORED_TOLERANCE")

__all__ = [
    "Tolerances", "TOLERANCE_OF_KIND", "Check", "ContactState", "ResidualReport", "evaluate", "contact_residuals",
    "limit_violations", "coupling_violations", *_CLAIMS,
]  # fmt: skip


def __getattr__(name: str):
    """A name of :mod:`.claims`, imported on first use (see the module docstring)."""
    if name not in _CLAIMS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(".claims", __name__), name)
    globals()[name] = value
    return value
