r"""The frame-free pair test: can two contacts be made at all, whatever the object's pose?

For two contacts ``a, b`` whose hand regions are fingertip sphere caps (or points), a
grasp makes the *hand side* -- the fingertip centres ``c_a, c_b`` and the contact normals
``h_a, h_b`` (outward from the hand), in the frame of the links' common ancestor --
congruent to the *object side* -- ``c = o + r nu`` and ``h = -nu`` of the object regions,
in the object frame.  Quantities that rotations preserve must agree; those that do not
involve the pose of the palm in the object frame, which the complete solver's system
must search (and which makes its relaxations loose near the reach frontier, where a
continuum of poses nearly works).  With ``d = c_b - c_a`` (``D = |d|``), each cap's
normal lying within ``beta`` of its axis ``m`` and ``phi_a`` the angle between ``d`` and
``h_a``:

.. math::

    |d^{hand}|^2 = |d^{obj}|^2, \qquad
    d^{hand} \cdot m_a \ge D \cos(\phi_a + \beta_a)
      = \cos\beta_a\, (d \cdot h_a)^{obj} - \sin\beta_a\, |d \times h_a|^{obj},

likewise for ``b`` (with ``-d``), ``m_a . m_b >= cos(gamma + beta_a + beta_b)`` for the
angle ``gamma`` between the normals, and, for a hand *point* region (a fixed normal), the
equations ``d . h`` (and, for two points, ``h_a . h_b`` and ``d . (h_a x h_b)``, which then
make the test exact).  For two fingertip caps touching points (a pinch) these conditions
are also exact: they say the line between the fingertip centres lies in both cones.

The test searches the few variables these depend on -- the joint angles below the links'
common ancestor (couplings folded in, :func:`prehension.hands.reach.pair_kinematics`) and
the object regions' parameters -- by branch and prune:

* on each box, every quantity is an affine form (:mod:`.affine`): a first-order Taylor
  expansion at the centre with a remainder from bounds on the second derivatives (lever
  arms for the hand's points, 1 for unit vectors turned by joints, Bézier control nets
  for the object's patches: ``|d2 nu| <= 2|N''|/n + 5|N'|^2/n^2`` with ``n`` a lower bound
  of ``|N|`` over the patch, the sphere's radius and 1 for an object cap);
* a box is discarded when a condition cannot hold on it; otherwise the conditions narrow
  the box (interval propagation on the affine forms) and it is split through the
  dimension that contributes most to the condition closest to excluding it.

If every box is discarded the pair, hence the task, is infeasible: a proof that does not
depend on the pose, sound for any number of contacts (the pair's conditions are necessary
for the whole grasp).  Floating-point rounding is covered by a relative margin of 1e-9
on every comparison (as in :mod:`prehension.hands.reach`).  A box narrower than
``witness_width`` that survives means the conditions can (numerically) be met: the test
then stops without a proof.

The package, in the order of the data flow (each module imports only those above it, and
nothing of the complete solver but its region adapter, :mod:`..region_kinds`):

* :mod:`.affine` -- affine forms (centre, linear part, remainder) and their products;
* :mod:`.problem` -- :class:`PairProblem` (the pair's variables and constants), its boxes
  and :class:`PairOutcome`;
* :mod:`.forms` -- the affine forms of the two sides over boxes, and interval bounds of
  lengths and angles read from them;
* :mod:`.span` -- the span test: the object side alone against the hand's span;
* :mod:`.product` -- the product test: branch and prune over angles and parameters at once;
* :mod:`.matching` -- the test by matching ranges: each side's invariants on its own boxes;
* :mod:`.congruence` -- the one entry point, :func:`congruence_test`: every pair of a task.
"""

from .congruence import MATCHING_BOXES, NEAR_FRONTIER_MM, CongruenceResult, congruence_test
from .problem import PairOutcome, PairProblem, pair_problem

__all__ = ["MATCHING_BOXES", "NEAR_FRONTIER_MM", "CongruenceResult", "congruence_test", "PairOutcome", "PairProblem",
           "pair_problem"]  # fmt: skip
