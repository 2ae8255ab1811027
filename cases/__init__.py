"""One package per case: what belongs to a scene and to no other (its plots, report figures, stability matrix,
diagnostics). Each registers its hooks as entry points named by its case (a scene's ``case`` key)."""
