"""Work-precision sweeps (``harness workprecision``)."""

#: The engine the study's targets are set against: the reference engine's compiled form must beat
#: MuJoCo RK4 at equal error (the head to head) and ``mujoco.rollout`` in batched throughput, and
#: MuJoCo's own variants (``rollout``, the stepping ``loop``) are timed. The study names that
#: engine here, once (``tests/engines/test_engine_names.py`` lists this exception); every curve
#: comes from the registry (``harness.engines.Declaration.curves``).
BASELINE = "mujoco"
