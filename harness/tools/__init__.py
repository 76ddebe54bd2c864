"""Model debugging: inspect, check, debug, dynamics terms, loaded-model readers."""
