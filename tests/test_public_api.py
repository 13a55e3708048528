"""Every name the package exports exists; the first-grasp example of the README runs."""

from __future__ import annotations

import prehension


def test_all_names_exist():
    for name in prehension.__all__:
        assert hasattr(prehension, name), name
    assert len(set(prehension.__all__)) == len(prehension.__all__)


def test_forward_kinematics_and_residuals_through_the_public_api():
    import numpy as np

    task = prehension.load_builtin_task("teapot-lid-lifting")
    q = np.clip(np.zeros(task.hand.n_dof), task.hand.lower, task.hand.upper)
    report = prehension.evaluate(task, prehension.Configuration(q, np.eye(4)))
    assert not report.ok  # the teapot at the palm origin is not grasped
    assert report.worst("contact_distance") > 10.0
    assert report.worst("joint_limit") == 0.0 and report.worst("coupling") == 0.0


def test_readme_python_example_runs(capsys, tmp_path, monkeypatch):
    import json
    import re
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    assert blocks, "the README has a Python example"
    monkeypatch.chdir(tmp_path)  # the example writes a result file
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert out.startswith("solved") and "holds: True" in out and out.rstrip().endswith("infeasible")
    assert json.loads((tmp_path / "lid.result.json").read_text())["status"] == "solved"


def test_tasks_pickle_for_worker_processes():
    import pickle

    import numpy as np

    task = prehension.load_builtin_task("teapot-service")
    again = pickle.loads(pickle.dumps(task))
    assert prehension.dumps_task(again) == prehension.dumps_task(task)
    q = np.clip(np.zeros(task.hand.n_dof), task.hand.lower, task.hand.upper)
    np.testing.assert_array_equal(
        prehension.forward_kinematics(again.hand, q).T_palm_link, prehension.forward_kinematics(task.hand, q).T_palm_link
    )
    with __import__("pytest").raises(TypeError):
        task.hand.regions["x"] = None  # still read-only


def test_importing_the_command_line_leaves_the_heavy_parts_for_later():
    """``import prehension.cli`` (what every command pays) imports no mesh library, no
    scipy.spatial / scipy.optimize, no quality measures, viewer or cluster code: the
    public names are imported on first use."""
    import subprocess
    import sys

    heavy = ("trimesh", "scipy.spatial", "scipy.optimize", "scipy.ndimage", "prehension.quality",
             "prehension.viewer", "prehension.solvers.complete.search", "dask", "distributed")  # fmt: skip
    code = (f"import sys, prehension, prehension.cli; print([m for m in {heavy!r} if m in sys.modules], "
            "'__version__' in vars(prehension))")  # fmt: skip
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[] False"  # nor the package metadata (read for --version only)


def test_version_is_the_installed_distributions():
    from importlib.metadata import version

    assert prehension.__version__ == version("prehension")
    assert "__version__" in prehension.__all__ and "__version__" in dir(prehension)


def test_public_names_are_the_objects_of_their_modules():
    from prehension.results import make_solution
    from prehension.solve import solve
    from prehension.verification.residuals import evaluate

    assert prehension.evaluate is evaluate and prehension.make_solution is make_solution
    assert prehension.solve is solve  # the function, not the submodule of the same name
    assert set(prehension.__all__) <= set(dir(prehension))
    with __import__("pytest").raises(AttributeError, match="no attribute 'not_a_name'"):
        prehension.not_a_name  # noqa: B018
