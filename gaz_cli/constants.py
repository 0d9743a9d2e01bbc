"""Exact SI constants (2019 SI)."""

K_B = 1.380649e-23
"""Boltzmann constant, J/K (exact)."""

N_A = 6.02214076e23
"""Avogadro constant, 1/mol (exact)."""

PRESSURE_UNIT = {1: "N", 2: "N/m", 3: "Pa"}
"""The unit of a pressure by dimension: a force per wall measure L^(D-1), so N in 1D (a force
on a point), N/m in 2D (per length of wall), Pa in 3D."""
