"""Writing results: atomic files, figures, provenance."""
