"""Parameter sweeps: the engines' disagreement and drift over a scene's parameter space."""
