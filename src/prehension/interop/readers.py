"""Which format a grasp file is in, and its records (:func:`read_records`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InvalidTask
from .dexgraspbench import record_from_dict as _bench_record
from .dexgraspnet import record_from_dict as _net_record
from .json_m import read_json_m
from .npy import load_npy

__all__ = ["IMPORT_FORMATS", "read_records"]

IMPORT_FORMATS = ("auto", "dexgraspbench", "dexgraspnet", "json-m")


def _npy_format(data) -> str:
    if isinstance(data, dict):
        return "dexgraspnet" if "qpos" in data and isinstance(data["qpos"], dict) else "dexgraspbench"
    return "dexgraspnet"


def read_records(path, hand, fmt: str = "auto") -> tuple[str, list]:
    """``(format, records)`` of a grasp file; ``fmt="auto"``: ``.json`` is json-m, a
    ``.npy`` dict with ``qpos`` a dict is DexGraspNet, another dict DexGraspBench, a list
    DexGraspNet."""
    path = Path(path)
    if fmt not in IMPORT_FORMATS:
        raise InvalidTask(f"unknown grasp format {fmt!r}; use one of {list(IMPORT_FORMATS)}")
    if fmt == "json-m" or (fmt == "auto" and path.suffix.lower() == ".json"):
        return "json-m", read_json_m(path, hand)
    data = load_npy(path)
    fmt = _npy_format(data) if fmt == "auto" else fmt
    if fmt == "dexgraspbench":
        return fmt, [_bench_record(data, hand, str(path))]
    items = [data] if isinstance(data, dict) else list(np.asarray(data, dtype=object).reshape(-1))
    return fmt, [_net_record(d, hand, f"{path}[{k}]") for k, d in enumerate(items)]
