"""A still picture of a grasp scene (PNG), with matplotlib's mplot3d on the Agg canvas.

Needs the ``plot`` extra (``pip install "prehension[plot]"``).  No pyplot and no global
backend switch: the figure is drawn on its own Agg canvas.  Every visible triangle goes
into one ``Poly3DCollection`` (so that matplotlib sorts them all back to front together),
shaded as in the HTML viewer (:func:`~prehension.viewer.model.shade_faces`); markers of
"on top" layers are drawn over it.  The projection is orthographic with equal scales.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..atomic import write_bytes_atomic
from ..errors import PrehensionError
from .model import BACKGROUND, Layer, Scene, camera_basis, shade_faces

__all__ = ["render_png", "render_image", "require_matplotlib", "IMAGE_FORMATS"]

_INSTALL = 'pip install "prehension[plot]"'
IMAGE_FORMATS = {".png": "png", ".jpg": "jpeg", ".jpeg": "jpeg", ".pdf": "pdf", ".svg": "svg"}  # suffix -> format


def image_format(path) -> str:
    """The picture format a file name asks for; a :class:`PrehensionError` for any other."""
    suffix = Path(path).suffix.lower()
    if suffix not in IMAGE_FORMATS:
        raise PrehensionError(
            f"cannot tell the picture format of {path}: the file name must end in {', '.join(IMAGE_FORMATS)}"
        )
    return IMAGE_FORMATS[suffix]


def require_matplotlib():
    """The ``matplotlib`` module, or a :class:`PrehensionError` that says how to install it."""
    try:
        import matplotlib  # noqa: F401
        from mpl_toolkits.mplot3d import art3d  # noqa: F401
    except ImportError:
        raise PrehensionError(f"rendering a picture needs matplotlib (>= 3.7); install it with: {_INSTALL}") from None
    return matplotlib


def render_image(
    scene: Scene, path, *, elev_deg: float | None = None, azim_deg: float | None = None,
    size_px: tuple[int, int] = (900, 700), dpi: int = 100, layers: tuple[str, ...] | None = None,
) -> Path:  # fmt: skip
    """Draw ``scene`` into a picture file (written atomically); the path written.

    The format follows the file name: ``.png``, ``.jpg``/``.jpeg``, ``.pdf`` or ``.svg``
    (:data:`IMAGE_FORMATS`); any other suffix is refused before drawing.

    Args:
        elev_deg, azim_deg: view direction (matplotlib's ``view_init``); default: the scene's.
        size_px: (width, height) [pixels].
        layers: keys of the layers to draw; default: those visible by default.
    """
    require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = Path(path)
    fmt = image_format(path)
    if not path.parent.is_dir():
        raise PrehensionError(f"cannot write {path}: folder {path.parent} does not exist")
    elev = scene.view_elev_deg if elev_deg is None else float(elev_deg)
    azim = scene.view_azim_deg if azim_deg is None else float(azim_deg)
    if not (np.isfinite(elev) and np.isfinite(azim)):
        raise PrehensionError(f"the view angles must be finite numbers of degrees, got elevation {elev} and azimuth {azim}")
    shown = _layers(scene, layers)
    fig = Figure(figsize=(size_px[0] / dpi, size_px[1] / dpi), dpi=dpi, facecolor=BACKGROUND)
    FigureCanvasAgg(fig)
    columns = 2 if size_px[0] >= 700 else 1
    bottom = min(0.4, (12 + 17 * -(-len(_legend(scene)) // columns)) / size_px[1])  # room for the legend
    ax = fig.add_axes((0.0, bottom, 1.0, 0.9 - bottom), projection="3d", facecolor=BACKGROUND)
    basis = camera_basis(elev, azim)
    points = _points(shown)
    bar = _scale_bar_geometry(points, basis)
    _setup_axes(ax, np.vstack([points, bar.start, bar.end, bar.label_at]), basis, elev, azim)
    _draw_triangles(ax, shown, basis)
    for layer in shown:
        _draw_markers(ax, layer)
    _draw_scale_bar(ax, bar)
    _annotate(fig, scene, columns)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=dpi, facecolor=BACKGROUND)
    write_bytes_atomic(path, buffer.getvalue())
    return path


render_png = render_image  # the name of earlier releases; any format of IMAGE_FORMATS


def _layers(scene: Scene, keys) -> list[Layer]:
    if keys is None:
        return [l for l in scene.layers if l.visible]
    known = [l.key for l in scene.layers]
    unknown = [k for k in keys if k not in known]
    if unknown:
        raise PrehensionError(f"unknown layer(s) {', '.join(unknown)}; layers are: {', '.join(known)}")
    return [l for l in scene.layers if l.key in keys]


def _points(layers: list[Layer]) -> np.ndarray:
    """(N, 3) every point drawn [mm] (one point at the origin when nothing is)."""
    pts = [l.all_points_mm() for l in layers]
    pts = np.concatenate(pts) if pts else np.zeros((0, 3))
    return pts if len(pts) else np.zeros((1, 3))


def _setup_axes(ax, points: np.ndarray, basis: np.ndarray, elev: float, azim: float) -> None:
    """Orthographic, equal scales, no axes drawn; ``points (N, 3)`` [mm] fill the axes.

    The axes box is a cube centred on the 3-D point that projects to the middle of the
    points' picture; matplotlib's projection of a cube has the same scale at any angle,
    so one measurement gives the zoom that fills the axes.
    """
    mid = (points.min(0) + points.max(0)) / 2
    screen = (points - mid) @ basis[:2].T  # (N, 2): right, up [mm]
    lo2, hi2 = screen.min(0), screen.max(0)
    centre = mid + (lo2[0] + hi2[0]) / 2 * basis[0] + (lo2[1] + hi2[1]) / 2 * basis[1]
    half = max(float(np.abs(points - centre).max()), 1.0)
    ax.set_proj_type("ortho")
    ax.view_init(elev=elev, azim=azim)
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.0)
    ax.set_axis_off()
    ax.computed_zorder = False
    w_px, h_px = np.ptp(_to_display(ax, points), axis=0)
    box = ax.get_window_extent()
    ax.set_box_aspect((1, 1, 1), zoom=0.94 * min(box.width / max(w_px, 1.0), box.height / max(h_px, 1.0)))


def _to_display(ax, points: np.ndarray) -> np.ndarray:
    """(N, 2) display coordinates [px] of ``points (N, 3)`` [mm] with the axes' current view."""
    from mpl_toolkits.mplot3d import proj3d

    x, y, _ = proj3d.proj_transform(points[:, 0], points[:, 1], points[:, 2], ax.get_proj())
    return ax.transData.transform(np.column_stack([x, y]))


def _rgba(hex_color: str, brightness: np.ndarray, opacity: float) -> np.ndarray:
    """(F, 4) colours: ``hex_color`` scaled by ``brightness (F,)``, alpha ``opacity``."""
    rgb = np.array([int(hex_color[i : i + 2], 16) for i in (1, 3, 5)]) / 255.0
    return np.column_stack([brightness[:, None] * rgb, np.full(len(brightness), opacity)])


def _draw_triangles(ax, layers: list[Layer], basis: np.ndarray) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    tris, faces, edges = [], [], []
    for mesh in (m for l in layers for m in l.meshes):
        t = mesh.vertices_mm[mesh.faces]  # (F, 3, 3)
        brightness, keep = shade_faces(t, basis, mesh.closed)
        color = _rgba(mesh.color, brightness[keep], mesh.opacity)
        tris.append(t[keep])
        faces.append(color)
        edges.append(color if mesh.opacity >= 1 else np.zeros_like(color))  # edges hide seams of opaque faces
    if not tris:
        return
    coll = Poly3DCollection(np.concatenate(tris), facecolors=np.concatenate(faces),
                            edgecolors=np.concatenate(edges), linewidths=0.35, zorder=1)  # fmt: skip
    ax.add_collection3d(coll)


def _draw_markers(ax, layer: Layer) -> None:
    z = 4 if layer.on_top else 2
    for line in layer.lines:
        p = line.points_mm
        ax.plot(p[:, 0], p[:, 1], p[:, 2], color=line.color, lw=line.width_px * 0.75,
                ls="--" if line.dashed else "-", zorder=z)  # fmt: skip
    for arrows in layer.arrows:
        o, d = arrows.origins_mm, arrows.vectors_mm
        ax.quiver(o[:, 0], o[:, 1], o[:, 2], d[:, 0], d[:, 1], d[:, 2], color=arrows.color,
                  arrow_length_ratio=0.28, linewidths=2.0, zorder=z + 1)  # fmt: skip
    for points in layer.points:
        p = points.points_mm
        ax.scatter(p[:, 0], p[:, 1], p[:, 2], s=(0.9 * points.size_px) ** 2, c=points.color, edgecolors="white",
                   linewidths=1.0, depthshade=False, zorder=z + 2)  # fmt: skip


def _nice_length(mm: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above ``mm``."""
    p = 10.0 ** np.floor(np.log10(mm))
    return max(m * p for m in (1, 2, 5, 10) if m * p <= mm)


@dataclass(frozen=True, eq=False)
class _ScaleBar:
    start: np.ndarray  # (3,) [mm]
    end: np.ndarray
    label_at: np.ndarray
    length_mm: float


def _scale_bar_geometry(points: np.ndarray, basis: np.ndarray) -> _ScaleBar:
    """A bar of a round length [mm] along the screen's horizontal, under the picture's right end."""
    mid = (points.min(0) + points.max(0)) / 2
    screen = (points - mid) @ basis[:2].T  # (N, 2): right, up [mm]
    width, height = float(np.ptp(screen[:, 0])) or 100.0, float(np.ptp(screen[:, 1])) or 100.0
    length = _nice_length(0.3 * width)
    right, up = basis[0], basis[1]
    start = mid + (screen[:, 0].max() - length) * right + (screen[:, 1].min() - 0.03 * height) * up
    end = start + length * right
    return _ScaleBar(start, end, start + 0.5 * length * right - 0.05 * height * up, length)


def _draw_scale_bar(ax, bar: _ScaleBar) -> None:
    ax.plot(*np.stack([bar.start, bar.end]).T, color="#1d2630", lw=2.0, zorder=6)
    ax.text(*bar.label_at, f"{bar.length_mm:g} mm", ha="center", va="center", fontsize=9, color="#1d2630", zorder=7)


def _legend(scene: Scene) -> list:
    """The legend entries of what the picture draws (another stage's hand is not drawn)."""
    return [e for e in scene.legend if e.stage is None or e.stage == scene.stage]


def _annotate(fig, scene: Scene, columns: int) -> None:
    from matplotlib.patches import Patch

    fig.text(0.015, 0.975, scene.title, fontsize=11, weight="bold", va="top", color="#1d2630")
    line = dict(scene.stages).get(scene.stage) if scene.stage != "grasp" else None  # a stage: what it shows
    fig.text(0.015, 0.94, line or (scene.caption[0] if scene.caption else ""), fontsize=9, va="top", color="#3d4853")
    handles = [Patch(facecolor=e.color, edgecolor="#00000040", label=e.label) for e in _legend(scene)]
    fig.legend(handles=handles, loc="lower left", bbox_to_anchor=(0.01, 0.005), ncol=columns, frameon=False, fontsize=8.5,
               columnspacing=2.5)  # fmt: skip
