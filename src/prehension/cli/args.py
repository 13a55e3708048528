"""Argument types of the command line: every bad value is refused by argparse with a
message that names the option and what would be valid (exit code 2), before any work."""

from __future__ import annotations

import argparse
import math
import re

__all__ = ["seed", "seconds", "finite", "positive", "positive_int", "time_limit", "DEFAULT_TIME_LIMIT_S", "join_negative_values",
           "add_option_rule", "check_option_rules"]

DEFAULT_TIME_LIMIT_S = 300.0  # prehension solve: every run is bounded unless asked otherwise


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def finite(text: str) -> float:
    """Any finite number (``4e1`` and ``40`` alike; not nan or inf)."""
    return _number(text)


def positive(text: str) -> float:
    """A finite number > 0 (a length such as ``--radius``)."""
    value = _number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}")
    return value


_NUMBER_LIST = re.compile(r"^-[0-9.][0-9eE.+\-]*(,\s*[-+]?[0-9.][0-9eE.+\-]*)*$")


def join_negative_values(argv: list[str], options: tuple[str, ...] = ("--at",)) -> list[str]:
    """``--at -30,0,0`` as ``--at=-30,0,0``: argparse would read a value that starts with a
    minus sign and holds commas as an option."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        if argv[i] in options and i + 1 < len(argv) and _NUMBER_LIST.match(argv[i + 1]):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


def seconds(text: str, zero: str = "no limit") -> float:
    """A duration [s] >= 0; 0 means ``zero`` (no limit, for a time limit)."""
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a number of seconds >= 0 (0: {zero}), got {text!r}")
    return value


def seed(text: str) -> int:
    """A random seed: an integer >= 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def time_limit(value: float | None, flag: str = "--time-limit") -> float | None:
    """A parsed time limit as the solvers take it: ``None`` for 0 (no limit)."""
    if value is None or value == 0:
        return None
    if not (value > 0 and math.isfinite(value)):
        from ..errors import PrehensionError

        raise PrehensionError(f"{flag} must be a number of seconds >= 0 (0: no limit), got {value!r}")
    return float(value)


def add_option_rule(parser: argparse.ArgumentParser, rule) -> None:
    """After parsing, ``rule(args)`` returning a message makes it ``parser``'s error (its usage
    and the message on stderr, exit code 2): an option that another one needs, or that the
    chosen method would ignore, is refused instead of dropped silently."""
    rules = parser.get_default("option_rules") or ()
    parser.set_defaults(option_rules=(*rules, (parser, rule)))


def check_option_rules(args: argparse.Namespace) -> None:
    """Apply the rules :func:`add_option_rule` registered for the parsed sub-command."""
    for parser, rule in getattr(args, "option_rules", ()):
        message = rule(args)
        if message:
            parser.error(message)
