"""The errors prehension raises on bad input.

Every error a user can provoke with a bad hand, object, task or world file is a
:class:`PrehensionError`; its message names the offending item and says what would
have been valid.  Code that calls prehension can catch the root class; the CLI turns
it into a one-line message and the "bad input" exit code.
"""

from __future__ import annotations

from pathlib import Path

__all__ = [
    "PrehensionError",
    "InvalidGeometry",
    "DegeneratePatch",
    "InvalidHand",
    "SamplingError",
    "InvalidObject",
    "InvalidTask",
    "InvalidConfiguration",
    "WorldFileError",
    "not_a_file",
]


class PrehensionError(ValueError):
    """Root of every error caused by invalid input to prehension."""


class InvalidGeometry(PrehensionError):
    """A geometric value (patch, region, vector, frame) is malformed."""


class DegeneratePatch(InvalidGeometry):
    """A Bézier patch whose normal p_u x p_v vanishes somewhere on [0, 1]^2."""


class InvalidHand(PrehensionError):
    """A hand model is inconsistent (unknown link, bad joint, bad coupling...)."""


class SamplingError(InvalidHand):
    """A random draw a hand cannot give: e.g. joint vectors free of self-collision that
    almost never occur; the message names the hand and what was tried."""


class InvalidObject(PrehensionError):
    """An object model is inconsistent (unknown region, bad mesh...)."""


class InvalidTask(PrehensionError):
    """A task (or task file) is inconsistent or malformed."""


class InvalidConfiguration(PrehensionError):
    """A configuration (joint angles, object pose, contact parameters) has the wrong shape."""


class WorldFileError(PrehensionError):
    """A CuikSuite ``.world`` file cannot be read; the message names file and line."""

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None):
        where = ""
        if path is not None:
            where = f"{path}:"
            if line is not None:
                where += f"{line}:"
            where += " "
        elif line is not None:
            where = f"line {line}: "
        super().__init__(where + message)
        self.path = path
        self.line = line


def not_a_file(what: str, path) -> str:
    """The message for a ``path`` that should be a file (``what``: "mesh file", "result
    file"...) and is not: a folder or a special file is said to be one, else "not found"."""
    path = Path(path)
    if path.is_dir():
        return f"{what} {path} is a folder, not a file; give the file inside it"
    if path.exists():
        return f"{what} {path} is not a regular file (a named pipe, socket or device); give a regular file"
    return f"{what} not found: {path}"
