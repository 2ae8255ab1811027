"""The spring wall of examples/spring_wall as an FMI 3.0 Co-Simulation FMU made by pythonfmu3 (another source than
cosim export-fmu): the tube's pressure in, its section out, one array of 101 nodes each. Each node's radius is
r = r0 + p r0^2 / E and the section a = pi r^2, as in the example. It holds no state of its own.

    pythonfmu3 build -f spring_wall_fmu.py -d OUT
"""

import math

import numpy as np
from pythonfmu3 import Dimension, Float64, Fmi3Causality, Fmi3Slave, Fmi3Variability

NODES = 101                  # the tube's 100 cells
A0, E = 1.0, 12500.0         # the scene's [tube] a0 and the wall's modulus
R0 = math.sqrt(A0 / math.pi)


class SpringWallFmu(Fmi3Slave):
    """Section of the tube for a given pressure, one linear spring per node."""

    author = "cosim tests"
    description = "spring wall of the elastic tube"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.pressure = np.zeros(NODES)
        self.section = np.full(NODES, A0)
        self.time = 0.0
        self.clock = None
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))
        for name, causality in (("pressure", Fmi3Causality.input), ("section", Fmi3Causality.output)):
            self.register_variable(Float64(name, causality=causality, variability=Fmi3Variability.continuous,
                                           dimensions=[Dimension(start=f"{NODES}")], setter=self.setter(name)))

    def setter(self, name):
        """An array variable's setter (pythonfmu3's own reshapes with an argument NumPy 2.4 no longer has)."""
        return lambda values: setattr(self, name, np.asarray(values, dtype=np.float64).reshape(NODES))

    def exit_initialization_mode(self):
        self.clock = None       # pythonfmu3 does not pass the start time on: the first step sets the clock

    def do_step(self, current_time, step_size):
        # FMI's call sequence, as the Reference FMUs check it: each step starts where the last one ended (a
        # window again needs a reset, or the FMU state)
        if self.clock is not None and abs(current_time - self.clock) > 1e-9 * max(1.0, abs(current_time)):
            return False
        self.clock = current_time + step_size
        self.section = math.pi * (R0 + self.pressure * R0 ** 2 / E) ** 2
        return True
