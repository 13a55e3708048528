"""``prehension check``: re-derive everything a result file claims (:mod:`prehension.verification.claims`).

Exit code: 5 when any claim does not hold; otherwise the code ``prehension solve`` gives
for the file's status (0 solved, 3 infeasible -- re-proved, 4 gave up, or an infeasibility
that could not be re-proved within the time limit, 6 approximate), so that ``check`` never
disagrees with ``solve``.  A batch output (``.jsonl``) gives 0 when every record holds.
"""

from __future__ import annotations

import json

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..errors import InvalidTask, PrehensionError, not_a_file
from ..results import Status
from .codes import EXIT_APPROXIMATE, EXIT_CHECK_FAILED, EXIT_GAVE_UP, EXIT_INFEASIBLE, EXIT_OK

__all__ = ["add_parser", "cmd_check", "jsonl_records"]


def add_parser(sub) -> None:
    p = sub.add_parser("check", help="re-derive everything a result file claims (or every record of a batch output)")
    p.add_argument("result", help="result file (.json) of 'prehension solve', or the output (.jsonl) of 'prehension batch'")
    p.add_argument("--no-reprove", action="store_true",
                   help="do not re-run the proof of a claimed infeasibility (it is then only restated)")  # fmt: skip
    p.add_argument("--time-limit", type=float, default=300.0, metavar="SECONDS",
                   help="limit of each re-run proof of infeasibility (default 300; 0: none)")  # fmt: skip


def cmd_check(args, console: Console) -> int:
    """A result file (``.json``), or a batch output (``.jsonl``, one row per record)."""
    from pathlib import Path

    from .args import time_limit

    path = Path(args.result)
    limit = time_limit(args.time_limit, "--time-limit")
    if path.suffix.lower() == ".jsonl":
        return _check_batch(path, console, not args.no_reprove, limit)
    from ..verification.claims import verify_result_file

    if not path.is_file():
        raise InvalidTask(not_a_file("result file", path))
    checked = verify_result_file(path, reprove=not args.no_reprove, time_limit_s=limit)
    solutions = len(checked.reports)
    console.print(f"{path}: task {checked.task.name!r}, status {checked.status}, {solutions} solution(s)")
    for i, report in enumerate(checked.reports):
        if report is not None:
            console.print(_checks_table(report, i))
    console.print(_findings_table(checked))
    code = _exit_code(checked)
    console.print(_verdict(checked, code))
    return code


def _exit_code(checked) -> int:
    if not checked.holds:
        return EXIT_CHECK_FAILED
    if checked.status == Status.INFEASIBLE:
        return EXIT_INFEASIBLE if checked.infeasibility_reproved else EXIT_GAVE_UP
    return {Status.SOLVED: EXIT_OK, Status.APPROXIMATE: EXIT_APPROXIMATE}.get(checked.status, EXIT_GAVE_UP)


def _verdict(checked, code: int) -> str:
    if code == EXIT_CHECK_FAILED:
        return f"[bold red]DOES NOT HOLD[/]: {len(checked.failures)} claim(s) of the file are false (listed above)"
    if checked.status == Status.INFEASIBLE:
        if checked.infeasibility_reproved:
            return "[bold yellow]infeasible[/]: the proof was run again on the embedded task and holds"
        return "[bold yellow]infeasible, not re-proved[/]: every other claim holds; the proof itself was not re-derived"
    return {
        Status.SOLVED: "[bold green]holds[/]: every claim re-derived, every constraint within the strict tolerances",
        Status.APPROXIMATE: "[bold magenta]approximate[/]: holds within the file's stated (looser) tolerances only; not a solution",
        Status.GAVE_UP: "gave up: the file claims no solution and no proof; its other claims hold",
    }.get(checked.status, "")


def _checks_table(report, index: int) -> Table:
    verdict = "holds" if report.ok else "DOES NOT HOLD"
    table = Table(title=f"Solution {index}: {verdict}", title_justify="left")
    for col in ("check", "name", "violation", "tolerance", ""):
        table.add_column(col)
    for c in report.checks:
        if c.kind == "collision" and c.ok:
            continue
        table.add_row(c.kind, escape(c.name), f"{c.value:.3g} {c.unit}", f"{c.tolerance:g}", "ok" if c.ok else "[bold red]FAILED[/]")
    table.caption = "collision pairs: only failures are listed"
    return table


def _findings_table(checked) -> Table:
    table = Table(title="What the file claims, re-derived", title_justify="left")
    for col in ("claim", "", "detail"):
        table.add_column(col)
    for f in checked.findings:
        table.add_row(escape(f.what), "ok" if f.ok else "[bold red]FALSE[/]", escape(f.detail))
    return table


def _check_batch(path, console: Console, reprove: bool, limit) -> int:
    """Re-derive every result of a batch output; one row per record (a compact record's
    task is read from the task line it refers to)."""
    from ..batch.journal import TaskLines, with_task
    from ..verification.claims import verify_result

    table = Table(title=f"{path}: every task's result re-derived", title_justify="left")
    for col in ("id", "status", "solutions", "contact [mm]", "normal [deg]", "verdict"):
        table.add_column(col)
    ok = True
    lines = TaskLines()
    for line, record in jsonl_records(path, lines):
        if not record.get("result"):
            table.add_row(escape(str(record.get("id"))), str(record.get("status")), "-", "", "", "no result stored")
            continue
        try:
            record = with_task(record, lines.tasks, f"{path}:{line}", lines.files)
        except PrehensionError:
            ok = False
            missing = f"[bold red]DOES NOT HOLD[/]: its task line {escape(str(record.get('task_ref')))} is missing"
            table.add_row(escape(str(record.get("id"))), str(record.get("status")), "-", "", "", missing)
            continue
        checked = verify_result(record["result"], source=f"{path}:{line}", base_dir=path.parent, reprove=reprove, time_limit_s=limit)
        if record.get("status") != checked.status:
            checked = _with_finding(checked, "record status", f"record says {record.get('status')!r}, its result {checked.status!r}")
        ok &= checked.holds
        reports = [r for r in checked.reports if r is not None]
        d = max((r.worst("contact_distance") for r in reports), default=0.0)
        a = max((r.worst("contact_normal") for r in reports), default=0.0)
        verdict = "holds" if checked.holds else "[bold red]DOES NOT HOLD[/]: " + escape("; ".join(f.what for f in checked.failures))
        table.add_row(escape(str(record.get("id"))), checked.status, str(len(checked.reports)), f"{d:.1e}", f"{a:.1e}", verdict)
    console.print(table)
    return EXIT_OK if ok else EXIT_CHECK_FAILED


def _with_finding(checked, what: str, detail: str):
    from dataclasses import replace

    from ..verification.claims import Finding

    return replace(checked, findings=checked.findings + (Finding(what, False, detail),))


def jsonl_records(path, lines):
    """``(line number, record)`` of a JSON-lines file; a bad line is an error naming it.
    The task and file lines of a batch output go into ``lines``
    (:class:`~prehension.batch.journal.TaskLines`), not out."""
    if not path.is_file():
        raise InvalidTask(not_a_file("batch output", path))
    with open(path, encoding="utf-8") as fh:
        for n, text in enumerate(fh, start=1):
            if not text.strip():
                continue
            try:
                record = json.loads(text)
            except json.JSONDecodeError as exc:
                raise InvalidTask(f"{path}:{n}: not valid JSON ({exc.msg}); a batch output holds one record per line") from None
            if not isinstance(record, dict):
                raise PrehensionError(f"{path}:{n}: expected a JSON object (a batch record)")
            if lines.add(record):
                continue
            yield n, record
