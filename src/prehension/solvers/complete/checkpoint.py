"""The search state, and checkpoints bound to their task and options.

A checkpoint holds the open boxes of a search, its counters, the boxes narrower than
``sigma`` and the solutions found so far.  Resuming it is only sound on the *same*
system: an open box of another task's system, or a count of boxes already pruned there,
says nothing about this one (resuming a checkpoint of the +167 mm lid variant on the
original lid task would "prove" the feasible task infeasible).  So a checkpoint carries
two fingerprints, and :func:`load_state` refuses one that does not match:

* **task**: SHA-256 of the canonical system (names, initial box, every equation and
  inequality, the Psi equations with their Bernstein coefficients, the angle couplings) and of the task's
  file mapping without its name and description (the idle angles, collision shapes and
  couplings that verification judges);
* **options**: SHA-256 of every option that changes the boxes visited or the answer:
  ``sigma``, ``order``, ``all_solutions``, the shrink options, ``verify_starts``, the
  local refinement options and the tolerances (``max_boxes`` and ``time_limit_s`` only
  say when to stop, so a resumed run may change them).

The refusal names what differs (the task, or which options with both values).  Saved
solutions are verified again on resume (:meth:`SearchState.from_json`).
"""

from __future__ import annotations

import hashlib
import json
from collections import deque
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ...atomic import write_text_atomic
from ...errors import PrehensionError
from ...results import make_solution
from ...system import Formulation
from ...tasks.model import Configuration, Task
from ...tasks.residuals import Tolerances

__all__ = ["SearchState", "search_fingerprint", "load_state", "save_state", "FORMAT"]

FORMAT = "prehension-complete-checkpoint/2"
_STOP_ONLY = ("max_boxes", "time_limit_s")  # options that do not change the search


@dataclass
class SearchState:
    """What a search has done and what is left: open boxes ``(lower, upper, depth)``."""

    open: deque
    boxes: int = 0
    lps: int = 0
    max_depth: int = 0
    solutions: list = field(default_factory=list)
    small: list = field(default_factory=list)
    best: tuple = (float("inf"), float("inf"))  # closest miss (contact_mm, normal_deg) so far
    pair_test: object = None  # the pair test's result once run (.congruence.CongruenceResult)
    collision_pruned: int = 0  # boxes pruned because every configuration in them penetrates the object
    self_collision_pruned: int = 0  # boxes pruned because every solution in them collides with the hand itself
    closure_pruned: int = 0  # boxes pruned because no configuration in them is force closure (require)

    def to_json(self) -> dict:
        return {
            "open": [{"lower": lo.tolist(), "upper": hi.tolist(), "depth": d} for lo, hi, d in self.open],
            "boxes": self.boxes,
            "lps": self.lps,
            "max_depth": self.max_depth,
            "collision_pruned": self.collision_pruned,
            "self_collision_pruned": self.self_collision_pruned,
            "closure_pruned": self.closure_pruned,
            "small": [{"lower": lo.tolist(), "upper": hi.tolist()} for lo, hi in self.small],
            "solutions": [_configuration_to_json(s.configuration()) for s in self.solutions],
        }

    @staticmethod
    def from_json(data: dict, task: Task, tolerances: Tolerances) -> "SearchState":
        """The saved state; saved solutions are verified again (any that fails is dropped)."""
        open_ = deque((np.array(b["lower"]), np.array(b["upper"]), int(b["depth"])) for b in data["open"])
        state = SearchState(open_, data["boxes"], data["lps"], data["max_depth"])
        state.collision_pruned = int(data.get("collision_pruned", 0))
        state.self_collision_pruned = int(data.get("self_collision_pruned", 0))
        state.closure_pruned = int(data.get("closure_pruned", 0))
        state.small = [(np.array(b["lower"]), np.array(b["upper"])) for b in data["small"]]
        again = (make_solution(task, _configuration_from_json(c), tolerances) for c in data.get("solutions", []))
        state.solutions = [s for s in again if s is not None]
        return state


def _configuration_to_json(config: Configuration) -> dict:
    return {
        "joint_angles": config.joint_angles.tolist(),
        "T_palm_object": config.T_palm_object.tolist(),
        "contact_params": [[h.tolist(), o.tolist()] for h, o in config.contact_params],
    }


def _configuration_from_json(data: dict) -> Configuration:
    params = tuple((np.array(h, dtype=float), np.array(o, dtype=float)) for h, o in data["contact_params"])
    return Configuration(np.array(data["joint_angles"]), np.array(data["T_palm_object"]), params)


