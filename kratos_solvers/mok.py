"""Mok's fluid and structure: the project's Kratos components with this case's boundaries, materials and
generated meshes (shared/scenes/mok.md).

- ``MokFluid``: the ALE fluid with the monolithic VMS element; inlet v_x = 4 v_ref(t) y (1 - y),
  v_ref ramped by (1 - cos(pi t / 10)) / 2 over the first 10 s; slip on the top wall, no slip on the
  bottom and the flexible wall, p = 0 at the outlet.
- ``MokStructure``: the dynamic solid (Newmark by default), total Lagrangian quadrilaterals, linear
  elastic plane stress, recording points A and B.

Both take the scene's ``mesh`` section (the resolution) and make the meshes on first use
(``kratos_solvers.mok_mesh``): the interface nodes of the two meshes coincide.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cosim.schema import AnyTable, Choice, Positive, Required, Value
from kratos_solvers.fluid import KratosFluid
from kratos_solvers.mok_mesh import BOTTOM, FLUID_INTERFACE, POINT_A, POINT_B, RESOLUTION, TOP, mok_meshes
from kratos_solvers.solid import CONSTITUTIVE_LAWS, LINEAR_SOLVERS, KratosSolid

MESH_SCHEMA = {"wall_cells": RESOLUTION["wall_cells"], "wall_size": Positive(RESOLUTION["wall_size"]),
               "far_size": Positive(RESOLUTION["far_size"]),
               "grading_distance": Positive(RESOLUTION["grading_distance"])}
TIME_SCHEMA = {"start": 0.0, "end": Required(float), "dt": Positive()}
FLUID_SCHEMA = {
    "time": TIME_SCHEMA,
    "flow": {"density": Positive(956.0), "viscosity": Positive(0.145), "reference_velocity": Positive(0.06067),
             "ramp_time": Positive(10.0)},
    "mesh": MESH_SCHEMA,
    "tolerance": Positive(1e-6),
    "max_iterations": Positive(10),
    "on_unconverged": Choice("warn", ("warn", "fail")),
    "interface": FLUID_INTERFACE,
}
STRUCTURE_SCHEMA = {
    "time": TIME_SCHEMA,
    "mesh": MESH_SCHEMA,
    "young_modulus": Positive(2.3e6),
    "poisson_ratio": Value(0.45, low=0.0, high=0.5, high_open=True),
    "density": Positive(1500.0),
    "constitutive_law": Choice("LinearElasticPlaneStress2DLaw", CONSTITUTIVE_LAWS),
    "dynamics": Choice("newmark", ("static", "newmark", "bossak")),
    "probes": AnyTable(),
    "linear_solver": Choice("sparse_lu", tuple(LINEAR_SOLVERS)),
    "tolerance": Positive(1e-6),
    "max_iterations": Positive(25),
    "on_unconverged": Choice("warn", ("warn", "fail")),
    "interface": "StructureInterface2D_Struc_Fsi",
    "clamped": "DISPLACEMENT_BCDisp",
}
PROBES = {"point_a": list(POINT_A), "point_b": list(POINT_B)}


class MokFluid(KratosFluid):
    """The ALE fluid of Mok's channel."""

    parameter_schema = FLUID_SCHEMA
    problem_name = "mok_fluid"
    walls = (BOTTOM,)
    slip_walls = (TOP,)
    element = "vms"

    def mesh_file(self, settings: dict[str, Any]) -> Path:
        return mok_meshes(settings["mesh"])["fluid"]

    @staticmethod
    def viscosity(flow: dict) -> float:
        return flow["viscosity"]

    @staticmethod
    def inlet_moduli(flow: dict) -> list[tuple[list, str]]:
        profile = f"4*{flow['reference_velocity']!r}*y*(1-y)"
        ramp = flow["ramp_time"]
        return [([0.0, ramp], f"0.5*(1-cos(pi*t/{ramp!r}))*{profile}"), ([ramp, "End"], profile)]


class MokStructure(KratosSolid):
    """Mok's flexible wall: dynamic, geometrically nonlinear, points A and B recorded."""

    name = "structure"
    parameter_schema = STRUCTURE_SCHEMA
    problem_name = "mok_structure"

    def instantiate(self, parameters: Any) -> None:
        super().instantiate({"probes": PROBES, **parameters})

    def mesh_file(self, settings: dict[str, Any]) -> Path:
        return mok_meshes(settings["mesh"])["solid"]
