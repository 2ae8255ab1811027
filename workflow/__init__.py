"""Workflows above the coupler and the ROM: the ROM evaluation campaign (FOM-FOM runs, training, ROM-FOM runs,
report), which calls both directly."""
