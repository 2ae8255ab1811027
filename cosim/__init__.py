"""Co-simulation runtime: component contract, wire protocol, processes, scenes, results."""

__version__ = "0.1.0"
