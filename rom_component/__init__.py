"""Non-intrusive solid ROMs, by family.

- ``static/``: the quasi-static ROM (reduction, regression, selection, estimator, online path, training, component);
- ``dynamic/``: the ROM with memory of a structure with inertia (the step map: model, training, online path,
  component);
- ``reduction/``: POD, encoders and decoders both families use;
- ``fmu/``: the FMU export of either family and its C code;
- ``report/``: ``cosim report``;
- at the top: the commands, the model file and its checks, the parts' registries, the training envelope, the
  recorded data a training reads.
"""
