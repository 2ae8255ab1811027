"""Non-intrusive solid ROMs, by family.

- ``static/``: the quasi-static ROM (reduction, regression, selection, estimator, online path, training, component);
- ``dynamic/``: the ROM with memory of a structure with inertia (the step map: model, training, online path,
  component);
- ``reduction/``: POD, encoders and decoders both families use;
- ``native/``: the ROMs' C code (the runtime, a source per ROM) and its build, which the families' in-process
  compiled paths load;
- ``fmu/``: the FMU export of either family (the FMI entry points on the native runtime);
- ``report/``: ``cosim report``;
- at the top: the commands, the model file and its checks, the parts' registries, the training envelope, the
  recorded data a training reads.
"""
