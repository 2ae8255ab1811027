"""``cosim report``: ROM-FOM runs against their FOM-FOM references."""
