"""The search state, and checkpoints bound to their task and options.

A checkpoint holds the open boxes of a search, its counters, the boxes narrower than
``sigma`` and the solutions found so far.  Resuming it is only sound on the *same*
system: an open box of another task's system, or a count of boxes already pruned there,
says nothing about this one (resuming a checkpoint of the +167 mm lid variant on the
original lid task would "prove" the feasible task infeasible).  So a checkpoint carries
two fingerprints, and :func:`load_state` refuses one that does not match:

* **task**: SHA-256 of the canonical system (names, initial box, every equation and
  inequality, the Psi equations with their Bernstein coefficients, the angle couplings) and of the task
  model without its name and description (hand, object, contacts, fingers, idle angles:
  the collision shapes and couplings that verification judges), read from the model's own
  fields, not from a file format (a checkpoint of format /3 hashed the task's YAML mapping:
  it is refused as written by another version);
* **options**: SHA-256 of every option that changes the boxes visited or the answer:
  ``sigma``, ``order``, ``all_solutions``, the shrink options, ``verify_starts``, the
  local refinement options and the tolerances (``max_boxes`` and ``time_limit_s`` only
  say when to stop, so a resumed run may change them).

The refusal names what differs (the task, or which options with both values).  Saved
solutions are verified again on resume (:meth:`SearchState.from_json`).

A checkpoint is a file a user can edit, and an edited one could make a feasible task
"infeasible" (emptying its open boxes leaves nothing to search).  So:

* a **content digest** (``digest``: SHA-256 of the file's JSON without it, keys sorted)
  refuses a file changed after it was written, by mistake or by hand;
* every field is **validated** before use: counters are non-negative integers; each box
  is finite, ``lower <= upper``, inside the task's initial box (to ``1e-9`` of its
  width), of the system's dimension; a checkpoint always has an open box (one is only
  written while boxes are open).  Each refusal names the field and what would be valid;
* the digest is no signature (whoever edits the boxes can recompute it), so a search
  resumed from a checkpoint **says so** in its result (``stats["resumed"]``, and the
  message of an infeasible answer): part of its proof rests on the boxes the checkpoint
  says were pruned.  ``prehension check`` re-proves such a claim from the initial box,
  as it does every infeasibility, and names the checkpoint in its finding.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections import deque
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from pathlib import Path

import numpy as np

from ...atomic import write_text_atomic
from ...errors import PrehensionError
from ...results import make_solution
from ...system import Formulation
from ...tasks.model import Configuration, Task
from ...verification.residuals import Tolerances

__all__ = ["SearchState", "search_fingerprint", "options_record", "load_state", "save_state", "FORMAT"]

FORMAT = "prehension-complete-checkpoint/4"  # /3: the content digest; /4: the task fingerprint from the task model
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
    pair_test: object = None  # the pair test's result once run (.pair.CongruenceResult)
    collision_pruned: int = 0  # boxes pruned because every configuration in them penetrates the object
    self_collision_pruned: int = 0  # boxes pruned because every solution in them collides with the hand itself
    closure_pruned: int = 0  # boxes pruned because no configuration in them is force closure (require)
    resumed: dict | None = None  # where a resumed search came from: {"checkpoint", "boxes", "lps"} (see the module docstring)

    def open_share(self) -> float:
        """The share of the search tree still open: ``sum 2^-depth`` over the open boxes (a
        split halves its box's share; the initial box is 1).  A stopped search's progress:
        the rest was pruned, solved or kept as small boxes.  Depth first, the share closed
        first lies below the first splits: a rough rate, not an estimate of the time left."""
        return float(math.fsum(2.0 ** -depth for _, _, depth in self.open))

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
    def from_json(data: dict, task: Task, tolerances: Tolerances, root: tuple | None = None,
                  where: str = "checkpoint") -> "SearchState":  # fmt: skip
        """The saved state, every field validated (see the module docstring); saved
        solutions are verified again (any that fails is dropped).  ``root``: the initial
        box ``(lower, upper)`` the boxes must lie in."""
        check = _Fields(data, where)
        open_ = deque((lo, hi, d) for lo, hi, d in check.boxes("open", root, depth=True))
        if not open_:
            raise PrehensionError(f"{where}: 'open' holds no box; a checkpoint is only written while boxes are "
                                  "open (was it edited?); start again without --resume")  # fmt: skip
        state = SearchState(open_, check.count("boxes"), check.count("lps"), check.count("max_depth"))
        state.collision_pruned = check.count("collision_pruned", default=0)
        state.self_collision_pruned = check.count("self_collision_pruned", default=0)
        state.closure_pruned = check.count("closure_pruned", default=0)
        state.small = [(lo, hi) for lo, hi, _ in check.boxes("small", root)]
        for i, saved in enumerate(check.solutions()):
            solution = _saved_solution(task, saved, tolerances, f"{where}: solutions[{i}]")
            if solution is not None:
                state.solutions.append(solution)
        return state


class _Fields:
    """The fields of a checkpoint's JSON, each checked as it is read (errors name it)."""

    def __init__(self, data: dict, where: str):
        self.data, self.where = data, where

    def _bad(self, key: str, expected: str, got) -> PrehensionError:
        shown = got if isinstance(got, str) and " " in got else repr(got) if len(repr(got)) < 60 else type(got).__name__
        return PrehensionError(f"{self.where}: '{key}' must be {expected}, got {shown}; the file is damaged or was "
                               "edited: start again without --resume")  # fmt: skip

    def count(self, key: str, default: int | None = None) -> int:
        value = self.data.get(key, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self._bad(key, "a non-negative integer", value)
        return value

    def boxes(self, key: str, root: tuple | None, depth: bool = False) -> list:
        """``[(lower, upper, depth)]`` of a list of boxes (depth 0 when not stored)."""
        items = self.data.get(key)
        if not isinstance(items, list):
            raise self._bad(key, "a list of boxes {lower, upper" + (", depth}" if depth else "}"), items)
        return [self._box(f"{key}[{i}]", b, root, depth) for i, b in enumerate(items)]

    def _box(self, key: str, box, root: tuple | None, depth: bool) -> tuple:
        if not isinstance(box, dict):
            raise self._bad(key, "a mapping {lower, upper}", box)
        n = None if root is None else len(root[0])
        lo, hi = (self._vector(f"{key}.{side}", box.get(side), n) for side in ("lower", "upper"))
        if len(lo) != len(hi) or np.any(lo > hi):
            k = int(np.argmax(lo > hi)) if len(lo) == len(hi) else None
            got = f"lower {lo[k]!r} > upper {hi[k]!r} in variable {k}" if k is not None else "bounds of two lengths"
            raise self._bad(key, "a box with lower <= upper in every variable", got)
        if root is not None:
            slack = 1e-9 * np.maximum(root[1] - root[0], 1.0)
            outside = np.flatnonzero((lo < root[0] - slack) | (hi > root[1] + slack))
            if outside.size:
                k = int(outside[0])
                got = f"[{lo[k]!r}, {hi[k]!r}] in variable {k}, whose initial range is [{root[0][k]!r}, {root[1][k]!r}]"
                raise self._bad(key, f"a box inside the task's initial box (variable {k} lies outside)", got)
        d = 0
        if depth:
            d = _Fields(box, self.where).count("depth")
        return lo, hi, d

    def _vector(self, key: str, values, n: int | None) -> np.ndarray:
        ok = isinstance(values, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        if not ok or (n is not None and len(values) != n):
            raise self._bad(key, "a list of " + (f"{n} numbers (one per variable)" if n is not None else "numbers"), values)
        array = np.array(values, dtype=float)
        if not np.all(np.isfinite(array)):
            raise self._bad(key, "finite numbers (no NaN or infinity)", values)
        return array

    def solutions(self) -> list:
        saved = self.data.get("solutions", [])
        if not isinstance(saved, list) or not all(isinstance(c, dict) for c in saved):
            raise self._bad("solutions", "a list of configurations", saved)
        return saved


def _configuration_to_json(config: Configuration) -> dict:
    return {
        "joint_angles": config.joint_angles.tolist(),
        "T_palm_object": config.T_palm_object.tolist(),
        "contact_params": [[h.tolist(), o.tolist()] for h, o in config.contact_params],
    }


def _configuration_from_json(data: dict) -> Configuration:
    params = tuple((np.array(h, dtype=float), np.array(o, dtype=float)) for h, o in data["contact_params"])
    return Configuration(np.array(data["joint_angles"], dtype=float), np.array(data["T_palm_object"], dtype=float), params)


def _saved_solution(task: Task, data: dict, tolerances: Tolerances, where: str):
    """A saved solution verified again (``None`` when it fails the residual function)."""
    try:
        return make_solution(task, _configuration_from_json(data), tolerances)
    except (KeyError, TypeError, ValueError, IndexError) as exc:  # PrehensionError is a ValueError
        raise PrehensionError(f"{where}: not a configuration of this task {{joint_angles, T_palm_object, "
                              f"contact_params}} ({type(exc).__name__}: {exc}); start again without --resume") from None


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


def _model_digest(value, h: "hashlib._Hash") -> None:
    """Feed a value of the task model to ``h``: dataclasses by type and fields, mappings by
    sorted key, sequences item by item, arrays by dtype, shape and bytes, numbers by
    ``repr`` (exact), and any other value by its ``repr``.  A field marked
    ``metadata={"digest": False}`` (what only draws the model) is left out."""
    if is_dataclass(value) and not isinstance(value, type):
        h.update(f"<{type(value).__qualname__}>".encode())
        for f in fields(value):
            if not f.metadata.get("digest", True):  # drawing only (a link's meshes): judged by nothing
                continue
            h.update(f.name.encode() + b"=")
            _model_digest(getattr(value, f.name), h)
    elif isinstance(value, Mapping):
        h.update(b"{")
        for key in sorted(value, key=repr):
            h.update(repr(key).encode() + b":")
            _model_digest(value[key], h)
        h.update(b"}")
    elif isinstance(value, (list, tuple)):
        h.update(b"[")
        for item in value:
            _model_digest(item, h)
            h.update(b",")
        h.update(b"]")
    elif isinstance(value, np.ndarray):
        h.update(f"{value.dtype.str}{value.shape}".encode() + np.ascontiguousarray(value).tobytes())
    else:
        h.update(repr(value).encode())


def _task_digest(task: Task) -> str:
    """SHA-256 of the task model without its name and description: the hand (joints,
    limits, links and their collision shapes, couplings, regions), the object (regions,
    solid), the contacts, the fingers taking part and the idle angles."""
    h = hashlib.sha256()
    for f in fields(task):
        if f.name not in ("name", "description"):
            h.update(f.name.encode() + b"=")
            _model_digest(getattr(task, f.name), h)
    return h.hexdigest()


def options_record(options) -> dict:
    """The search's options as plain values (``asdict``), its box verifier recorded by the
    verifier's own options under ``"refine"`` (None without a verifier)."""
    verifier = getattr(options, "verifier", None)
    record = asdict(options)
    refine = asdict(verifier.options) if verifier is not None and is_dataclass(verifier.options) else None
    return {("refine" if k == "verifier" else k): (refine if k == "verifier" else v) for k, v in record.items()}


#: Shrink options added after checkpoints existed, with the value that is the search before
#: them; left out of the fingerprint at that value, so a checkpoint written before them
#: resumes.  Set otherwise, they are part of it: a different search.
_ADDED_LATER = {"shrink.rotation_cuts": False, "shrink.limit_cuts": False, "shrink.feasibility_first": False,
                "shrink.lp_order": "widest", "shrink.stop_after": 0, "shrink.quaternions": "none",
                "shrink.angles": False}
#: Added with ``shrink.stop_after`` and meaningless without it (left out while it is 0).
_STOP_GAIN = "shrink.stop_gain"


def _options_mapping(options) -> dict:
    """The options that change the search, flattened to ``{"shrink.rho": 0.9, ...}``."""
    flat: dict = {}

    def walk(prefix: str, value) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}{k}.", v)
        else:
            flat[prefix[:-1]] = value

    values = {k: v for k, v in options_record(options).items() if k not in _STOP_ONLY}
    if values.get("require") is None:  # no requirement: the fingerprint of a search before it existed
        values.pop("require", None)
        values.pop("quality", None)
    walk("", values)
    if flat.get("shrink.stop_after") == 0:
        flat.pop(_STOP_GAIN, None)
    if flat.get("shrink.quaternions") == "none" and flat.get("shrink.angles") is False:  # meaningless without them
        flat.pop("shrink.branch_width", None)
    for key, before in _ADDED_LATER.items():  # added later: at the search before them, the old fingerprint
        if key in flat and flat[key] == before and type(flat[key]) is type(before):
            del flat[key]
    return flat


def _digest(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=repr).encode()).hexdigest()


def search_fingerprint(form: Formulation, options) -> dict:
    """The fingerprints a checkpoint of this search carries (see the module docstring)."""
    task_hash = _system_digest(form)
    task_hash.update(_task_digest(form.task).encode())
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
def _content_digest(data: dict) -> str:
    """SHA-256 of a checkpoint's JSON without its ``digest`` (keys sorted, compact)."""
    body = {k: v for k, v in data.items() if k != "digest"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _read(checkpoint) -> tuple[dict, dict]:
    """``(data, its fingerprints)`` of a checkpoint file, its digest checked."""
    if checkpoint is None or not Path(checkpoint).is_file():
        raise PrehensionError(f"cannot resume: no checkpoint file {checkpoint}")
    try:
        data = json.loads(Path(checkpoint).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PrehensionError(f"cannot resume: {checkpoint} is not a checkpoint file ({exc})") from None
    if not isinstance(data, dict):
        raise PrehensionError(f"cannot resume: {checkpoint} is not a checkpoint file (a JSON object was expected)")
    saved = data["search"] if isinstance(data.get("search"), dict) else {}
    if saved.get("format") == FORMAT and data.get("digest") != _content_digest(data):
        raise PrehensionError(f"cannot resume: checkpoint {checkpoint} was changed after it was written (its content "
                              "does not match its SHA-256 digest); a changed checkpoint could prove a wrong answer: "
                              "start again without --resume")  # fmt: skip
    return data, saved


def load_state(form: Formulation, options, checkpoint) -> SearchState:
    """The state saved in ``checkpoint`` for this very search; refused otherwise (another
    task or options, a changed file, a field of the wrong type or a box out of place)."""
    data, saved = _read(checkpoint)
    reason = _mismatch(saved, search_fingerprint(form, options), checkpoint)
    if reason:
        raise PrehensionError(reason)
    root = (form.system.lower, form.system.upper)
    state = SearchState.from_json(data, form.task, options.tolerances, root, where=f"checkpoint {checkpoint}")
    state.resumed = {"checkpoint": str(checkpoint), "boxes": state.boxes, "lps": state.lps}
    return state


def save_state(checkpoint, state: SearchState, fingerprint: dict) -> None:
    """Write the state, its fingerprints and its digest atomically (nothing when no box is open)."""
    if checkpoint is not None and state.open:
        data = state.to_json()
        data["search"] = fingerprint
        data["digest"] = _content_digest(data)
        write_text_atomic(Path(checkpoint), json.dumps(data))
