"""The ahead-of-time compiled entry points (prehension.kernels.aot, _aot_build, kernels.manifest).

What the JIT sees at the Python call sites must be what the signatures module records (so the
install-time build compiles the functions that run); every Python call of a compiled function
goes through ``aot()``; the extension, when installed and fresh, gives the JIT's answers bit for
bit; a missing or stale extension falls back to the JIT; the CLI announces a compilation only
when one will happen.
"""

from __future__ import annotations

import cProfile
import importlib
import pstats
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import prehension.kernels.aot as C
from prehension.kernels.manifest import ENTRY_POINTS, SIGNATURES, SOURCES
from prehension.solvers.local import random_point_problems, solve_local, solve_local_batch
from prehension.solvers.local import _kernel as K
from prehension.kernels.jit import HAVE_NUMBA
from prehension.tasks.library import builtin_task_names, load_builtin_task

ROOT = Path(__file__).resolve().parents[1]
needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason="numba is not installed: nothing is compiled")
needs_aot = pytest.mark.skipif(not C.aot_available(), reason="no fresh ahead-of-time extension installed")


@pytest.fixture
def jit_only():
    previous = C.use_aot(False)
    yield
    C.use_aot(previous)


def _workload():
    task = load_builtin_task("teapot-lid-lifting")
    solve_local(task)
    solve_local_batch(random_point_problems(3, seed=2))
    task.object.distance.signed_distance(np.zeros((2, 3)))
    from prehension.hands.collision import capsule_clearances
    from prehension.hands.kinematics import forward_kinematics

    capsule_clearances(task.hand, forward_kinematics(task.hand, np.zeros(task.hand.n_dof)))


@needs_numba
def test_the_call_sites_pass_what_the_signatures_module_records(monkeypatch):
    """Every compiled function Python calls is an entry point, called through aot(), with the
    argument types recorded for the ahead-of-time build (else: python scripts/aot_signatures.py)."""
    from numba import typeof

    from prehension._aot_build import signatures

    seen: dict[str, set] = {}
    choose = C._choose

    def recording(function):
        chosen, py = choose(function), getattr(function, "py_func", function)
        key = f"{py.__module__}:{py.__qualname__}"

        def call(*args):
            seen.setdefault(key, set()).add(tuple(typeof(a) for a in args))
            return chosen(*args)

        return call

    monkeypatch.setattr(C, "_choose", recording)
    monkeypatch.setattr(C, "_CHOSEN", {})
    profile = cProfile.Profile()
    profile.enable()
    _workload()
    profile.disable()
    direct = {C.loaded_dispatchers().get(frame, (None,))[0] for frame in pstats.Stats(profile).stats} - {None}
    expected = signatures()
    assert set(ENTRY_POINTS) == set(expected) == set(SIGNATURES)
    assert direct <= set(seen), f"compiled functions called from Python without aot(): {direct - set(seen)}"
    assert set(seen) <= set(ENTRY_POINTS), f"not in the signatures module: {set(seen) - set(ENTRY_POINTS)}"
    for key, types in seen.items():
        assert types == {tuple(expected[key].args)}, f"{key}: the call sites pass {types}, recorded {expected[key].args}"


def test_the_sources_list_is_what_the_build_imports():
    """SOURCES (hashed into the extension) names every file the kernels' modules import."""
    code = (
        "import sys, runpy; ns = runpy.run_path(sys.argv[1]); ns['load_kernel_modules'](); "
        "print('\\n'.join(m.__file__ for n, m in list(sys.modules.items()) "
        "if n.startswith('prehension.') and getattr(m, '__file__', None)))"
    )
    build = ROOT / "src" / "prehension" / "_aot_build.py"
    if not build.exists():
        pytest.skip("not a source checkout")
    out = subprocess.run([sys.executable, "-c", code, str(build)], capture_output=True, text=True, check=True).stdout
    package = build.parent
    imported = {Path(f).resolve().relative_to(package).as_posix() for f in out.split()}
    assert imported - {"kernels/aot.py"} | {"kernels/manifest.py"} == set(SOURCES)  # kernels.aot chooses, is not compiled


