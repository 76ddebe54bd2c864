"""The benchmark report (``harness benchmark``): the published multibody benchmarks the scenes
reproduce, per problem and engine (``run``: the study, ``report``: what it writes)."""
