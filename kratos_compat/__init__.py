"""Kratos CoSimulation cases under cosim: a ``ProjectParametersCoSim.json`` and its solvers' own files, read into a
cosim scene whose components are Kratos analysis stages, each in its own process."""
