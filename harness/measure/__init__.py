"""What is measured on a run: the common trajectory, invariants, comparisons, contact metrics."""
