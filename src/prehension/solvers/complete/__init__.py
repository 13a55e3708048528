"""The complete solver: branch-and-prune with linear relaxations (Rosales et al. 2011, sec. 4).

It consumes the polynomial system built by :mod:`prehension.system`: relaxations
(:mod:`.relaxations`), interval contraction (:mod:`.contract`), LP box shrinking
(:mod:`.shrink`) and the search (:mod:`.search`), which discards boxes by the collision,
self-collision and force-closure prunes (:mod:`.collision`, :mod:`.self_collision`,
:mod:`.closure`) and ends the search with the pose-free pair test (the package
:mod:`.pair`).  The region kinds are known to one module, :mod:`.region_kinds`; boxes are
verified through the :class:`~.verifier.BoxVerifier` the caller gives (the complete solver
does not import the local solver); checkpoints: :mod:`.checkpoint`.
"""
