"""Benchmarks and studies, each with its run and its report apart."""
