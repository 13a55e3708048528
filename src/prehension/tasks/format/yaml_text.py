"""YAML text to plain data and back.

Reading refuses duplicate keys in a mapping (plain ``yaml.safe_load`` silently keeps the
last one) and names the line of a syntax error; writing puts short lists (and short flat
mappings) in flow style, e.g. ``[1.0, 2.0, 3.0]``.
"""

from __future__ import annotations

import contextlib
import re
from pathlib import Path

import yaml

from .errors import fail


class _Loader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses duplicate keys (PyYAML silently keeps the last)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=deep)
                with contextlib.suppress(TypeError):  # unhashable keys: the base class reports them
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            "while reading a mapping", node.start_mark, f"duplicate key {key!r}", key_node.start_mark
                        )
                    seen.add(key)
        return yaml.SafeLoader.construct_mapping(self, node, deep=deep)


if hasattr(yaml, "CSafeLoader"):  # libyaml's parser, 5x faster, for files that parse

    class _FastLoader(yaml.CSafeLoader):
        construct_mapping = _Loader.construct_mapping

else:  # pragma: no cover - PyYAML built without libyaml
    _FastLoader = _Loader

# YAML 1.2 reads 4e1 and 1E-3 as numbers; PyYAML (YAML 1.1) needs a dot (4.0e1) and would
# hand the task format the string "4e1".  Numbers with an exponent and no dot are floats here.
_EXPONENT_FLOAT = re.compile(r"^[-+]?(?:[0-9][0-9_]*|\.[0-9]+)[eE][-+]?[0-9]+$")
for _cls in {_Loader, _FastLoader}:
    _cls.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789."))


def parse_yaml(text: str, source: str):
    """The data of YAML ``text``; a syntax error or a duplicate key names its line.

    Text is parsed with libyaml when PyYAML has it; a text that fails is parsed again by
    the pure-Python parser, whose messages name the line where the problem starts.
    """
    try:
        return yaml.load(text, Loader=_FastLoader)  # noqa: S506 (a safe loader)
    except yaml.YAMLError:
        pass
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f" (line {mark.line + 1})" if mark is not None else ""
        context = ""
        if exc.context and exc.context_mark is not None:
            context = f" ({exc.context} on line {exc.context_mark.line + 1})"
        raise fail(source, "", f"not valid YAML{line}: {exc.problem or exc.context}{context}") from None
    except yaml.YAMLError as exc:
        raise fail(source, "", f"not valid YAML: {exc}") from None


def read_text(path: Path, source: str) -> str:
    """The UTF-8 text of ``path``; an unreadable file is an error that starts with ``source``."""
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise fail(source, "", "not a UTF-8 text file") from None
    except OSError as exc:
        raise fail(source, "", f"cannot read the file: {exc.strerror or exc}") from None


class _FlowList(list):
    pass


class _FlowDict(dict):
    pass


class _Dumper(yaml.SafeDumper):
    def ignore_aliases(self, data):
        return True


_Dumper.add_representer(
    _FlowList, lambda d, x: d.represent_sequence("tag:yaml.org,2002:seq", x, flow_style=True)
)
_Dumper.add_representer(
    _FlowDict, lambda d, x: d.represent_mapping("tag:yaml.org,2002:map", x, flow_style=True)
)


def _is_flat(value) -> bool:
    if isinstance(value, list):
        return all(_is_flat(v) for v in value)
    return not isinstance(value, dict)


def _depth(value) -> int:
    return 1 + max((_depth(v) for v in value), default=0) if isinstance(value, list) else 0


def _styled(value):
    """Mark short lists (and short flat mappings) for YAML flow style, e.g. [1.0, 2.0, 3.0]."""
    if isinstance(value, dict):
        out = {k: _styled(v) for k, v in value.items()}
        short = all(_is_flat(v) for v in value.values()) and len(repr(value)) <= 90
        return _FlowDict(out) if short and value else out
    if isinstance(value, list):
        items = [_styled(v) for v in value]
        flow = _is_flat(value) and (_depth(value) <= 1 or (_depth(value) == 2 and len(repr(value)) <= 80))
        return _FlowList(items) if flow else items
    return value


def dump_yaml(data) -> str:
    """The YAML text of plain ``data`` (keys in the given order, short lists in flow style)."""
    return yaml.dump(_styled(data), Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=100)
