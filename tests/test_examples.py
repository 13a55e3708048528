"""The result files shipped in examples/ re-check: a change that alters what a result file
claims (quality, pre-grasp, collision geometry, ...) must regenerate them
(``python examples/quality/box_grasps.py``), or the README's ``simulate``/``render``
examples on them refuse to run."""

from pathlib import Path

import pytest

from prehension.verification import verify_result_file

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RESULTS = sorted(EXAMPLES.rglob("*.result.json"))


def test_there_are_example_results():
    assert RESULTS


@pytest.mark.parametrize("path", RESULTS, ids=[p.name for p in RESULTS])
def test_an_example_result_holds(path):
    checked = verify_result_file(path, physics=False)
    assert checked.holds, [f"{f.what}: {f.detail}" for f in checked.failures]
