"""Re-deriving a result file's claims moved to :mod:`prehension.verification.claims`
(issue 29: verification is a stage of its own).  This module keeps the old import path
working; new code imports from :mod:`prehension.verification`."""

from .verification.claims import STORED_TOLERANCE, Finding, Verification, verify_result, verify_result_file  # noqa: F401

__all__ = ["Finding", "Verification", "verify_result", "verify_result_file", "STORED_TOLERANCE"]
