"""The tube's wall as a preCICE v3 participant: the loop a preCICE user writes, around cosim's tube wall solver.

Usage: python3 SolidSolver.py ../precice-config.xml
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
    participant = precice.Participant("Solid", config, 0, 1)
    axis = solid.meshes()["axis"][:, 0]
    vertex_ids = participant.set_mesh_vertices("Solid-Nodes", np.column_stack([axis, np.zeros_like(axis)]))
    solid.enter_initialization_mode(0.0, 0.0)
    solid.exit_initialization_mode()
    if participant.requires_initial_data():
        participant.write_data("Solid-Nodes", "CrossSectionLength", vertex_ids,
                               solid.get_values(["section"])["section"])
    participant.initialize()
    window = 0
    while participant.is_coupling_ongoing():
        if participant.requires_writing_checkpoint():
            pass        # quasi-static: the wall keeps no state, so its checkpoint is empty (preCICE wants it asked)
        dt = participant.get_max_time_step_size()
        pressure = participant.read_data("Solid-Nodes", "Pressure", vertex_ids, dt)
        solid.set_values({"pressure": pressure})
        solid.do_step(window * dt, dt)
        participant.write_data("Solid-Nodes", "CrossSectionLength", vertex_ids,
                               solid.get_values(["section"])["section"])
        participant.advance(dt)
        if not participant.requires_reading_checkpoint():
            window += 1
    participant.finalize()


if __name__ == "__main__":
    main(sys.argv[1])
