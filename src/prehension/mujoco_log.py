"""MuJoCo, imported with its warnings sent to prehension's log instead of stdout.

MuJoCo's default warning handler prints each warning on stdout and appends it to a file
``MUJOCO_LOG.TXT`` in the working directory: third-party text inside prehension's own
output (a table, a ``--json`` answer) and a file left in the user's folder.
:func:`import_mujoco` imports the module and, once per process, installs a handler that sends
each warning to the ``prehension.mujoco`` logger (level WARNING) instead -- unless the
program has installed its own handler, which is then left as it is.

The text is for people.  What a warning means for a verdict (a simulation that went
unstable) is read from ``mjData.warning``'s counters by the code that steps the model
(:mod:`prehension.sim.run`).
"""

from __future__ import annotations

import logging

__all__ = ["import_mujoco", "LOGGER_NAME"]

LOGGER_NAME = "prehension.mujoco"
_LOG = logging.getLogger(LOGGER_NAME)
_installed = False


def _to_log(message: str) -> None:
    _LOG.warning("MuJoCo: %s", message.strip())


def import_mujoco():
    """The ``mujoco`` module with its warnings going to the ``prehension.mujoco`` logger
    (module docstring); raises :class:`ImportError` when MuJoCo is not installed."""
    global _installed
    import mujoco

    if not _installed:
        if mujoco.get_mju_user_warning() is None:
            mujoco.set_mju_user_warning(_to_log)
        _installed = True
    return mujoco
