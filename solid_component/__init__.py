"""Solid full-order solvers behind the component contract."""
