"""The tube's fluid as a preCICE v2 participant (``precice.Interface``), around cosim's tube fluid solver.

Usage: python3 FluidSolverV2.py ../precice-config-v2.xml [END]
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
    interface = precice.Interface("Fluid", config, 0, 1)
    mesh_id = interface.get_mesh_id("Fluid-Nodes-Mesh")
    pressure_id = interface.get_data_id("Pressure", mesh_id)
    section_id = interface.get_data_id("CrossSectionLength", mesh_id)
    axis = fluid.meshes()["axis"][:, 0]
    vertex_ids = interface.set_mesh_vertices(mesh_id, np.column_stack([axis, np.zeros_like(axis)]))
    fluid.enter_initialization_mode(0.0, end)
    fluid.exit_initialization_mode()
    dt = interface.initialize()
    if interface.is_action_required(precice.action_write_initial_data()):
        interface.write_block_scalar_data(pressure_id, vertex_ids, fluid.get_values(["pressure"])["pressure"])
        interface.mark_action_fulfilled(precice.action_write_initial_data())
    interface.initialize_data()
    window = 0
    state = None
    while interface.is_coupling_ongoing():
        if interface.is_action_required(precice.action_write_iteration_checkpoint()):
            state = fluid.save_state()
            interface.mark_action_fulfilled(precice.action_write_iteration_checkpoint())
        section = interface.read_block_scalar_data(section_id, vertex_ids)
        fluid.set_values({"section": section})
        fluid.do_step(window * dt, dt)
        interface.write_block_scalar_data(pressure_id, vertex_ids, fluid.get_values(["pressure"])["pressure"])
        interface.advance(dt)
        if interface.is_action_required(precice.action_read_iteration_checkpoint()):
            fluid.restore_state(state)
            interface.mark_action_fulfilled(precice.action_read_iteration_checkpoint())
        else:
            window += 1
    interface.finalize()


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]) if len(sys.argv) > 2 else 120.0)
