"""The interactive viewer: one self-contained HTML file (no network, no server).

The page is ``assets/template.html`` with the renderer ``assets/viewer.js`` (plain JS,
Canvas2D, depth-sorted flat-shaded triangles) and the scene as JSON inlined.  Coordinates
are rounded to 0.01 mm to keep the file small.
"""

from __future__ import annotations

import html
import json
import re
from importlib import resources
from pathlib import Path

import numpy as np

from ..atomic import write_text_atomic
from ..errors import PrehensionError
from .model import AMBIENT, BACKGROUND, LIGHT_IN_CAMERA, Layer, Scene

__all__ = ["scene_to_dict", "scene_to_html", "write_html"]

_ASSETS = "prehension.viewer"
DECIMALS = 2  # 0.01 mm


def _floats(a: np.ndarray) -> list:
    """A flat list of numbers rounded to 0.01 (ints where exact, to keep the JSON short)."""
    flat = np.round(np.asarray(a, dtype=float).ravel(), DECIMALS) + 0.0  # + 0.0: no "-0.0"
    return [int(x) if x.is_integer() else x for x in flat.tolist()]


def _layer_to_dict(layer: Layer) -> dict:
    return {
        "key": layer.key, "label": layer.label, "visible": layer.visible, "onTop": layer.on_top, "stage": layer.stage,
        "meshes": [{"color": m.color, "opacity": m.opacity, "closed": m.closed,
                    "v": _floats(m.vertices_mm), "f": m.faces.ravel().tolist()} for m in layer.meshes],
        "lines": [{"color": l.color, "width": l.width_px, "dashed": l.dashed, "p": _floats(l.points_mm)}
                  for l in layer.lines],
        "points": [{"color": p.color, "size": p.size_px, "p": _floats(p.points_mm)} for p in layer.points],
        "arrows": [{"color": a.color, "o": _floats(a.origins_mm), "d": _floats(a.vectors_mm)} for a in layer.arrows],
    }  # fmt: skip


def scene_to_dict(scene: Scene) -> dict:
    """The JSON the page's script reads (palm frame, mm)."""
    lo, hi = scene.bounds_mm(visible_only=True)  # the first view frames what is shown at first
    return {
        "title": scene.title, "task": scene.task_name, "status": scene.status, "caption": list(scene.caption),
        "view": {"elev": scene.view_elev_deg, "azim": scene.view_azim_deg},
        "lighting": {"lightInCamera": list(LIGHT_IN_CAMERA), "ambient": AMBIENT, "background": BACKGROUND},
        "bounds": {"lo": _floats(lo), "hi": _floats(hi)},
        "legend": [{"label": e.label, "color": e.color} for e in scene.legend],
        "stages": [{"key": key, "label": label} for key, label in scene.stages], "stage": scene.stage,
        "layers": [_layer_to_dict(l) for l in scene.layers],
    }  # fmt: skip


def _asset(name: str) -> str:
    return resources.files(_ASSETS).joinpath("assets", name).read_text(encoding="utf-8")


def _json_in_script(text: str) -> str:
    """JSON that cannot close (or comment out) the ``<script>`` element it sits in:
    every ``<``, ``>`` and ``&`` written as a JSON unicode escape (same data)."""
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _script(name: str) -> str:
    """A script asset, checked to be safe to inline."""
    text = _asset(name)
    if re.search(r"</script|<!--", text, re.I):
        raise RuntimeError(f"viewer asset {name} must not contain '</script' or '<!--' (it is inlined)")
    return text


def scene_to_html(scene: Scene) -> str:
    """The whole page as one string: template, script and scene data inlined."""
    data = json.dumps(scene_to_dict(scene), separators=(",", ":"), ensure_ascii=True)
    values = {
        "__TITLE__": html.escape(scene.title),
        "/*__VIEWER_JS__*/": _script("viewer.js"),
        "__SCENE_JSON__": _json_in_script(data),
    }
    page = _asset("template.html")
    missing = [key for key in values if page.count(key) != 1]
    if missing:
        raise RuntimeError(f"the viewer template must hold each placeholder once: {missing}")
    # One pass, so that no inserted text is searched for the next placeholder.
    return _PLACEHOLDER.sub(lambda m: values[m.group(0)], page)


_PLACEHOLDER = re.compile("|".join(re.escape(k) for k in ("__TITLE__", "/*__VIEWER_JS__*/", "__SCENE_JSON__")))


def write_html(scene: Scene, path) -> Path:
    """Write the page atomically to ``path``; the path written."""
    path = Path(path)
    if not path.parent.is_dir():
        raise PrehensionError(f"cannot write {path}: folder {path.parent} does not exist")
    write_text_atomic(path, scene_to_html(scene))
    return path
