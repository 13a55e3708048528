"""How much of the CuikSuite world language prehension reads: every ``.world`` of a checkout.

For each ``.world`` file under ``CHECKOUT`` (a CuikSuite clone, e.g. ``github:Logan-Shi/CuikSuite``;
read at run time, nothing of it is copied) the script tries, in order:

1. **parse**: :func:`prehension.tasks.cuik_parser.read_world`;
2. **import**: :func:`prehension.tasks.cuik_import.import_world` (a grasp task), else
   ``hand_from_world`` when the installed prehension has it (a hand without contacts);
3. **solve**: for a task, :func:`prehension.solve` (``auto``, ``--time-limit`` s), every
   "solved" re-checked by :func:`prehension.evaluate`.

It prints one row per file (the first refusal's message, shortened) and a summary: the
counts, and the refusals grouped by reason (the message with names, numbers and lines
blanked).  Not run in CI: it needs the checkout.

    PYTHONPATH=$PWD/src python benchmarks/cuik_worlds.py /path/to/CuikSuite [--time-limit 60] [--quiet]
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter
from pathlib import Path

from prehension import evaluate, solve
from prehension.solve import SolveOptions
from prehension.tasks import cuik_import
from prehension.tasks.cuik_parser import read_world


def _reason(message: str) -> str:
    """The refusal's kind: the message after the file and line, names/numbers blanked."""
    text = re.sub(r"^.*?\.world(:\d+)?:\s*", "", message.splitlines()[0])
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "X", text)
    text = re.sub(r"\d+(\.\d+)?", "N", text)
    return text.split(" (in the ")[0].split("; ")[0][:110]


def _import(world, path: Path):
    """A task when the file states contacts (``in_patch``) or the importer has no
    ``hand_from_world`` (before it existed); else a hand."""
    to_hand = getattr(cuik_import, "hand_from_world", None)
    if to_hand is None or any(j.kind == "in_patch" for j in world.joints):
        return "task", cuik_import.task_from_world(world)
    return "hand", to_hand(world)


def _one(path: Path, time_limit: float) -> tuple[str, str, str]:
    """(stage reached, what it imported as, the message)."""
    try:
        world = read_world(path)
    except Exception as exc:  # noqa: BLE001
        return "refused at parse", "", str(exc)
    try:
        kind, thing = _import(world, path)
    except Exception as exc:  # noqa: BLE001
        return "parsed", "", str(exc)
    if kind == "hand":
        return "imported", "hand", f"{len(thing.links)} links, {thing.n_dof} dof"
    result = solve(thing, SolveOptions(time_limit_s=time_limit))
    if result.status == "solved":
        verdict = evaluate(thing, result.solutions[0].configuration())
        if verdict.ok:
            return "solved", "task", f"solved ({result.message[:60]})"
        return "imported", "task", "solve claimed solved, evaluate disagrees"
    return "imported", "task", f"{result.status}: {result.message[:80]}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkout", type=Path, help="a CuikSuite checkout (its .world files are read)")
    parser.add_argument("--time-limit", type=float, default=60.0, help="per solve [s]")
    parser.add_argument("--quiet", action="store_true", help="only the summary")
    args = parser.parse_args(argv)
    files = sorted(args.checkout.rglob("*.world"))
    if not files:
        print(f"no .world files under {args.checkout}", file=sys.stderr)
        return 2
    stages, kinds, reasons = Counter(), Counter(), Counter()
    started = time.perf_counter()
    for path in files:
        stage, kind, message = _one(path, args.time_limit)
        stages[stage] += 1
        kinds[kind] += 1
        if stage in ("refused at parse", "parsed"):
            reasons[(stage, _reason(message))] += 1
        if not args.quiet:
            print(f"{str(path.relative_to(args.checkout)):70s} {stage:17s} {kind:5s} {message.splitlines()[0][:150]}")
    n = len(files)
    parsed = n - stages["refused at parse"]
    imported = stages["imported"] + stages["solved"]
    print(f"\n{n} .world files ({time.perf_counter() - started:.0f} s)")
    print("| parse | import (task + hand) | solve |\n| --- | --- | --- |")
    print(f"| {parsed} | {imported} ({kinds['task']} + {kinds['hand']}) | {stages['solved']} |")
    print("\nrefusals by reason:\n| files | stage | reason |\n| --- | --- | --- |")
    for (stage, reason), count in reasons.most_common():
        print(f"| {count} | {stage} | {reason} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
