"""``prehension check``: re-verify a result file against the task it embeds."""

from __future__ import annotations

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
    from ..results import read_result

    task, data = read_result(args.result)
    solutions = data.get("solutions", [])
    console.print(f"{args.result}: task {task.name!r}, status {data.get('status')}, {len(solutions)} solution(s)")
    ok = True
    for i, sol in enumerate(solutions):
        report = evaluate(task, _configuration(task, sol, i))
        gap = _stored_points_agree(report, sol)
        ok &= report.ok and gap < 1e-6
        console.print(_checks_table(report, i, gap))
    if not solutions:
        console.print("no solution stored: nothing to verify")
    return EXIT_OK if ok else EXIT_CHECK_FAILED


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
