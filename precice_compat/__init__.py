"""preCICE cases under cosim: a ``precice-config.xml`` read into a scene (``config``), the case file that names it and
each participant's program (``case``), and, in ``participant/``, the ``precice`` package a participant imports, served
by cosim's coupler instead of libprecice (installable alone: ``pip install ./precice_compat/participant``)."""
