"""Stress catalogue and stability map (``harness stress``)."""
