"""The task-file format is cut by kind, one direction of imports (tasks/format/__init__.py).

Read from the source with scripts/structure.py (every import statement counted, at module
level or inside a function), so that a kind module reaching back up fails here.
"""

import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "structure.py"
spec = importlib.util.spec_from_file_location("structure_script_format", SCRIPT)
structure = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = structure
spec.loader.exec_module(structure)

PACKAGE = "prehension.tasks.format"
SHARED = ("errors", "schema", "values", "yaml_text", "embedded")  # below every kind
KINDS = ("regions", "hands", "hand_files", "task_hands", "objects", "tasks")  # each imports only earlier ones


def _format_imports():
    modules = structure.read_modules()
    structure.resolve_imports(modules)
    return {
        name[len(PACKAGE) + 1 :]: {i[len(PACKAGE) + 1 :] for i in m.imports if i.startswith(PACKAGE + ".")}
        for name, m in modules.items()
        if name.startswith(PACKAGE + ".")
    }


def test_kind_modules_import_only_downwards():
    imports = _format_imports()
    assert set(imports) == set(SHARED) | set(KINDS)
    for k, name in enumerate(KINDS):
        assert imports[name] <= set(SHARED) | set(KINDS[:k]), (name, imports[name])
    for name in SHARED:
        assert imports[name] <= set(SHARED) and name not in imports[name]


def test_region_kinds_are_dispatched_in_one_format_module():
    modules = structure.read_modules()
    counts = structure.dispatch_modules(modules)
    assert [m for m in counts if m.startswith(PACKAGE)] == [PACKAGE + ".regions"]
