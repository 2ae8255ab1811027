"""The tube's wall as a preCICE v2 participant (``precice.Interface``), around cosim's tube wall solver.

Usage: python3 SolidSolverV2.py ../precice-config-v2.xml
"""

import sys

import numpy as np
import precice

from solid_component.tube import TubeSolid

SOLID = {"tube": {"length": 10.0, "cells": 100, "a0": 1.0}, "E_small": 12500.0, "E_large": 2500.0, "s0": 20.0,
         "eps0": 2e-3}


def main(config: str) -> None:
    solid = TubeSolid()
    solid.instantiate(SOLID)
    interface = precice.Interface("Solid", config, 0, 1)
    mesh_id = interface.get_mesh_id("Solid-Nodes-Mesh")
    section_id = interface.get_data_id("CrossSectionLength", mesh_id)
    pressure_id = interface.get_data_id("Pressure", mesh_id)
    axis = solid.meshes()["axis"][:, 0]
    vertex_ids = interface.set_mesh_vertices(mesh_id, np.column_stack([axis, np.zeros_like(axis)]))
    solid.enter_initialization_mode(0.0, 0.0)
    solid.exit_initialization_mode()
    dt = interface.initialize()
    if interface.is_action_required(precice.action_write_initial_data()):
        interface.write_block_scalar_data(section_id, vertex_ids, solid.get_values(["section"])["section"])
        interface.mark_action_fulfilled(precice.action_write_initial_data())
    interface.initialize_data()
    window = 0
    while interface.is_coupling_ongoing():
        if interface.is_action_required(precice.action_write_iteration_checkpoint()):
            interface.mark_action_fulfilled(precice.action_write_iteration_checkpoint())
        pressure = interface.read_block_scalar_data(pressure_id, vertex_ids)
        solid.set_values({"pressure": pressure})
        solid.do_step(window * dt, dt)
        interface.write_block_scalar_data(section_id, vertex_ids, solid.get_values(["section"])["section"])
        interface.advance(dt)
        if interface.is_action_required(precice.action_read_iteration_checkpoint()):
            interface.mark_action_fulfilled(precice.action_read_iteration_checkpoint())
        else:
            window += 1
    interface.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
