"""The SA hand's capsules against its published link meshes (issue 26 item 2).

The meshes are the CuikSuite bodies in ``../shared/cuik-ijrr/bodies`` (GPL: read here at
test time, never copied).  Their frames are the links' frames: the world files place
them on the same joints as :mod:`prehension.hands.sa_hand`.  The test re-measures what
the capsules miss and how far they stick out, and checks the numbers the hand records.
"""

from pathlib import Path

import numpy as np
import pytest

from prehension.hands.enclosure import fit_of_points, points_distance
from prehension.hands.sa_hand import SA_LINK_FITS, schunk_sa_hand

BODIES = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr" / "bodies"
PARTS = {
    "palm": ("palmSAH", "acs1palm", "acs2palm", "acs3palm"),
    "thumb_base": ("p0thumb",),
    "proximal": ("p1", "p2", "b2"),
    "middle": ("p3",),
    "distal": ("p4", "b4"),
}
LINKS = {"palm": "palm", "thumb_base": "thumb_base", "proximal": "index_proximal", "middle": "index_middle",
         "distal": "index_distal"}  # fmt: skip


def _off_vertices(name: str) -> np.ndarray:
    rows = [r for r in (BODIES / f"{name}.off").read_text().splitlines() if r.strip() and not r.startswith("#")]
    n = int(rows[1].split()[0])
    return np.array([[float(x) for x in r.split()[:3]] for r in rows[2 : 2 + n]])


@pytest.mark.skipif(not BODIES.is_dir(), reason="needs ../shared/cuik-ijrr/bodies")
@pytest.mark.parametrize("kind", sorted(PARTS))
def test_recorded_fit_is_what_the_published_mesh_gives(kind):
    hand = schunk_sa_hand()
    meshes = [_off_vertices(p) for p in PARTS[kind]]
    link = hand.links[hand.link_index(LINKS[kind])]
    fit = fit_of_points(link.collision, np.concatenate(meshes),
                        lambda q: np.min([points_distance(m, q) for m in meshes], axis=0), SA_LINK_FITS[kind].geometry)  # fmt: skip
    assert link.fit == SA_LINK_FITS[kind]
    assert fit.miss_mm == pytest.approx(link.fit.miss_mm, abs=0.02)
    assert fit.stick_out_mm == pytest.approx(link.fit.stick_out_mm, abs=0.05)
