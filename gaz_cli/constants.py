"""Exact SI constants (2019 SI)."""

K_B = 1.380649e-23
"""Boltzmann constant, J/K (exact)."""

N_A = 6.02214076e23
"""Avogadro constant, 1/mol (exact)."""
