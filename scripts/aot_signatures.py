"""Regenerate ``src/prehension/kernels/manifest.py``: the compiled entry points and their types.

    python scripts/aot_signatures.py          # rewrite the file (runs the JIT: minutes on an empty cache)
    python scripts/aot_signatures.py --check  # exit 1 when the committed file is out of date

An *entry point* is a compiled (numba) function that Python code calls directly; the
ahead-of-time build (:mod:`prehension._aot_build`) compiles exactly these, for exactly the
signature recorded here, so that it needs no JIT run of its own.  This script finds them by
running the README's first command, ``check`` on its result, a local batch of point problems
and ``solve_local`` on every built-in task under cProfile (numba reports a call from Python
as a call of the function's Python code object; calls between compiled functions are not
seen), and reads each one's compiled signature (one per function:
``test_the_kernel_compiles_each_function_for_one_signature``).  It also records every
``prehension`` source file the compiled code is built from (``SOURCES``): their hash is
what an installed extension is checked against before it is used.

The manifest is data only: each signature is written as nested tuples of plain names
(:func:`type_spec`), which the build (:func:`prehension._aot_build.signatures`) turns back
into numba types.  ``tests/test_aot.py`` checks that the file still matches what the JIT sees.
"""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import io
import os
import pstats
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET = ROOT / "src" / "prehension" / "kernels" / "manifest.py"


def run_workloads() -> cProfile.Profile:
    """Everything the entry points are collected from, profiled."""
    from prehension.cli import main
    from prehension.solvers.local import random_point_problems, solve_local, solve_local_batch
    from prehension.tasks.library import builtin_task_names, load_builtin_task

    profile = cProfile.Profile()
    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()), \
            contextlib.redirect_stderr(io.StringIO()):  # fmt: skip
        result = os.path.join(tmp, "r.json")
        profile.enable()
        for argv in (["solve", "teapot-lid-lifting", "--html", os.path.join(tmp, "g.html"), "-o", result],
                     ["check", result]):  # fmt: skip
            with contextlib.suppress(SystemExit):
                main(argv)
        solve_local_batch(random_point_problems(20, seed=1))
        for name in builtin_task_names():
            solve_local(load_builtin_task(name))
        profile.disable()
    return profile


def entry_points(profile: cProfile.Profile) -> dict:
    """key -> numba signature (return type included) of every entry point called."""
    from prehension.kernels.aot import loaded_dispatchers

    known = loaded_dispatchers()
    entries = {}
    for frame in pstats.Stats(profile).stats:
        if frame in known:
            key, dispatcher = known[frame]
            if len(dispatcher.overloads) != 1:
                raise SystemExit(f"{key} has {len(dispatcher.overloads)} signatures; an entry point needs one")
            (cres,) = dispatcher.overloads.values()
            entries[key] = cres.signature
    return dict(sorted(entries.items()))


def type_spec(t):
    """numba type -> its manifest entry (data): ``"float64"``, ``"int64"``, ``"bool"``,
    ``"none"``; ``("array", dtype, ndim)`` for a writable C-contiguous array;
    ``("namedtuple", "module:Class", (fields...))``; ``("tuple", (items...))``."""
    from numba.core import types

    if isinstance(t, types.Array):
        if t.layout != "C" or not t.mutable:
            raise SystemExit(f"an argument is {t}: entry points take writable C-contiguous arrays")
        return ("array", str(t.dtype), t.ndim)
    if isinstance(t, types.BaseNamedTuple):
        cls = t.instance_class
        return ("namedtuple", f"{cls.__module__}:{cls.__qualname__}", tuple(type_spec(x) for x in t.types))
    if isinstance(t, types.BaseTuple):
        return ("tuple", tuple(type_spec(x) for x in t.types))
    if isinstance(t, types.NoneType):
        return "none"
    if isinstance(t, (types.Boolean, types.Integer, types.Float)):
        return str(t)
    raise SystemExit(f"no manifest entry for the numba type {t!r}: extend scripts/aot_signatures.py")


def sources(entries: dict) -> tuple[str, ...]:
    """Every prehension module the entry points' import pulls in (as the build imports them:
    :func:`prehension._aot_build.load_kernel_modules`), relative to the package."""
    import subprocess

    code = (
        "import sys, runpy; ns = runpy.run_path(sys.argv[1]); "
        "ns['load_kernel_modules'](tuple(sys.argv[2:])); "
        "print('\\n'.join(m.__file__ for n, m in list(sys.modules.items()) "
        "if n.startswith('prehension.') and getattr(m, '__file__', None)))"
    )
    build = ROOT / "src" / "prehension" / "_aot_build.py"
    out = subprocess.run([sys.executable, "-c", code, str(build), *{k.split(":")[0] for k in entries}], capture_output=True, text=True,
                         check=True).stdout  # fmt: skip
    pkg = ROOT / "src" / "prehension"
    files = {Path(f).resolve().relative_to(pkg).as_posix() for f in out.split()}
    return tuple(sorted(files - {"kernels/aot.py"} | {"kernels/manifest.py"}))  # kernels.aot chooses, is not compiled


def render(entries: dict, files: tuple[str, ...]) -> str:
    def signature(key, sig) -> list[str]:
        args = [f"            {type_spec(a)!r}," for a in sig.args]
        return [f'    "{key}": (', f"        {type_spec(sig.return_type)!r},", "        (", *args, "        ),", "    ),"]

    return "\n".join([
        '"""GENERATED by ``scripts/aot_signatures.py`` -- do not edit; ``tests/test_aot.py`` checks it.',
        "",
        "The ahead-of-time build's manifest, data only: the compiled functions Python calls (entry",
        "points), each with the one signature the JIT gives it (``SIGNATURES``: return type and",
        "argument types, as ``scripts/aot_signatures.py``'s ``type_spec`` writes them; the build,",
        ":mod:`prehension._aot_build`, turns them into numba types); ``SOURCES``: the package's",
        "files (relative paths) whose hash an installed extension must match to be used.",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        '__all__ = ["ENTRY_POINTS", "SIGNATURES", "SOURCES"]',
        "",
        "ENTRY_POINTS = (",
        *[f'    "{key}",' for key in entries],
        ")",
        "",
        "SIGNATURES = {",
        *[line for key, sig in entries.items() for line in signature(key, sig)],
        "}",
        "",
        "SOURCES = (",
        *[f'    "{f}",' for f in files],
        ")",
        "",
    ])  # fmt: skip


def current() -> str:
    entries = entry_points(run_workloads())
    return render(entries, sources(entries))


def main() -> None:
    os.environ["PREHENSION_AOT"] = "0"  # the JIT's signatures: the installed extension must not serve the calls
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare with the committed file instead of writing")
    args = parser.parse_args()
    text = current()
    if args.check:
        same = TARGET.read_text() == text
        print("up to date" if same else f"{TARGET} is out of date: run python scripts/aot_signatures.py")
        raise SystemExit(0 if same else 1)
    TARGET.write_text(text)
    print(f"wrote {TARGET}")


if __name__ == "__main__":
    main()
