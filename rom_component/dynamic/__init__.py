"""The ROM with memory of a structure with inertia: the step map, its training, its online path, its component."""
