"""``harness validate``: cases run in isolated workers, tolerances, reports."""