# -- fingerprints ------------------------------------------------------------------------
def _system_digest(form: Formulation) -> "hashlib._Hash":
    s, h = form.system, hashlib.sha256()
    h.update("\n".join(s.names).encode())
    for array in (s.lower, s.upper, s.b, s.h, s.squares, s.products):
        h.update(np.ascontiguousarray(array).tobytes())
    for M in (s.A, s.G):
        for array in (M.data, M.indices, M.indptr):
            h.update(np.ascontiguousarray(array).tobytes())
    for eq in s.bernstein:
        h.update(f"{eq.k},{eq.i},{eq.j}".encode() + np.ascontiguousarray(eq.coeffs, dtype=float).tobytes())
    for c in s.couplings:
        h.update(repr(c).encode())
    return h


def _task_mapping(task: Task) -> dict:
    from ...tasks.format.write import task_to_dict

    data = task_to_dict(task)
    data.pop("name", None)
    data.pop("description", None)
    return data


def _options_mapping(options) -> dict:
    """The options that change the search, flattened to ``{"shrink.rho": 0.9, ...}``."""
    flat: dict = {}

    def walk(prefix: str, value) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}{k}.", v)
        else:
            flat[prefix[:-1]] = value

    values = {k: v for k, v in asdict(options).items() if k not in _STOP_ONLY}
    if values.get("require") is None:  # no requirement: the fingerprint of a search before it existed
        values.pop("require", None)
        values.pop("quality", None)
    walk("", values)
    return flat


def _digest(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()


def search_fingerprint(form: Formulation, options) -> dict:
    """The fingerprints a checkpoint of this search carries (see the module docstring)."""
    task_hash = _system_digest(form)
    task_hash.update(_digest(_task_mapping(form.task)).encode())
    flat = _options_mapping(options)
    return {
        "format": FORMAT,
        "task": task_hash.hexdigest(),
        "task_name": form.task.name,
        "options": _digest(flat),
        "option_values": json.loads(json.dumps(flat, default=repr)),
    }


def _mismatch(saved: dict, now: dict, path) -> str:
    """Why the checkpoint ``saved`` cannot resume the search ``now`` ('' when it can)."""
    if saved.get("format") != FORMAT:
        return (f"checkpoint {path} was not written by this version of the complete solver "
                f"(format {saved.get('format')!r}, expected {FORMAT!r}); start again without --resume")  # fmt: skip
    if saved["task"] != now["task"]:
        return (f"checkpoint {path} belongs to another task ({saved.get('task_name')!r}: its system or task "
                f"differs from those of {now['task_name']!r}); resume it with that task, or start again "
                "without --resume")  # fmt: skip
    if saved["options"] != now["options"]:
        old, new = saved.get("option_values", {}), now["option_values"]
        diff = [f"{k} {old.get(k, '(unset)')!r} -> {new.get(k, '(unset)')!r}" for k in sorted(set(old) | set(new))
                if old.get(k) != new.get(k)]  # fmt: skip
        return (f"checkpoint {path} was saved with other search options ({'; '.join(diff) or 'options differ'}); "
                "resume with the options it was saved with (only max_boxes and the time limit may change), "
                "or start again without --resume")  # fmt: skip
    return ""


# -- files -------------------------------------------------------------------------------
def load_state(form: Formulation, options, checkpoint) -> SearchState:
    """The state saved in ``checkpoint`` for this very search; refused otherwise."""
    if checkpoint is None or not Path(checkpoint).is_file():
        raise PrehensionError(f"cannot resume: no checkpoint file {checkpoint}")
    try:
        data = json.loads(Path(checkpoint).read_text())
        saved = data["search"] if isinstance(data, dict) and isinstance(data.get("search"), dict) else {}
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PrehensionError(f"cannot resume: {checkpoint} is not a checkpoint file ({exc})") from None
    reason = _mismatch(saved, search_fingerprint(form, options), checkpoint)
    if reason:
        raise PrehensionError(reason)
    return SearchState.from_json(data, form.task, options.tolerances)


def save_state(checkpoint, state: SearchState, fingerprint: dict) -> None:
    """Write the state and its fingerprints atomically (nothing when no box is open)."""
    if checkpoint is not None and state.open:
        data = state.to_json()
        data["search"] = fingerprint
        write_text_atomic(Path(checkpoint), json.dumps(data))
