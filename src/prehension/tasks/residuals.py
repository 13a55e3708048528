"""The residual function moved to :mod:`prehension.verification.residuals` (issue 29: the
stage that judges every answer stands apart from the task model).  This module keeps the
old import path working; new code imports from :mod:`prehension.verification`."""

from ..verification.residuals import (  # noqa: F401  (re-exported)
    TOLERANCE_OF_KIND, Check, ContactState, ResidualReport, Tolerances, _evaluate, contact_residuals, coupling_violations,
    evaluate, limit_violations,
)  # fmt: skip

__all__ = [
    "Tolerances", "TOLERANCE_OF_KIND", "Check", "ContactState", "ResidualReport", "evaluate", "contact_residuals",
    "limit_violations", "coupling_violations",
]  # fmt: skip
