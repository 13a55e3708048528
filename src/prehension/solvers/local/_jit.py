"""``njit`` for the local solver's compiled modules: numba's when installed, else a no-op.

Every compiled function is cached on disk (``cache=True``), so a process after the first
loads machine code instead of compiling it; :func:`prehension.solvers.local.warm_up`
compiles (or loads) everything at once and says how long it took.
"""

from __future__ import annotations

try:  # numba is a dependency; without it the same code runs as (slow) Python.
    from numba import njit

    HAVE_NUMBA = True
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False

    def njit(*args, **kwargs):
        if len(args) == 1 and callable(args[0]) and not kwargs:
            return args[0]
        return lambda f: f


__all__ = ["njit", "HAVE_NUMBA"]
