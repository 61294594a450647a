"""Numba kernels. Only this package holds `@njit` code; the layers above call it.

geometry  closed-form contact geometry (MODEL 3) and vertex strikes (MODEL 4)
finger    one finger: closing sequence, stick-slip, reconfiguration, energy, forces (MODEL 4-6)
part      part equilibrium, containment, opening (MODEL 7, 8)
field     grids of points, in parallel: finger fields, map outcomes, trajectories (MODEL 8)
"""
