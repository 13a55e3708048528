"""The built-in tasks, and one function that turns whatever a user names into a Task.

Built-in tasks are task files shipped in ``prehension/tasks/builtin/``: the nine benchmark
problems of Table 2 of Rosales et al. (IJRR 2011).  :func:`resolve_task` accepts a
built-in name, a task file (``.yaml``/``.yml``) or a CuikSuite ``.world`` file.
"""

from __future__ import annotations

from functools import lru_cache
from importlib import resources
from pathlib import Path

from ..errors import InvalidTask
from .model import Task

__all__ = ["builtin_task_names", "load_builtin_task", "resolve_task", "builtin_mesh_dir", "builtin_regions"]

_PACKAGE = "prehension.tasks"


def _builtin_dir():
    return resources.files(_PACKAGE).joinpath("builtin")


def builtin_mesh_dir() -> Path:
    """The folder of the built-in objects' meshes (``mesh:`` paths of built-in tasks are relative to its parent)."""
    return Path(str(_builtin_dir())) / "meshes"


def builtin_regions() -> dict[str, dict]:
    """Every object region of the built-in task files, by object name.

    Read from the files' YAML alone (no mesh is read), so that
    ``scripts/make_builtin_meshes.py`` can make the meshes the regions must lie on.
    """
    from .format.regions import region_from_dict
    from .format.yaml_text import parse_yaml

    out: dict[str, dict] = {}
    for name in builtin_task_names():
        text = _builtin_dir().joinpath(f"{name}.yaml").read_text(encoding="utf-8")
        obj = parse_yaml(text, name)["object"]
        for rname, spec in obj["regions"].items():
            out.setdefault(obj["name"], {})[rname] = region_from_dict(spec, f"built-in task {name}: object.regions.{rname}")
    return out


@lru_cache(maxsize=None)
def builtin_task_names() -> tuple[str, ...]:
    """Names of the built-in tasks, sorted."""
    return tuple(sorted(p.name[: -len(".yaml")] for p in _builtin_dir().iterdir() if p.name.endswith(".yaml")))


def load_builtin_task(name: str) -> Task:
    """The built-in task called ``name``."""
    from .yaml_io import loads_task

    if name not in builtin_task_names():
        raise InvalidTask(f"unknown built-in task {name!r}; built-in tasks are: {', '.join(builtin_task_names())}")
    text = _builtin_dir().joinpath(f"{name}.yaml").read_text(encoding="utf-8")
    return loads_task(text, source=f"built-in task {name}", base_dir=Path(str(_builtin_dir())))


def resolve_task(spec: str | Path, **world_options) -> Task:
    """A task from a built-in name, a YAML task file or a CuikSuite ``.world`` file.

    ``world_options`` go to :func:`prehension.tasks.cuik_import.import_world`.
    """
    text = str(spec)
    path = Path(text)
    if path.suffix.lower() == ".world":
        from .cuik_import import import_world

        return import_world(path, **world_options)
    if path.suffix.lower() in (".yaml", ".yml"):
        from .yaml_io import load_task

        return load_task(path)
    if text in builtin_task_names():
        return load_builtin_task(text)
    if path.is_dir():
        raise InvalidTask(f"{text} is a folder, not a task; give a task file (.yaml or .world) inside it")
    raise InvalidTask(
        f"{text!r} is neither a built-in task, a task file (.yaml) nor a CuikSuite file (.world); "
        f"built-in tasks are: {', '.join(builtin_task_names())}"
    )
