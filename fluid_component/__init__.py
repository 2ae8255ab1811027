"""Fluid solvers behind the component contract."""
