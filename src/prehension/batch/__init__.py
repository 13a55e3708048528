"""Solve many tasks on a Dask cluster, with a journal that survives crashes (``prehension batch``).

* :func:`read_inputs` -- a ``.jsonl`` file of tasks or a folder of task files ->
  :class:`BatchEntry` values with stable ids (:mod:`.inputs`);
* :func:`run_batch` -- solve them on a :class:`distributed.Client`
  (:func:`prehension.parallel.cluster`), appending one record per task to a ``.jsonl``
  journal as results arrive and skipping what it already holds (:mod:`.run`,
  :mod:`.journal`);
* :class:`BatchOptions`, :func:`task_seed` -- method, seeds, chunking; what a worker does
  with a chunk (:mod:`.solving`, :mod:`.loading`, :mod:`.records`);
* :func:`read_records`, :func:`read_tasks`, :func:`with_task` -- reading a journal back
  (compact records refer to task lines).

See ``docs/batch.md``.
"""

from .inputs import BatchEntry, read_inputs
from .journal import RECORD_TAG, TASK_TAG, is_done, read_records, read_tasks, with_task
from .run import BatchProgress, BatchSummary, run_batch
from .solving import BatchOptions, task_seed

__all__ = [
    "BatchEntry", "read_inputs", "BatchOptions", "task_seed", "BatchProgress", "BatchSummary", "run_batch",
    "read_records", "read_tasks", "with_task", "is_done", "RECORD_TAG", "TASK_TAG",
]  # fmt: skip
