"""A trained ROM as an FMI 2.0 or FMI 3.0 Co-Simulation FMU: the export, and the FMI entry points compiled with the
native runtime (``rom_component.native``)."""