def test_the_manifest_is_data_only():
    """The manifest imports nothing (its signatures are plain names: the build makes the numba
    types), and every array it records is what the run-time check reads."""
    import ast

    tree = ast.parse((ROOT / "src" / "prehension" / "kernels" / "manifest.py").read_text())
    imports = [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom)) and n.module != "__future__"]
    assert not imports and not [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
    fk = C.array_arguments(SIGNATURES["prehension.kernels.chain:pose_chains"][1])
    assert fk[0] == ((0,), "float64", 2) and ((1, 0), "int64", 1) in fk  # q, then the joint tables' parent


def test_a_missing_extension_falls_back_to_the_jit(monkeypatch):
    def missing(name):
        raise ImportError(name)

    C._module.cache_clear()
    monkeypatch.setattr(importlib, "import_module", missing)
    monkeypatch.setattr(C, "_CHOSEN", {})
    try:
        assert not C.aot_available()
        assert C.aot(K.run_states) is K.run_states
    finally:
        monkeypatch.undo()
        C._module.cache_clear()


def test_a_stale_extension_falls_back_to_the_jit(monkeypatch):
    """An edited checkout (sources no longer hashing to the extension's marker) never runs it."""
    C._module.cache_clear()
    monkeypatch.setattr(C, "source_hash", lambda: "0" * 24)
    monkeypatch.setattr(C, "_CHOSEN", {})
    try:
        assert not C.aot_available()
        assert C.aot(K.run_states) is K.run_states
        from prehension.solvers.local.warmup import compile_pending

        compile_pending()  # says what numba's cache says, not "nothing to compile"
    finally:
        monkeypatch.undo()
        C._module.cache_clear()


@needs_aot
def test_a_fresh_extension_serves_every_entry_point_and_nothing_compiles():
    from prehension.solvers.local.warmup import compile_pending

    module = C._module()
    for key in ENTRY_POINTS:
        assert hasattr(module, C.export_name(key)), key
    assert C.aot(K.run_states) is not K.run_states
    assert not compile_pending()  # no COMPILING_MESSAGE: nothing will compile


@needs_aot
def test_a_call_off_the_compiled_signature_goes_to_the_jit_not_misread():
    from prehension.hands.kinematics import forward_kinematics, joint_tables
    from prehension.kernels.chain import pose_chains
    from prehension.hands.sa_hand import schunk_sa_hand

    hand = schunk_sa_hand()
    q = np.random.default_rng(0).uniform(-0.5, 0.5, (2, hand.n_dof))
    checked = C.aot(pose_chains)
    R, r = np.zeros((2, len(hand.links), 3, 3)), np.zeros((2, len(hand.links), 3))
    axis, origin = np.zeros((2, hand.n_dof, 3)), np.zeros((2, hand.n_dof, 3))
    assert checked.mismatch((q, joint_tables(hand), R, r, axis, origin)) is None
    assert "argument 0 is not a writable C-contiguous 2-d float64 array: float64 2-d" in checked.mismatch(
        (np.asfortranarray(q), joint_tables(hand), R, r, axis, origin))
    assert "int64 2-d" in checked.mismatch((q.astype(np.int64), joint_tables(hand), R, r, axis, origin))
    frozen = q.copy()
    frozen.flags.writeable = False  # another numba type: the JIT serves it
    a, b = forward_kinematics(hand, q), forward_kinematics(hand, frozen)
    assert np.array_equal(a.R_palm_link, b.R_palm_link) and np.array_equal(a.r_palm_link, b.r_palm_link)


def _answers():
    out = []
    for name in builtin_task_names():
        result = solve_local(load_builtin_task(name))
        out.append((name, str(result.status), [(dict(s.joint_angles), s.T_palm_object.tobytes()) for s in result.solutions]))
    batch = solve_local_batch(random_point_problems(30, seed=3))
    for record in batch.records:
        out.append({k: (v.tobytes() if isinstance(v, np.ndarray) else v) for k, v in vars(record).items()
                    if isinstance(v, (np.ndarray, int, str)) or (isinstance(v, float) and k != "seconds")})  # fmt: skip
    return out


@needs_aot
@pytest.mark.slow  # compiles every kernel by JIT (~70 s with an empty numba cache)
def test_the_extension_gives_the_jits_answers_bit_for_bit():
    """Built for the installing machine's CPU (PREHENSION_AOT_CPU=host), the extension computes
    what the JIT computes, to the bit: the nine built-ins and 30 random point problems."""
    ahead = _answers()
    previous = C.use_aot(False)
    try:
        jit = _answers()
    finally:
        C.use_aot(previous)
    assert ahead == jit
