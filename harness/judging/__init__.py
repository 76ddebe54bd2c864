"""Judging runs by how their error converges: each check's error model (observed order, the floor
that does not vanish with the step, the resolution) and its class (``error_model``), and the
further runs that measure it (``refinement``)."""
