"""The SA hand's capsules against its published link meshes (issue 26 item 2).

The meshes are the CuikSuite bodies in ``../shared/cuik-ijrr/bodies`` (GPL: read here at
test time, never copied).  Their frames are the links' frames: the world files place
them on the same joints as :mod:`prehension.hands.sa_hand`.  The tests re-measure what
the capsules miss and how far they stick out, and check the numbers each hand records:
the paper's capsules (``schunk-sa``: inside the meshes) and the enclosing ones
(``schunk-sa-enclosing``: holding the meshes, the pad spheres standing for the surface
near the pads, :mod:`prehension.hands.sa_published`).
"""

from pathlib import Path

import numpy as np
import pytest

from prehension.hands.enclosure import capsule_gaps, fit_of_points, points_distance
from prehension.hands.sa_enclosing import SA_ENCLOSING_FITS, schunk_sa_hand_enclosing
from prehension.hands.sa_hand import SA_LINK_FITS, schunk_sa_hand
from prehension.hands.sa_published import PARTS, in_pad_cone, off_vertices, published_shape

BODIES = Path(__file__).resolve().parents[2] / "shared" / "cuik-ijrr" / "bodies"
LINKS = {"palm": "palm", "thumb_base": "thumb_base", "proximal": "index_proximal", "middle": "index_middle",
         "distal": "index_distal"}  # fmt: skip
needs_bodies = pytest.mark.skipif(not BODIES.is_dir(), reason="needs ../shared/cuik-ijrr/bodies")


def _meshes(kind: str) -> list[np.ndarray]:
    return [off_vertices(BODIES / f"{p}.off") for p in PARTS[kind]]


@needs_bodies
@pytest.mark.parametrize("kind", sorted(PARTS))
def test_recorded_fit_is_what_the_published_mesh_gives(kind):
    hand = schunk_sa_hand()
    meshes = _meshes(kind)
    link = hand.links[hand.link_index(LINKS[kind])]
    fit = fit_of_points(link.collision, np.concatenate(meshes),
                        lambda q: np.min([points_distance(m, q) for m in meshes], axis=0), SA_LINK_FITS[kind].geometry)  # fmt: skip
    assert link.fit == SA_LINK_FITS[kind]
    assert fit.miss_mm == pytest.approx(link.fit.miss_mm, abs=0.02)
    assert fit.stick_out_mm == pytest.approx(link.fit.stick_out_mm, abs=0.05)
    assert fit.stick_out_mm == 0.0  # the default hand's capsules lie inside the published shapes (docs/hands.md)


@needs_bodies
@pytest.mark.parametrize("kind", sorted(PARTS))
def test_enclosing_capsules_hold_the_published_shape(kind):
    hand = schunk_sa_hand_enclosing()
    link = hand.links[hand.link_index(LINKS[kind])]
    meshes = _meshes(kind)
    pts, distance = published_shape(kind, meshes)
    assert capsule_gaps(pts, link.collision).max() <= 1e-9  # every vertex (outside a pad's cone) is inside
    verts = np.concatenate(meshes)
    assert in_pad_cone(verts, kind).any() == (kind in ("palm", "distal"))
    fit = fit_of_points(link.collision, pts, distance, link.fit.geometry)
    assert link.fit == SA_ENCLOSING_FITS[kind] and link.fit.miss_mm == 0.0
    assert fit.stick_out_mm == pytest.approx(link.fit.stick_out_mm, abs=0.1)


def test_enclosing_hand_keeps_the_kinematics_and_excludes_only_pairs_touching_at_rest():
    paper, enclosing = schunk_sa_hand(), schunk_sa_hand_enclosing()
    assert enclosing.dof_names == paper.dof_names and set(enclosing.regions) == set(paper.regions)
    for a, b in enclosing.collision_exclusions:  # neighbouring fingers only: 3 mm apart, fatter capsules
        assert a.split("_")[0] != b.split("_")[0] and "thumb" not in (a + b) and "palm" not in (a + b)
    assert ("middle_proximal", "index_proximal") in enclosing.collision_exclusions
    assert any("overlap at the rest pose" in n for n in enclosing.notes)
