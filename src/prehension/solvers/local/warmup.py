"""First run: whether the compiled kernel is on disk yet, and compiling it once, visibly.

numba compiles the kernel on its first call and keeps the machine code in its cache
(``__pycache__`` beside the sources, or ``NUMBA_CACHE_DIR``); later processes load it in
well under a second.  :func:`compile_pending` tells a caller (the CLI) that the next local
solve will compile, so that it can say so before the wait; :func:`warm_up` compiles (or
loads) everything the local solver runs and returns how long that took.
"""

from __future__ import annotations

import time

__all__ = ["compile_pending", "warm_up", "COMPILING_MESSAGE"]

#: What a front end prints before a first, compiling run (measured for the README's first
#: command with an empty cache: 71-93 s of CPU on the 2-core development machine, 72.5 s of
#: wall time at load ~3 and several minutes under heavy load;
#: ``benchmarks/first_run.py``, docs/local-solver.md).
COMPILING_MESSAGE = "compiling the local solver once (one to two minutes); later runs start at once"


def _entry_points():
    """The compiled functions every local solve runs (the kernel's entry): a solve may not
    reach others (e.g. ``hands._capsules._max_depths`` serves point problems only), so
    their missing cache must not announce a compilation that will not happen."""
    from . import _kernel

    return (_kernel.run_states,)


def compile_pending() -> bool:
    """True when the next solve compiles: no fresh ahead-of-time kernels are installed
    (:mod:`prehension.kernels.aot`) and no usable compiled kernel is cached on disk."""
    from ...kernels.aot import aot_available
    from ...kernels.jit import HAVE_NUMBA

    if not HAVE_NUMBA or aot_available():  # the installed ahead-of-time kernels run at once
        return False
    try:
        for dispatcher in _entry_points():
            if dispatcher.signatures:  # already compiled or loaded in this process
                continue
            cache = getattr(dispatcher, "_cache", None)
            if cache is None or not cache._cache_file._load_index():  # missing or stale
                return True
    except Exception:  # numba's cache internals changed: say nothing rather than guess
        return False
    return False


def warm_up() -> float:
    """Compile (first run) or load (later runs) the local solver's kernel by solving one
    small problem; the seconds it took."""
    from .problems import random_point_problems
    from .solver import solve_local_batch

    t0 = time.perf_counter()
    solve_local_batch(random_point_problems(1, seed=0))
    return time.perf_counter() - t0
