"""``prehension simulate RESULT``: does the grasp hold in a physics engine?

``RESULT`` is a result file, or a JSON-lines file of records (``batch``, ``plan``,
``import-grasps``) of which one is simulated: ``--record K`` (its position, from 0) or
``--task NAME`` (its id or its task's name; the only record when the file holds one).
Every solution of the result (or the one ``--solution`` names) is first re-derived
as ``prehension check`` would (:func:`prehension.verification.claims.verify_result_file`): a file whose
claims do not hold is refused, never simulated.  Then the DexGraspBench protocol runs
(:mod:`prehension.sim`).  Exit code: 0 when every simulated grasp holds, 7 when one drops
or is rejected (too much penetration at the start), 2 on bad input -- including a
missing ``sim`` extra (the message says what to install).  Interrupted (Ctrl-C, SIGTERM
or SIGHUP), it writes (atomically) and prints the grasps it has finished, marked
``"interrupted": true``, and exits with 4.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..atomic import check_output_path, write_json_atomic
from ..errors import InvalidTask, PrehensionError, not_a_file
from . import args as types
from .codes import EXIT_DROPPED, EXIT_GAVE_UP, EXIT_OK

__all__ = ["add_parser", "cmd_simulate", "EXIT_DROPPED", "PHYSICS_TAG"]

PHYSICS_TAG = "physics/1"


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="push the grasped object in MuJoCo along six directions: does the grasp hold? "
                                        '(needs: pip install "prehension[sim]")')  # fmt: skip
    p.add_argument("result", type=Path, help="result file (.json) written by 'prehension solve', or JSON lines (.jsonl) "
                                             "of 'batch', 'plan' or 'import-grasps': one record, picked by --record or --task")  # fmt: skip
    p.add_argument("--record", type=int, default=None, metavar="K", help="JSON lines: the K-th record (from 0, in file order)")
    p.add_argument("--task", default=None, metavar="NAME", help="JSON lines: the record of this id or task name")
    p.add_argument("--solution", type=int, default=None, metavar="K", help="simulate only solution K (from 0; default: every one)")
    p.add_argument("-o", "--output", type=Path, help="write the outcome as JSON here")
    p.add_argument("--seed", type=types.seed, default=0, help="seed of --jitter (default 0)")
    p.add_argument("--jitter-mm", type=types.finite, default=0.0, metavar="MM",
                   help="start the object this far from its solved pose, in a seeded random direction (default 0)")  # fmt: skip
    p.add_argument("--jitter-deg", type=types.finite, default=0.0, metavar="DEG",
                   help="and turned by this angle about a seeded random axis (default 0)")  # fmt: skip
    p.add_argument("--squeeze", type=types.finite, default=None, metavar="MM", help="how far each contact is aimed into the object (default 10)")
    p.add_argument("--squeeze-kind", choices=("push", "forces", "balanced", "uniform"), default=None,
                   help="push (default): targets whose actuator torques press with the contact forces of zero net wrench "
                        "that resist the largest push, every contact at most --squeeze mm in; forces: one such set "
                        "picked without regard to the pushes, the deepest contact --squeeze mm in; balanced: each contact squeezed in proportion to its force "
                        "in such a set; uniform: every contact --squeeze mm (DexGraspBench's)")  # fmt: skip
    p.add_argument("--mass", type=types.finite, default=None, metavar="KG", help="object mass (default 0.1)")
    p.add_argument("--friction", type=types.finite, default=None, metavar="MU", help="sliding friction (default 0.6)")
    p.add_argument("--from-pregrasp", action="store_true",
                   help="start from the solution's pre-grasp (fingers backed off along the contact normals) and close "
                        "the hand onto the object first: reports whether the grasp is reached (docs/quality.md)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the outcome as JSON on stdout")


class StoredGrasp(NamedTuple):
    """A solution of a result file, as the physics test needs it (re-derived by check)."""

    q: np.ndarray
    T_palm_object: np.ndarray
    contacts: tuple
    pregrasp_q: np.ndarray | None = None  # the stored pre-grasp's angles (None: the file has none)


def stored_grasps(path: Path, index: int | None, record: int | None = None, task: str | None = None):
    """``(task, [(k, StoredGrasp)])`` of a result file whose claims hold, or of one record of
    a JSON-lines file (``record``: its position; ``task``: its id or task name)."""
    from ..verification.claims import verify_result

    data, where = result_of(path, record, task)
    checked = verify_result(data, source=where, base_dir=path.parent, reprove=False, physics=False)  # physics runs next
    if not checked.holds:
        failures = "; ".join(f"{f.what}: {f.detail}" for f in checked.failures[:3])
        raise PrehensionError(f"{where} does not hold (see 'prehension check {path}'): {failures}")
    solutions = data.get("solutions") or []
    if not solutions:
        raise PrehensionError(f"{where} holds no solution to simulate (status {checked.status})")
    if index is not None and not 0 <= index < len(solutions):
        raise PrehensionError(f"--solution {index} is out of range: the result holds {len(solutions)} solution(s), numbered 0 to {len(solutions) - 1}")
    picked = range(len(solutions)) if index is None else [index]
    grasps = []
    for k in picked:
        names = checked.task.hand.dof_names
        q = np.array([float(solutions[k]["joint_angles_rad"][d]) for d in names])
        pre = solutions[k].get("pregrasp")  # re-derived by the check above when present
        q_pre = None if pre is None else np.array([float(pre["joint_angles_rad"][d]) for d in names])
        grasps.append((k, StoredGrasp(q, np.array(solutions[k]["T_palm_object"], float), checked.reports[k].contacts, q_pre)))
    return checked.task, grasps


def result_of(path: Path, record: int | None, task: str | None) -> tuple[dict, str]:
    """``(the result dict, where it is for messages)``: the file's, or the record's that
    ``record`` / ``task`` picks in a ``.jsonl`` file (with its task put back)."""
    from ..atomic import read_json

    if path.suffix.lower() != ".jsonl":
        if not path.is_file():
            raise InvalidTask(not_a_file("result file", path))
        if record is not None or task is not None:
            raise PrehensionError("--record and --task pick a record of a JSON-lines file (.jsonl); a result file (.json) holds one result")
        return read_json(path, "result file"), str(path)
    from ..batch.journal import TaskLines, with_task
    from .check import jsonl_records

    lines = TaskLines()
    records = list(jsonl_records(path, lines))
    n, picked = _pick(path, records, record, task, lines.tasks)
    where = f"{path}:{n} (record {picked.get('id')!r})"
    if not isinstance(picked.get("result"), dict):
        raise PrehensionError(f"{where} stores no result (status {picked.get('status')!r}, {picked.get('message') or 'no message'})")
    return with_task(picked, lines.tasks, where, lines.files)["result"], where


def _record_names(record: dict, tasks: dict) -> tuple[str, ...]:
    """A record's id, its task's label (a batch's file stem) and its task's name (embedded
    in its result, or on the task line a compact record refers to)."""
    result = record.get("result") if isinstance(record.get("result"), dict) else {}
    task = result.get("task") if isinstance(result.get("task"), dict) else tasks.get(record.get("task_ref")) or {}
    names = (record.get("id"), record.get("task"), task.get("name") if isinstance(task, dict) else None)
    return tuple(dict.fromkeys(str(v) for v in names if v is not None))


def _pick(path: Path, records: list, record: int | None, task: str | None, tasks: dict) -> tuple[int, dict]:
    """The ``(line, record)`` that ``record`` or ``task`` names (the only one when neither)."""
    if not records:
        raise PrehensionError(f"{path} holds no record")
    if record is not None and task is not None:
        raise PrehensionError("give --record K or --task NAME, not both")
    if record is not None:
        if not 0 <= record < len(records):
            raise PrehensionError(f"--record {record} is out of range: {path} holds {len(records)} record(s), numbered 0 to {len(records) - 1}")
        return records[record]
    if task is not None:
        found = [r for r in records if task in _record_names(r[1], tasks)]
        if len(found) == 1:
            return found[0]
        if found:
            lines = ", ".join(str(n) for n, _ in found)
            raise PrehensionError(f"--task {task!r} names {len(found)} records of {path} (lines {lines}); pick one with --record K")
    elif len(records) == 1:
        return records[0]
    ids = "; ".join(f"{k}: {' / '.join(_record_names(r, tasks))}" for k, (_, r) in enumerate(records[:10]))
    ids += "; ..." if len(records) > 10 else ""
    what = f"no record of {path} has the id or task name {task!r}" if task is not None else f"{path} holds {len(records)} records"
    raise PrehensionError(f"{what}; pick one with --record K or --task NAME (records: {ids})")


_FLAGS = {"squeeze_mm": "--squeeze", "mass_kg": "--mass", "friction": "--friction", "jitter_mm": "--jitter-mm",
          "jitter_deg": "--jitter-deg"}  # fmt: skip


def sim_options(args):
    """The :class:`~prehension.sim.SimOptions` the arguments ask for; errors name the flag."""
    from ..sim import SimOptions

    given = {"squeeze_mm": args.squeeze, "squeeze": getattr(args, "squeeze_kind", None), "mass_kg": args.mass, "friction": args.friction,
             "jitter_mm": args.jitter_mm, "jitter_deg": args.jitter_deg}  # fmt: skip
    try:
        return SimOptions(**{k: v for k, v in given.items() if v is not None})
    except PrehensionError as exc:
        text = str(exc).replace("simulation options: ", "")
        for name, flag in _FLAGS.items():
            text = text.replace(name, flag)
        raise PrehensionError(text) from None


def cmd_simulate(args, console: Console) -> int:
    from ..sim import require_mujoco, simulate_grasp

    require_mujoco()  # before any work: say what to install (main() prints the message as text)
    options = sim_options(args)
    out = check_output_path(args.output, "output", inputs=[args.result], suffixes=(".json",)) if args.output else None
    task, grasps = stored_grasps(args.result, args.solution, args.record, args.task)
    reports = []
    try:
        for k, g in grasps:  # SIGTERM and SIGHUP arrive as KeyboardInterrupt too (cli.terminate)
            start = _start_angles(args, task, g)
            extra = () if start is None else (start,)
            reports.append((k, simulate_grasp(task, g, options, args.seed, *extra)))
    except KeyboardInterrupt:
        _report(args, console, out, task, reports, interrupted=True)
        Console(stderr=True, highlight=False).print(
            f"interrupted after {len(reports)} of {len(grasps)} grasp(s); "
            + (f"the finished ones are in {out}" if out is not None else "the finished ones are printed above"),
            soft_wrap=True)  # fmt: skip
        return EXIT_GAVE_UP
    _report(args, console, out, task, reports, interrupted=False)
    return EXIT_OK if all(r.success for _, r in reports) else EXIT_DROPPED


def _start_angles(args, task, grasp):
    """``--from-pregrasp``: the stored pre-grasp's angles (computed as ``solve`` would for
    a file written before pre-grasps were stored); otherwise ``None``."""
    if not getattr(args, "from_pregrasp", False):
        return None
    if grasp.pregrasp_q is not None:
        return grasp.pregrasp_q
    from ..pregrasp import pregrasp

    return pregrasp(task, grasp).q


def _report(args, console: Console, out, task, reports, interrupted: bool) -> None:
    """Write (atomically) and print the outcome of the grasps in ``reports``."""
    data = {"prehension": PHYSICS_TAG, "result": str(args.result), "task": task.name, "interrupted": interrupted,
            "grasps": [dict(solution=k, **r.to_dict()) for k, r in reports]}  # fmt: skip
    picked = {"record": getattr(args, "record", None), "record_task": getattr(args, "task", None)}
    data.update({k: v for k, v in picked.items() if v is not None})
    if out is not None:
        write_json_atomic(out, data)
    if args.json:
        import json

        print(json.dumps(data, indent=1, allow_nan=False))
        return
    for k, report in reports:
        console.print(_table(k, report))
    if out is not None:
        console.print(f"outcome written to {out}")


def _table(k: int, report) -> Table:
    style = "bold green" if report.success else "bold red"
    table = Table(title=f"Solution {k}: [{style}]{escape(report.describe())}[/]", title_justify="left")
    for col in ("push", "held", "moved [mm]", "turned [deg]", "initial penetration [mm]"):
        table.add_column(col)
    for p in report.pushes:
        held = "yes" if p.held else "[bold red]no (unstable)[/]" if p.unstable else "[bold red]no[/]"
        moved = ("-", "-") if p.unstable else (f"{p.shift_mm:.1f}", f"{p.turn_deg:.1f}")  # read after MuJoCo's reset
        table.add_row(p.direction, held, *moved, f"{p.initial_penetration_mm:.2f}")
    o = report.options
    table.caption = (f"object {o.mass_kg:g} kg, friction {o.friction:g}, pushed with {o.push_accel * o.mass_kg:g} N for "
                     f"{o.hold_s:g} s after a {o.squeeze_mm:g} mm {o.squeeze} squeeze; held: moved < {o.max_shift_mm:g} mm and "
                     f"turned < {o.max_turn_deg:g} deg\n{_start(report)}")  # fmt: skip
    return table


def _start(report) -> str:
    """The initial penetration, split into the hand's own and the object's approximation."""
    hand = "no mesh to measure" if report.hand_penetration_mm is None else f"{report.hand_penetration_mm:.2f} mm"
    return (f"start: {report.initial_penetration_mm:.2f} mm of penetration in MuJoCo; the hand's own into the solver's "
            f"mesh: {hand}; the object's convex approximation ({report.object_pieces} pieces) off the mesh next to "
            f"the hand: {report.approximation_mm:.2f} mm")
