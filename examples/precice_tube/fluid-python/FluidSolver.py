"""The tube's fluid as a preCICE v3 participant: the loop a preCICE user writes, around cosim's tube fluid solver.

Usage: python3 FluidSolver.py ../precice-config.xml [END]   (END: the run's end in s, for the inlet signal; 120)
"""

import sys

import numpy as np
import precice

from fluid_component.tube import TubeFluid

TUBE = {"length": 10.0, "cells": 100, "a0": 1.0}
INLET = {"f": 2.0, "h": 6.0, "table": ""}
FLUID = {"tube": TUBE, "inlet": INLET, "rho": 1.0, "v_ref": 6.0, "newton_tolerance": 1e-10}


def main(config: str, end: float) -> None:
    fluid = TubeFluid()
    fluid.instantiate(FLUID)
    participant = precice.Participant("Fluid", config, 0, 1)
    axis = fluid.meshes()["axis"][:, 0]
    vertex_ids = participant.set_mesh_vertices("Fluid-Nodes", np.column_stack([axis, np.zeros_like(axis)]))
    fluid.enter_initialization_mode(0.0, end)
    fluid.exit_initialization_mode()
    if participant.requires_initial_data():
        participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, fluid.get_values(["pressure"])["pressure"])
    participant.initialize()
    window = 0                    # windows done: the time is window * dt, as the coupler counts it
    state = None
    while participant.is_coupling_ongoing():
        if participant.requires_writing_checkpoint():
            state = fluid.save_state()
        dt = participant.get_max_time_step_size()
        section = participant.read_data("Fluid-Nodes", "CrossSectionLength", vertex_ids, dt)
        fluid.set_values({"section": section})
        fluid.do_step(window * dt, dt)
        participant.write_data("Fluid-Nodes", "Pressure", vertex_ids, fluid.get_values(["pressure"])["pressure"])
        participant.advance(dt)
        if participant.requires_reading_checkpoint():
            fluid.restore_state(state)
        else:
            window += 1
    participant.finalize()


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]) if len(sys.argv) > 2 else 120.0)
