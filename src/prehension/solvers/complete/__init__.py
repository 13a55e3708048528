"""The complete solver: branch-and-prune with linear relaxations (Rosales et al. 2011, sec. 4)."""
