"""Exudyn engine: bodies in redundant coordinates, joints as algebraic constraints (``engine``)."""
