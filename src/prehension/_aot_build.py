"""Build-time only: compile the entry points ahead of time into ``prehension._aot`` (numba pycc).

``setup.py`` loads this file by path (the package is not installed yet, and pip builds in an
isolated environment holding only ``[build-system] requires``) and calls :func:`extension`,
which returns numba's setuptools ``Extension`` for the module.  It imports the kernels'
modules without running the package ``__init__`` files (:func:`load_kernel_modules`), so
the build needs numpy, numba, scipy and PyYAML only -- not the whole library.

What is compiled: every entry point of the manifest (:mod:`prehension.kernels.manifest`,
data only), for its one recorded signature (:func:`signatures` turns the manifest's entries
into numba types), plus a marker function ``source_<hash>`` naming the hash of the
sources it was built from (:func:`prehension.kernels.aot.source_hash`), which the run time
compares before using the module.  Compiling takes about as long as the JIT's first run
(one to two minutes of CPU), once, at install.

Run by hand (``python src/prehension/_aot_build.py [OUTDIR]``) it builds the module into
OUTDIR (default: beside this file) without setuptools.
"""

from __future__ import annotations

import importlib
import os
import sys
import types
from pathlib import Path

__all__ = ["load_kernel_modules", "signatures", "make_cc", "extension"]

PACKAGE_DIR = Path(__file__).resolve().parent
BASENAME = "_aot"


def load_kernel_modules(modules: tuple[str, ...] | None = None) -> None:
    """Make ``prehension.*`` importable from this source tree without executing any package's
    ``__init__`` (each package becomes an empty module with its ``__path__``), then import
    every entry point's module (or ``modules``).  Does nothing to packages already imported."""
    if "prehension" not in sys.modules:
        for init in sorted(PACKAGE_DIR.rglob("__init__.py")):
            parts = init.parent.relative_to(PACKAGE_DIR.parent).parts
            package = types.ModuleType(".".join(parts))
            package.__path__ = [str(init.parent)]
            package.__file__ = None
            sys.modules[package.__name__] = package
    if modules is None:
        from prehension.kernels.manifest import ENTRY_POINTS

        modules = tuple(key.split(":")[0] for key in ENTRY_POINTS)
    for module in modules:
        importlib.import_module(module)


def numba_type(spec):
    """A manifest's type entry (data, :data:`prehension.kernels.manifest.SIGNATURES`) -> the numba type."""
    import numpy as np
    from numba import from_dtype
    from numba.core import types

    if spec == "none":
        return types.none
    if isinstance(spec, str):
        return from_dtype(np.dtype(spec))
    if spec[0] == "array":
        return types.Array(from_dtype(np.dtype(spec[1])), spec[2], "C")
    if spec[0] == "namedtuple":
        module, name = spec[1].split(":")
        return types.NamedTuple([numba_type(x) for x in spec[2]], getattr(importlib.import_module(module), name))
    return types.Tuple([numba_type(x) for x in spec[1]])


def signatures() -> dict:
    """Entry point -> numba signature, from the manifest (imports numba and the kernels' modules)."""
    from prehension.kernels.manifest import SIGNATURES

    load_kernel_modules()
    out = {}
    for key, (result, arguments) in SIGNATURES.items():
        out[key] = numba_type(result)(*(numba_type(a) for a in arguments))
    return out


def _stamp():
    return 0


def make_cc(output_dir: str | Path | None = None):
    """numba's ``CC`` for ``prehension._aot``, every entry point exported."""
    from numba.pycc import CC

    load_kernel_modules()
    from prehension.kernels.aot import STAMP_PREFIX, export_name, source_hash

    source = types.ModuleType("prehension._aot_build")  # names the extension prehension._aot
    source.__file__ = str(PACKAGE_DIR / "_aot_build.py")
    cc = CC(BASENAME, source_module=source)
    cc.output_dir = str(output_dir or PACKAGE_DIR)
    cc.target_cpu = os.environ.get("PREHENSION_AOT_CPU", "host")
    for key, sig in signatures().items():
        module, function = key.split(":")
        dispatcher = getattr(sys.modules[module], function)
        cc.export(export_name(key), sig)(getattr(dispatcher, "py_func", dispatcher))
    cc.export(STAMP_PREFIX + source_hash(), "int64()")(_stamp)
    return cc


def extension():
    """The setuptools ``Extension`` (optional: a failed C build leaves the JIT in charge)."""
    return make_cc().distutils_extension(optional=True)


if __name__ == "__main__":
    make_cc(sys.argv[1] if len(sys.argv) > 1 else None).compile()
