"""The closed-loop study (``harness loop-study``): loop closure, energy and exact error against step size."""
