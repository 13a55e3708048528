"""Error reporting: every error is an :class:`InvalidTask` that starts with the source
(normally the file name) and the path of the offending field, in plain words."""

from __future__ import annotations

import contextlib
from typing import Iterator

from pydantic import ValidationError

from ...errors import InvalidTask, PrehensionError


def join_path(*parts) -> str:
    """The dotted field path of ``parts``, empty and None parts left out."""
    return ".".join(str(p) for p in parts if p != "" and p is not None)


def fail(source: str, loc: str, message: str) -> InvalidTask:
    """An :class:`InvalidTask` reading ``"<source>: <loc>: <message>"`` (marked as located)."""
    exc = InvalidTask(": ".join(p for p in (source, loc, message) if p))
    exc._prehension_located = True  # type: ignore[attr-defined]
    return exc


@contextlib.contextmanager
def located(source: str, loc: str) -> Iterator[None]:
    """Re-raise a model error (InvalidHand, InvalidGeometry, ...) as a located InvalidTask."""
    try:
        yield
    except PrehensionError as exc:
        if getattr(exc, "_prehension_located", False):
            raise
        raise fail(source, loc, str(exc)) from None


def kind_of(value) -> str:
    """What ``value`` is, in the words of a YAML file ("a mapping", "a list", ...)."""
    names = {dict: "a mapping", list: "a list", str: "a string", type(None): "nothing (null)"}
    return names.get(type(value), type(value).__name__)


def check_mapping(data, source: str, what: str) -> None:
    """Refuse an empty file or one whose top level is not a mapping; ``what`` says what belongs there."""
    if data is None:
        raise fail(source, "", f"the file is empty; {what}")
    if not isinstance(data, dict):
        raise fail(source, "", f"the top level must be a mapping (key: value pairs), got {kind_of(data)}; {what}")


def _pydantic_message(err: dict) -> str:
    """One pydantic error as plain words (no pydantic jargon, no URLs)."""
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    if kind == "missing":
        return "field required"
    if kind in ("value_error", "assertion_error"):
        return err["msg"].split(", ", 1)[-1] if err["msg"].startswith(("Value error", "Assertion")) else err["msg"]
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return f"expected a mapping (key: value pairs), got {kind_of(value)}"
    if kind in ("list_type", "tuple_type"):
        return f"expected a list, got {kind_of(value)}"
    if kind == "too_short":
        return f"needs at least {ctx.get('min_length')} item(s), got {ctx.get('actual_length')}"
    if kind == "too_long":
        return f"takes at most {ctx.get('max_length')} item(s), got {ctx.get('actual_length')}"
    if kind == "extra_forbidden":
        return "extra key not allowed here"
    msg = err["msg"].replace("Input should be", "must be", 1)
    if isinstance(value, (int, float, str, bool)) or value is None:
        msg += f" (got {value!r})"
    return msg


def _validation_error(exc: ValidationError, source: str, prefix: tuple = ()) -> InvalidTask:
    lines = []
    for err in exc.errors(include_url=False):
        loc = join_path(*prefix, *err["loc"])
        lines.append(": ".join(p for p in (source, loc, _pydantic_message(err)) if p))
    more = f"\n(and {len(lines) - 10} more)" if len(lines) > 10 else ""
    result = InvalidTask("\n".join(lines[:10]) + more)
    result._prehension_located = True  # type: ignore[attr-defined]
    return result


def validate(spec_cls, data, source: str, prefix: tuple = ()):
    """``spec_cls`` checked from ``data``; at most ten located errors in one InvalidTask."""
    try:
        return spec_cls.model_validate(data)
    except ValidationError as exc:
        raise _validation_error(exc, source, prefix) from None
