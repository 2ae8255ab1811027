"""Coupling schemes, convergence measures, acceleration, extrapolation, mapping, recording."""
