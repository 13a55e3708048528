"""The local solver: Jacobian iterations from an off-line sequence of initial poses (Claret & Suárez)."""
