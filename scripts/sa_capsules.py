"""Fit the SA hand's enclosing collision capsules to its published link meshes (issue 26 item 2).

    python scripts/sa_capsules.py [BODIES]      # default ../shared/cuik-ijrr/bodies

The meshes are the CuikSuite bodies (GPL): this script reads them at run time and prints
only numbers (capsule end points and radii, and what they miss and how far they stick
out), which :mod:`prehension.hands.sa_enclosing` records.  Per link, the shape to enclose is
its meshes' vertices, except inside a pad's cone (the fingertip's and the palm's sphere
cap, half-angle 60 degrees): there the pad sphere stands for the link's
surface (:func:`~prehension.hands.sa_published.published_shape`), and the capsules hold
the sphere's cap, not the mesh; the pad sphere itself is one of the link's capsules.

For each link, ``k`` = 1..``K`` capsules are fitted to a k-means partition of the points
(seeded, several starts), each part enclosed by
:func:`~prehension.hands.shapes.mesh_capsule`; the union of least total volume is kept
(for the distal link: the union reaching least past the fingertip's tangent planes,
:func:`flat_reach`; :func:`best_fit`).  :mod:`prehension.hands.sa_enclosing` records,
per kind, the k printed there (palm 3, thumb base 3, proximal 2, middle 3, distal 3).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from prehension.hands.enclosure import capsule_gaps, fit_of_points, union_surface
from prehension.hands.model import Capsule
from prehension.hands.sa_published import PADS, PARTS, in_pad_cone, off_vertices, published_shape
from prehension.hands.shapes import _volume, mesh_capsule



def pad_ball(kind: str) -> list:
    """The pad sphere as a capsule of the link (none for a link without a pad)."""
    if kind not in PADS:
        return []
    c, rho, _ = PADS[kind]
    return [Capsule(c, c, rho)]


def pad_protrusion(kind: str, caps) -> float:
    """How far the capsules' outer surface reaches past the pad sphere inside the pad's
    cone [mm] (0 without a pad)."""
    if kind not in PADS:
        return 0.0
    c, rho, _ = PADS[kind]
    surface = union_surface(caps)
    inside = in_pad_cone(surface, kind)
    return float(max(0.0, np.max(np.linalg.norm(surface[inside] - np.asarray(c), axis=1) - rho))) if inside.any() else 0.0


def flat_reach(kind: str, caps, max_deg: float = 20.0) -> float:
    """How far the capsules reach past a plane tangent to the pad sphere, for contacts up
    to ``max_deg`` off the pad's axis (every 10 deg, 24 directions around) [mm]; 0 without a pad."""
    if kind not in PADS:
        return 0.0
    c, rho, m = (np.asarray(v, dtype=float) if not np.isscalar(v) else v for v in PADS[kind])
    m = m / np.linalg.norm(m)
    e1 = np.cross(m, [0.0, 1.0, 0.0] if abs(m[1]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(m, e1)
    worst = -np.inf
    for th in np.radians(np.arange(0.0, max_deg + 1e-9, 10.0)):
        for ph in np.radians(np.arange(0.0, 360.0, 15.0)):
            n = np.cos(th) * m + np.sin(th) * (np.cos(ph) * e1 + np.sin(ph) * e2)
            worst = max(worst, max(max((cap.a - c) @ n, (cap.b - c) @ n) + cap.radius for cap in caps) - rho)
    return float(worst)


def kmeans_capsules(pts: np.ndarray, k: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    centres = pts[rng.choice(len(pts), k, replace=False)]
    for _ in range(30):
        label = np.argmin(np.linalg.norm(pts[:, None] - centres[None], axis=2), axis=1)
        centres = np.array([pts[label == j].mean(axis=0) if np.any(label == j) else centres[j] for j in range(k)])
    return [mesh_capsule(pts[label == j]) for j in range(k) if np.sum(label == j) >= 4]


def best_fit(kind: str, pts: np.ndarray, distance, k_max: int, starts: int = 4):
    """Per k, the pad ball and k capsules fitted to the points outside it, over ``starts``
    k-means starts the union of least volume (distal: reaching least past the pad's
    tangent planes, :func:`flat_reach`); (k, capsules, fit, protrusion, reach) rows."""
    score = (lambda cs: flat_reach(kind, fixed + cs)) if kind == "distal" else (lambda cs: sum(_volume(c) for c in cs))
    fixed = pad_ball(kind)
    rest = pts[capsule_gaps(pts, fixed) > 0] if fixed else pts
    rows = []
    for k in range(1, k_max + 1):
        tries = [kmeans_capsules(rest, k, s) for s in range(starts if k > 1 else 1)]
        caps = fixed + min(tries, key=score)
        assert capsule_gaps(pts, caps).max() <= 1e-6
        rows.append((k, caps, fit_of_points(caps, pts, distance, "published mesh"), pad_protrusion(kind, caps), flat_reach(kind, caps)))
    return rows


def main() -> None:
    here = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr" / "bodies"
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bodies", nargs="?", type=Path, default=here)
    parser.add_argument("--k-max", type=int, default=4)
    parser.add_argument("--starts", type=int, default=4, help="k-means starts per k (seeds 0..)")
    parser.add_argument("--kinds", nargs="*", default=sorted(PARTS), help="link kinds (default: all)")
    args = parser.parse_args()
    for kind in args.kinds:
        parts = PARTS[kind]
        meshes = [off_vertices(args.bodies / f"{p}.off") for p in parts]
        pts, distance = published_shape(kind, meshes)
        for k, caps, fit, out, flat in best_fit(kind, pts, distance, args.k_max + (2 if kind == "palm" else 0), args.starts):
            vol = sum(_volume(c) for c in caps) / 1e3
            print(f"{kind:10s} k={k} volume {vol:7.1f} cm3  misses {fit.miss_mm:5.2f}  sticks out {fit.stick_out_mm:5.2f} mm"
                  f"  past the pad {out:5.2f} mm  past a tangent plane (contacts within 20 deg) {flat:5.2f} mm")
            for c in caps:
                print(f"    Capsule({np.round(c.a, 2).tolist()}, {np.round(c.b, 2).tolist()}, {math.ceil(c.radius * 100 + 1) / 100}),  # radius rounded up past the end points' rounding")


if __name__ == "__main__":
    main()
