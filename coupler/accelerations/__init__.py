"""Accelerations of implicit coupling iterations, one module per family, each registered here by its import.

- ``base``: the base class (plain fixed-point iteration, ``none``), the registry, shared settings, and
  ``resolve_acceleration`` / ``make_acceleration``.
- ``relaxation``: ``constant``, ``aitken``.
- ``quasi_newton``: ``iqn-ils``, ``iqn-imvj`` (as preCICE's).
- ``surrogate``: ``iqn-surrogate``, the experimental coupled surrogate's IQN.
- ``kratos``: Kratos CoSimulation's updates, ``kratos-aitken``, ``kratos-iqn-ils``, ``kratos-mvqn``.
"""

from coupler.accelerations.base import ACCELERATIONS, Acceleration, make_acceleration, resolve_acceleration

# in registration order: the order error messages and the scene reference list the accelerations in
# isort: off
from coupler.accelerations import relaxation, quasi_newton, surrogate, kratos
# isort: on

FAMILIES = (relaxation, quasi_newton, surrogate, kratos)     # the modules whose classes ACCELERATIONS holds

__all__ = ["ACCELERATIONS", "FAMILIES", "Acceleration", "make_acceleration", "resolve_acceleration"]
