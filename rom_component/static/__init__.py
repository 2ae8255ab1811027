"""The quasi-static solid ROM: reduction parts and regression composed, trained, served online, as a component."""
