"""``prehension offline HAND``: search a hand's sequence of initial poses (local solver, sec. 3.2).

HAND is any hand (a built-in name, a URDF / MJCF / hand YAML file, see
:mod:`prehension.cli.hands`).  The random problems touch the hand's fingertips: every
``<finger>_tip`` sphere cap (the opposing finger's first), or the regions given with
``--regions``; the SA hand's default is the paper's four fingertips.  The grid points of
each step run on a Dask cluster (``--scheduler ADDR`` or ``--workers N``) or inline (the
default); the sequence is the same either way for the same ``--seed``.  ``solve
--sequence FILE`` and ``batch --sequence FILE`` use the file.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from ..errors import PrehensionError
from . import args as types
from .codes import EXIT_GAVE_UP, EXIT_OK

__all__ = ["add_parser", "cmd_offline", "cli_offline"]


def add_parser(sub) -> None:
    """The ``offline`` sub-command."""
    off = sub.add_parser("offline", help="local solver: compute a hand's sequence of initial poses (sec. 3.2)")
    off.add_argument("hand", help="built-in hand (schunk-sa, alias sa), hand file (.urdf; .xml/.mjcf for MJCF; .yaml)")
    off.add_argument("--regions", metavar="A,B", help="hand regions of the random problems (default: every fingertip)")
    off.add_argument("-o", "--output", type=Path, required=True, help="sequence file to write (.json)")
    off.add_argument("--M", type=types.positive_int, default=5000, help="random problems per step (paper: 5000)")
    off.add_argument("--N", type=types.positive_int, default=30, help="grid values per lambda (paper: 30)")
    off.add_argument("--imax", type=types.positive_int, default=12, help="initial poses in the sequence (paper: 12)")
    where = off.add_mutually_exclusive_group()
    where.add_argument("--scheduler", metavar="ADDR", help="a running Dask scheduler, e.g. tcp://host:8786")
    where.add_argument("--workers", type=types.positive_int, default=None, help="local cluster of N processes (default: run inline)")
    off.add_argument("--seed", type=types.seed, default=0, help="random seed (an integer >= 0)")
    off.add_argument("--time-limit", type=types.seconds, default=0.0, metavar="SECONDS",
                     help="stop after this long (default 0: no limit); the poses found by then are written, "
                          "exit code 4")  # fmt: skip
    off.add_argument("--force", action="store_true", help="overwrite the output file if it exists")


def cmd_offline(args, console: Console) -> int:
    from ..solvers.local.offline import OfflineSearch

    regions = tuple(r.strip() for r in args.regions.split(",") if r.strip()) if args.regions else None
    search = OfflineSearch(M=args.M, N=args.N, imax=args.imax, seed=args.seed, hand_regions=regions,
                           time_limit_s=types.time_limit(args.time_limit, "--time-limit"))  # fmt: skip
    seq = cli_offline(args.hand, args.output, search, workers=args.workers, scheduler=args.scheduler, force=args.force,
                      console=console)  # fmt: skip
    return EXIT_GAVE_UP if seq.meta.get("stopped") else EXIT_OK


def _search(hand, search, executor, console: Console):
    from ..solvers.local.offline import offline_sequence

    with Progress(
        TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} chunks"),
        TimeElapsedColumn(), TimeRemainingColumn(), console=console,
    ) as bar:  # fmt: skip
        task_id = bar.add_task("off-line search", total=None)

        def progress(done, total, message):
            bar.update(task_id, completed=done, total=total, description=f"off-line search, {message}")

        return offline_sequence(hand, search, executor=executor, progress=progress)


def _table(seq, M: int, N: int) -> Table:
    from ..solvers.local.offline import compare_with_paper

    if seq.hand != "schunk-sa":
        return _plain_table(seq, M, N)
    table = Table(title=f"Initial poses: ours (M={M}, N={N}) beside Table 1 of Claret & Suárez (M=5000, N=30)")
    for col in ("i", "ours l1", "ours l2", "E_i (ours)", "paper l1", "paper l2"):
        table.add_column(col, justify="right")
    rates = seq.meta.get("best_rate_per_step", [])
    for i, ours, paper in compare_with_paper(seq):
        e = f"{100 * rates[i - 1]:.1f}%" if i - 1 < len(rates) else ""
        table.add_row(
            str(i), *(f"{v:.3f}" for v in ours) if ours else ("", ""), e,
            *(f"{v:.3f}" for v in paper) if paper else ("", ""),
        )  # fmt: skip
    return table


def _plain_table(seq, M: int, N: int) -> Table:
    table = Table(title=f"Initial poses of {seq.hand} (M={M}, N={N})")
    for col in ("i", "l1", "l2", "E_i"):
        table.add_column(col, justify="right")
    rates = seq.meta.get("best_rate_per_step", [])
    for i, lam in enumerate(seq.lambdas):
        e = f"{100 * rates[i]:.1f}%" if i < len(rates) else ""
        table.add_row(str(i + 1), f"{lam[0]:.3f}", f"{lam[1]:.3f}", e)
    return table


def cli_offline(hand_name: str, output, search=None, *, workers: int | None = None, scheduler: str | None = None,
                force: bool = False, console=None):  # fmt: skip
    """What ``prehension offline HAND`` does: search with a rich progress bar (on a Dask
    cluster when ``scheduler`` or ``workers > 1``), write the file, print the sequence
    (beside the paper's Table 1 for the SA hand).  Returns the :class:`InitialPoseSequence`.

    ``search`` is an :class:`~prehension.solvers.local.offline.OfflineSearch` (default: the
    paper's parameters on the hand's fingertips).  With its ``time_limit_s`` the search
    stops at it: the poses found by then are written (the sequence's ``meta["stopped"]``
    says so); none found raises :class:`~prehension.deadline.TimeLimitReached` and writes
    nothing."""
    from ..parallel import executor_for
    from ..solvers.local.offline import OfflineSearch
    from ..tasks.format.tasks import resolve_hand
    from .hands import print_hand_warnings

    from ..atomic import check_output_path
    from .outputs import task_inputs

    console = console or Console()
    output = check_output_path(output, "sequence file", inputs=task_inputs(hand_name), suffixes=(".json",))
    if output.exists() and not force:
        raise PrehensionError(f"{output} already exists; pass --force to overwrite it")
    hand = resolve_hand(hand_name)
    print_hand_warnings(console, hand)
    search = search or OfflineSearch()
    search = replace(search, hand_regions=search.regions_of(hand))
    for r in search.hand_regions:
        hand.region(r)  # an unknown name: an error listing the hand's regions
    with executor_for(scheduler, workers) as executor:
        seq = _search(hand, search, executor, console)
    seq.save(output)
    console.print(_table(seq, search.M, search.N))
    console.print(f"wrote {output} ({seq.meta['seconds']:.0f} s)")
    if seq.meta.get("stopped"):
        Console(stderr=True, highlight=False).print(f"gave up: {seq.meta['stopped']}; the poses found are written",
                                                     soft_wrap=True, markup=False)  # fmt: skip
    return seq
