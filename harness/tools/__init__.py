"""Model debugging: inspect, check, debug, dynamics terms, loaded-model readers; an engine's linearisation about a state (``linearize``)."""
