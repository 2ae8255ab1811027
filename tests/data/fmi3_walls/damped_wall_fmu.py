"""The damped wall of examples/damped_wall as an FMI 3.0 Co-Simulation FMU made by pythonfmu3: each node's radius
relaxes towards the spring law of the pressure over tau, by implicit Euler over each step,
r(t + dt) = (r(t) + dt / tau r_eq(p)) / (1 + dt / tau), r_eq = r0 + p r0^2 / E, as in the example. The radius is
state: built with --handle-state, the FMU can be rolled back to a window's start through its FMU state.

    pythonfmu3 build -f damped_wall_fmu.py -d OUT --handle-state
"""

import math

import numpy as np
from pythonfmu3 import Dimension, Float64, Fmi3Causality, Fmi3Slave, Fmi3Variability

NODES = 101
A0, E, TAU = 1.0, 12500.0, 0.05
R0 = math.sqrt(A0 / math.pi)


class DampedWallFmu(Fmi3Slave):
    """Section of the tube whose radius relaxes towards the spring law of the pressure."""

    author = "cosim tests"
    description = "damped wall of the elastic tube"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.pressure = np.zeros(NODES)
        self.radius = np.full(NODES, R0)
        self.section = np.full(NODES, A0)
        self.time = 0.0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))
        for name, causality in (("pressure", Fmi3Causality.input), ("section", Fmi3Causality.output),
                                ("radius", Fmi3Causality.local)):
            self.register_variable(Float64(name, causality=causality, variability=Fmi3Variability.continuous,
                                           dimensions=[Dimension(start=f"{NODES}")], setter=self.setter(name)))

    def setter(self, name):
        """An array variable's setter (pythonfmu3's own reshapes with an argument NumPy 2.4 no longer has)."""
        return lambda values: setattr(self, name, np.asarray(values, dtype=np.float64).reshape(NODES))

    def do_step(self, current_time, step_size):
        ratio = step_size / TAU
        self.radius = (self.radius + ratio * (R0 + self.pressure * R0 ** 2 / E)) / (1.0 + ratio)
        self.section = math.pi * self.radius ** 2
        return True
