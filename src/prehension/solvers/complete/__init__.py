"""The complete solver: branch-and-prune with linear relaxations (Rosales et al. 2011, sec. 4).

It consumes the polynomial system built by :mod:`prehension.system`: relaxations
(:mod:`.relaxations`), interval contraction (:mod:`.contract`), LP box shrinking
(:mod:`.shrink`) and the search (:mod:`.search`).
"""
