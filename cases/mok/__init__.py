"""Mok's benchmark (a flexible wall in a convergent channel, strongly coupled, on Kratos): its meshes, its
components' settings, run plots and stability rows."""
