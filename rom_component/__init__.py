"""Non-intrusive solid ROM: POD encoder/decoder, regression, selection, persistence, component."""
