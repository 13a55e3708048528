"""scripts/structure.py: the import-cycle and dispatch counts the structure issue is judged by."""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "structure.py"
spec = importlib.util.spec_from_file_location("structure_script", SCRIPT)
structure = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = structure  # dataclasses look their module up there
spec.loader.exec_module(structure)


def _tree(tmp_path, files):
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    modules = structure.read_modules(tmp_path)
    structure.resolve_imports(modules)
    return modules


def test_a_function_level_import_closes_a_cycle(tmp_path):
    modules = _tree(tmp_path, {
        "__init__.py": "from . import a\n",
        "a.py": "from .b import f\n",
        "b.py": "def f():\n    from .sub.c import g\n    return g\n",
        "sub/__init__.py": "from .c import g\n",  # a package importing its own child: not an edge
        "sub/c.py": "import prehension.a\n",
    })  # fmt: skip
    assert modules["prehension.b"].imports == {"prehension.sub.c"}
    assert modules["prehension.sub"].imports == set()
    assert structure.cycles(modules) == [["prehension.a", "prehension.b", "prehension.sub.c"]]


def test_no_cycle_and_region_dispatch_counted(tmp_path):
    modules = _tree(tmp_path, {
        "__init__.py": "",
        "low.py": "class SphereCap: ...\n",
        "high.py": "from .low import SphereCap\n"
                   "def f(r):\n    return isinstance(r, (SphereCap, int)), isinstance(r, str)\n",
    })  # fmt: skip
    assert structure.cycles(modules) == []
    assert structure.dispatch_modules(modules) == {"prehension.high": 1}


def test_numba_kernels_are_excepted_from_the_function_limits(tmp_path):
    body = "\n".join("    x = 1" for _ in range(70))
    modules = _tree(tmp_path, {
        "__init__.py": "",
        "k.py": f"@njit(cache=True)\ndef kernel(a, b, c, d, e, f, g, h, i):\n{body}\n"
                f"def plain(self, a, b):\n{body}\n",
    })  # fmt: skip
    assert [(f[1], f[3]) for f in structure.functions(modules)] == [("plain", 2)]


def test_layers_place_a_module_by_its_longest_prefix_and_catch_an_upward_import(tmp_path, monkeypatch):
    monkeypatch.setattr(structure, "LAYERS", (("low",), ("mid", "low.top"), ("high",)))
    modules = _tree(tmp_path, {
        "__init__.py": "",
        "low/__init__.py": "",
        "low/base.py": "",
        "low/top.py": "from ..mid import f\n",      # layer 1 -> 1: allowed
        "mid.py": "from .low.base import g\n",      # 1 -> 0: allowed
        "high.py": "from .mid import f\n",          # 2 -> 1: allowed
        "stray.py": "",                             # in no layer
    })  # fmt: skip
    assert structure.layer_of("prehension.low.top") == 1 and structure.layer_of("prehension.low.base") == 0
    assert structure.upward_imports(modules) == ([], ["prehension.stray"])
    (tmp_path / "low" / "base.py").write_text("def g():\n    from ..high import h\n")  # 0 -> 2, inside a function
    modules = _tree(tmp_path, {})
    assert structure.upward_imports(modules)[0] == [("prehension.low.base", "prehension.high")]


def test_the_package_meets_the_structure_limits(capsys):
    """Issue 29's done-when, on the package itself: no cycle, no upward import, region kinds
    in at most 7 modules, no module over 600 lines, no function over 60 lines or 8 parameters."""
    code = structure.main(["--check"])
    assert code == 0, capsys.readouterr().out
