"""The first run: numba's compilation of the README's first command, and what it costs later.

    python benchmarks/first_run.py                  # numba's default optimisation level
    python benchmarks/first_run.py --opt 3 1 0      # one row per NUMBA_OPT level
    python benchmarks/first_run.py --kernels aot jit  # the installed ahead-of-time kernels, then the JIT

``--kernels aot`` (the default) uses the ahead-of-time compiled kernels when a fresh
extension is installed (``prehension.kernels.aot``; the row says whether it was), ``jit``
forces numba's JIT (``PREHENSION_AOT=0``) -- the first run of an install without them.

Each row runs in a fresh process with an EMPTY numba cache (a temporary ``NUMBA_CACHE_DIR``;
nobody else's cache is touched), BLAS pinned to one thread:

* ``first run``: ``prehension solve teapot-lid-lifting`` in-process (``cli.main``), CPU
  seconds of the process (``time.process_time``, imports included) and wall seconds --
  everything it compiles (the task's distance functions, the local solver's kernel, the
  verification) is compiled here;
* then, with everything compiled: the median CPU time of one ``solve_local`` call over 100
  SA-hand point problems (``random_point_problems(100, seed=0)``), of one batch of 1000
  (``solve_local_batch``, per problem) and of ``solve_local(teapot-lid-lifting)`` (5 calls:
  the kernel with the object's penetration rows).

CPU times are the better guide on a shared machine (wall times there grow with the load);
compare rows of one run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

_CHILD = r"""
import contextlib, io, json, os, sys, time
import numpy as np
c0, w0 = time.process_time(), time.perf_counter()
from prehension.cli import main
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        code = main(["solve", "teapot-lid-lifting", "-o", os.path.join(sys.argv[1], "r.json")])
    except SystemExit as exc:
        code = exc.code
first_cpu, first_wall = time.process_time() - c0, time.perf_counter() - w0
from prehension.hands.sa_hand import schunk_sa_hand
from prehension.solvers.local import random_point_problems, solve_local, solve_local_batch
from prehension.tasks.library import load_builtin_task
p = random_point_problems(100, schunk_sa_hand(), seed=0)
tasks = [p.task(i) for i in range(100)]
solve_local(tasks[0])
ts = []
for t in tasks:
    a = time.process_time(); solve_local(t); ts.append(time.process_time() - a)
pb = random_point_problems(1000, schunk_sa_hand(), seed=1)
a = time.process_time(); solve_local_batch(pb); batch = time.process_time() - a
task = load_builtin_task("teapot-lid-lifting")
solve_local(task)
tt = []
for _ in range(5):
    a = time.process_time(); solve_local(task); tt.append(time.process_time() - a)
from prehension.kernels.aot import aot_available
print(json.dumps(dict(aot=aot_available(), exit=code, first_cpu=first_cpu, first_wall=first_wall, single_ms=1e3 * float(np.median(ts)),
                      batch_ms=batch, teapot_ms=1e3 * float(np.median(tt)))))
"""


def measure(opt: str | None, kernels: str = "aot") -> dict:
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
               "MKL_NUM_THREADS": "1"}  # fmt: skip
        env.pop("NUMBA_OPT", None)
        env["PREHENSION_AOT"] = "0" if kernels == "jit" else "1"
        if opt is not None:
            env["NUMBA_OPT"] = opt
        proc = subprocess.run([sys.executable, "-c", _CHILD, cache], capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise SystemExit(f"the measurement failed (NUMBA_OPT={opt}):\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--opt", nargs="*", default=[None], help="NUMBA_OPT levels, one row each (default: numba's)")
    parser.add_argument("--kernels", nargs="*", default=["aot"], choices=["aot", "jit"],
                        help="aot: the installed ahead-of-time kernels (when fresh), jit: numba's JIT; one row each")
    args = parser.parse_args()
    print("| kernels | NUMBA_OPT | exit | first run CPU s | first run wall s | solve_local ms (median) | batch ms/problem | teapot solve_local ms |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for kernels in args.kernels:
        for opt in args.opt:
            r = measure(opt, kernels)
            label = "ahead of time" if r["aot"] else ("JIT" if kernels == "jit" else "JIT (no fresh extension)")
            print(f"| {label} | {opt or 'default (3)'} | {r['exit']} | {r['first_cpu']:.1f} | {r['first_wall']:.1f} | {r['single_ms']:.2f} "
                  f"| {r['batch_ms']:.3f} | {r['teapot_ms']:.1f} |", flush=True)


if __name__ == "__main__":
    main()
