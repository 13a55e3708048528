"""``prehension check``: re-verify a result file against the task it embeds."""

from __future__ import annotations

import json

import numpy as np
from rich.console import Console
from rich.table import Table

from ..errors import InvalidTask
from ..tasks.model import Configuration
from ..tasks.residuals import evaluate
from .codes import EXIT_CHECK_FAILED, EXIT_OK


def _configuration(task, sol: dict, index: int) -> Configuration:
    try:
        q = np.array([sol["joint_angles_rad"][d] for d in task.hand.dof_names])
        params = tuple((np.array(c["hand_params"]), np.array(c["object_params"])) for c in sol["contacts"])
        return Configuration(q, np.array(sol["T_palm_object"]), params)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidTask(f"solution {index}: malformed or from a different task ({exc!r} is missing or wrong)") from None


def _stored_points_agree(report, sol: dict) -> float:
    """Largest gap [mm] between the points stored in the file and the recomputed ones."""
    gaps = [0.0]
    for state, stored in zip(report.contacts, sol["contacts"]):
        gaps.append(float(np.linalg.norm(state.hand_point - np.array(stored["hand_point"]))))
        gaps.append(float(np.linalg.norm(state.object_point - np.array(stored["object_point"]))))
    return max(gaps)


def cmd_check(args, console: Console) -> int:
    """A result file (``.json``): every check of every solution; a batch output
    (``.jsonl``, see ``prehension batch``): one line per task."""
    if args.result.suffix.lower() == ".jsonl":
        return _check_batch(args.result, console)
    from ..results import read_result

    task, data = read_result(args.result)
    solutions = data.get("solutions", [])
    console.print(f"{args.result}: task {task.name!r}, status {data.get('status')}, {len(solutions)} solution(s)")
    ok = True
    for i, (report, gap) in enumerate(_verified(task, solutions)):
        ok &= report.ok and gap < 1e-6
        console.print(_checks_table(report, i, gap))
    if not solutions:
        console.print("no solution stored: nothing to verify")
    return EXIT_OK if ok else EXIT_CHECK_FAILED


def _verified(task, solutions: list) -> list:
    """Per stored solution: the residual report and the gap to the stored points [mm]."""
    out = []
    for i, sol in enumerate(solutions):
        report = evaluate(task, _configuration(task, sol, i))
        out.append((report, _stored_points_agree(report, sol)))
    return out


def _check_batch(path, console: Console) -> int:
    """Re-verify every result of a batch output; one row per task."""
    from ..results import result_task

    table = Table(title=f"{path}: every task's result re-verified", title_justify="left")
    for col in ("id", "status", "solutions", "contact [mm]", "normal [deg]", "verdict"):
        table.add_column(col)
    ok = True
    for line, record in _records(path):
        if not record.get("result"):
            table.add_row(str(record.get("id")), str(record.get("status")), "-", "", "", "no result stored")
            continue
        task, data = result_task(record["result"], f"{path}:{line}", path.parent)
        checked = _verified(task, data.get("solutions", []))
        holds = all(r.ok and gap < 1e-6 for r, gap in checked)
        ok &= holds
        worst = [(r.worst("contact_distance"), r.worst("contact_normal")) for r, _ in checked] or [(0.0, 0.0)]
        table.add_row(str(record.get("id")), str(data.get("status")), str(len(checked)),
                      f"{max(d for d, _ in worst):.1e}", f"{max(a for _, a in worst):.1e}",
                      ("holds" if checked else "nothing to verify") if holds else "[bold red]DOES NOT HOLD[/]")  # fmt: skip
    console.print(table)
    return EXIT_OK if ok else EXIT_CHECK_FAILED


def _records(path):
    """``(line number, record)`` of a JSON-lines file; a bad line is an error naming it."""
    if not path.is_file():
        raise InvalidTask(f"batch output not found: {path}")
    with open(path, encoding="utf-8") as fh:
        for n, text in enumerate(fh, start=1):
            if not text.strip():
                continue
            try:
                record = json.loads(text)
            except json.JSONDecodeError as exc:
                raise InvalidTask(f"{path}:{n}: not valid JSON ({exc.msg}); a batch output holds one record per line") from None
            if not isinstance(record, dict):
                raise InvalidTask(f"{path}:{n}: expected a JSON object (a batch record)")
            yield n, record


def _checks_table(report, index: int, gap: float) -> Table:
    verdict = "holds" if report.ok else "DOES NOT HOLD"
    table = Table(title=f"Solution {index}: {verdict}", title_justify="left")
    for col in ("check", "name", "violation", "tolerance", ""):
        table.add_column(col)
    for c in report.checks:
        if c.kind == "collision" and c.ok:
            continue
        table.add_row(c.kind, c.name, f"{c.value:.3g} {c.unit}", f"{c.tolerance:g}", "ok" if c.ok else "[bold red]FAILED[/]")
    table.caption = f"stored contact points agree with the recomputed ones to {gap:.1e} mm (collision pairs: only failures are listed)"
    return table
