"""``njit`` for every compiled module of the package: numba's when installed, else a no-op.

The one fallback shim: without numba the same code runs as (slow) Python.  Every compiled
function is cached on disk (``cache=True``), so a process after the first loads machine
code instead of compiling it; :func:`prehension.solvers.local.warm_up` compiles (or loads)
the local solver's kernel at once and says how long it took.

One signature per function: numba types a constant argument (``0``, ``True``, a module
constant such as ``BEST``) as a *literal* and compiles a specialisation of the callee -- and
of everything it calls -- for each value, so the first run pays for every variant.  Calls
between compiled functions therefore pass constants as ``np.int64(0)`` / ``np.bool_(True)``
(typed ``int64`` / ``bool``), and Python callers pass writable C-contiguous arrays (a
read-only array is another type).  ``test_the_kernel_compiles_each_function_for_one_signature``
keeps it so.
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
