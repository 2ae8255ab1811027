"""Any FMI 2.0 or FMI 3.0 Co-Simulation FMU behind the component contract (loaded with fmpy)."""
