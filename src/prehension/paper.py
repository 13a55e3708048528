"""Numbers published in the two papers prehension implements, for side-by-side reports.

Table 2 of Rosales et al. (IJRR 2011): for each benchmark task, the size of their
polynomial system (n_v variables, n_e equations, solution-set dimension d) and the CPU
time to the first solution on a grid of 64 cores (sigma = 0.1).
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["Table2Row", "TABLE2", "CUIK_FILE_TASKS"]


class Table2Row(NamedTuple):
    n_v: int
    n_e: int
    d: int
    seconds: float


TABLE2: dict[str, Table2Row] = {
    "scalpel-upholding": Table2Row(219, 209, 17, 106),
    "scalpel-handling": Table2Row(243, 235, 19, 255),
    "scalpel-incision": Table2Row(331, 324, 18, 418),
    "teapot-lid-lifting": Table2Row(219, 209, 17, 114),
    "teapot-service": Table2Row(288, 278, 19, 262),
    "teapot-transportation": Table2Row(312, 305, 17, 375),
    "guitar-tuning": Table2Row(219, 209, 17, 68),
    "guitar-playing": Table2Row(307, 298, 19, 229),
    "guitar-holding": Table2Row(331, 324, 18, 664),
}


# The authors' CuikSuite problem files (folder/subfolder in shared/cuik-ijrr) and the
# built-in task that reproduces each one's numbers.
CUIK_FILE_TASKS: dict[str, str] = {
    "scalpel/2_contacts_index_thumb": "scalpel-upholding",
    "scalpel/3_contacts_middle_thumb_palm": "scalpel-handling",
    "scalpel/4_contacts_middle_index_thumb_palm": "scalpel-incision",
    "teapot/2_contacts_index_thumb": "teapot-lid-lifting",
    "teapot/3_contacts_middle_index_thumb": "teapot-service",
    "teapot/4_contacts_index_middle_ring_palm": "teapot-transportation",
}
