"""Work-precision sweeps (``harness workprecision``)."""
