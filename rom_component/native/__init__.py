"""The ROMs' native runtime: their C code (the runtime, one source per ROM) and its build into the library the
families' in-process ``arithmetic = "compiled"`` paths load. The FMU export (``rom_component.fmu``) compiles the
same sources with its FMI entry points."""
