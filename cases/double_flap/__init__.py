"""The double flap (the paper's second example, on Kratos): its run and report plots, and the diagnostics of its
ROM runs (``python -m cases.double_flap.NAME``)."""
