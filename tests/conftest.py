"""Shared fixtures: the built-in SA hand, seeded random generators, shared data paths."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

SHARED = Path(__file__).resolve().parents[2] / "shared"
SLOW_ENV = "PREHENSION_SLOW_TESTS"  # "1": run the tests marked slow too (CI does: .ci/run)


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` (the long property tests: many seeded cases, frontier searches,
    the JIT-against-extension comparison) are skipped unless ``PREHENSION_SLOW_TESTS=1``;
    CI sets it, so they always run there.  ``-m slow`` runs only them (with the variable)."""
    import os

    if os.environ.get(SLOW_ENV, "").strip() in ("1", "true", "yes"):
        return
    skip = pytest.mark.skip(reason=f"slow: set {SLOW_ENV}=1 to run it (CI does)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
CUIK_DIR = SHARED / "cuik-ijrr"
HANDS_DIR = SHARED / "hands"


@pytest.fixture(scope="session", autouse=True)
def _own_geometry_cache(tmp_path_factory):
    """The suite's own on-disk geometry cache (``PREHENSION_CACHE_DIR``), inherited by the
    command-line runs it starts: a run never reads or fills the user's ``~/.cache``."""
    import os

    from prehension.objects.geometry_cache import CACHE_ENV

    before = os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("geometry-cache"))
    yield
    if before is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = before


@pytest.fixture
def default_signals():
    """SIGINT, SIGTERM and SIGHUP at Python's defaults for one test, as a terminal gives
    them: a runner started in the background or under ``nohup`` hands the suite SIGINT
    and SIGHUP ignored, and prehension rightly keeps an ignored signal ignored
    (``cli/terminate.py``), so tests that send them need their defaults.  Restored after."""
    import signal

    defaults = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL,
                signal.SIGHUP: signal.SIG_DFL}  # fmt: skip
    before = {sig: signal.signal(sig, handler) for sig, handler in defaults.items()}
    yield
    for sig, handler in before.items():
        signal.signal(sig, handler)


@pytest.fixture(scope="session")
def sa_hand():
    from prehension.hands.sa_hand import schunk_sa_hand

    return schunk_sa_hand()


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def random_angles(hand, rng, n):
    """Random joint angles within the limits that satisfy the couplings, (n, n_dof)."""
    q = rng.uniform(hand.lower, hand.upper, size=(n, hand.n_dof))
    for c in hand.couplings:
        q[:, hand.dof_index(c.dof)] = c.ratio * q[:, hand.dof_index(c.source)] + c.offset
    return q


def cuik_worlds():
    """The six shared world files (empty when shared/ is absent)."""
    return sorted(CUIK_DIR.glob("*/*/*.world")) if CUIK_DIR.is_dir() else []


requires_cuik = pytest.mark.skipif(not CUIK_DIR.is_dir(), reason="shared/cuik-ijrr not present beside the checkout")


@pytest.fixture(scope="module")
def client():
    """A local Dask cluster of two worker processes, shared by a test module's tests."""
    from prehension.parallel import cluster

    with cluster(workers=2) as c:
        yield c


def write_jsonl(path, lines) -> str:
    """Write ``lines`` (JSON values) to ``path``, one per line; returns the path as text."""
    path.write_text("".join(json.dumps(line) + "\n" for line in lines))
    return str(path)


def _box_grasps():
    """``examples/quality/box_grasps.py`` (the four-finger and the one-face grasps of a box), loaded once."""
    import importlib.util
    import sys

    if "box_grasps" not in sys.modules:
        spec = importlib.util.spec_from_file_location("box_grasps", Path(__file__).resolve().parents[1] / "examples" / "quality" / "box_grasps.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        sys.modules["box_grasps"] = module
    return sys.modules["box_grasps"]


@pytest.fixture(scope="module")
def four():
    """``(task, grasp)``: three fingertips on one face of a box, the thumb on the other (force closure)."""
    return _box_grasps().four_finger_grasp()


@pytest.fixture(scope="module")
def one_face():
    """``(task, grasp)``: three fingertips on one face of a box (not force closure)."""
    return _box_grasps().one_face_grasp()
