"""setuptools hook for the one thing pyproject.toml cannot say: the ahead-of-time compiled kernels.

``pip install`` (and ``pip install -e .``) compiles the compiled entry points into the
extension module ``prehension._aot`` (:mod:`prehension._aot_build`, numba's pycc; about 20 s
of CPU, a C compiler needed), so that a fresh install's first solve does not spend one to
two minutes in numba's JIT.  The extension is optional: without a C compiler, without numba
in the build environment, or with ``PREHENSION_NO_AOT=1``, the install goes on without it and
the kernels are compiled by the JIT on first use, as before.  ``PREHENSION_AOT_CPU`` names
LLVM's target CPU (default ``host``: the machine that installs; ``generic`` for a binary to
copy elsewhere, whose answers then differ from the JIT's by rounding).
"""

import importlib.util
import os
import sys
from pathlib import Path

from setuptools import setup


def aot_extensions() -> list:
    if os.environ.get("PREHENSION_NO_AOT", "0") not in ("", "0"):
        return []
    path = Path(__file__).resolve().parent / "src" / "prehension" / "_aot_build.py"
    spec = importlib.util.spec_from_file_location("prehension_aot_build", path)
    try:
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return [module.extension()]
    except Exception as exc:  # no numba or numpy here: the JIT compiles on first use instead
        print(f"prehension: ahead-of-time kernels not built ({type(exc).__name__}: {exc}); "
              "numba compiles them on first use", file=sys.stderr)  # fmt: skip
        return []


setup(ext_modules=aot_extensions())
