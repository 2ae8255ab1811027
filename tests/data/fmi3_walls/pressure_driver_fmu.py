"""A pressure signal as an FMI 3.0 Co-Simulation FMU made by pythonfmu3, with outputs and no Float64 input: it
drives the tube's wall one way, p(t, node) = P0 sin(2 pi F t) (1 - node / 100). Its Int32 input ``mode`` is
never coupled (FMUs of other makers carry such variables).

    pythonfmu3 build -f pressure_driver_fmu.py -d OUT
"""

import math

import numpy as np
from pythonfmu3 import Dimension, Float64, Fmi3Causality, Fmi3Slave, Fmi3Variability, Int32

NODES = 101
P0, F = 50.0, 2.0


class PressureDriverFmu(Fmi3Slave):
    """The tube's pressure as a function of time alone."""

    author = "cosim tests"
    description = "a pressure signal that drives the tube's wall"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.pressure = np.zeros(NODES)
        self.mode = 0
        self.time = 0.0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))
        self.register_variable(Float64("pressure", causality=Fmi3Causality.output,
                                       variability=Fmi3Variability.continuous,
                                       dimensions=[Dimension(start=f"{NODES}")], setter=self.set_pressure))
        self.register_variable(Int32("mode", causality=Fmi3Causality.input, variability=Fmi3Variability.discrete))

    def set_pressure(self, values):
        """pythonfmu3's own setter reshapes with an argument NumPy 2.4 no longer has."""
        self.pressure = np.asarray(values, dtype=np.float64).reshape(NODES)

    def do_step(self, current_time, step_size):
        t = current_time + step_size
        self.pressure = P0 * math.sin(2.0 * math.pi * F * t) * (1.0 - np.arange(NODES) / (NODES - 1))
        return True
