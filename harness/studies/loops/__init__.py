"""The closed-loop study (``harness loop-study``): loop closure, energy and exact error against step size."""

#: The engine whose soft loop settings the study varies: MuJoCo states a cut joint as ``<connect>``
#: equalities whose ``solref``/``solimp`` set how far the loop opens, which no other engine has, so
#: the study names that engine here, once (``tests/engines/test_engine_names.py`` lists this
#: exception); the other engines come from the registry (``harness.engines.with_loops``).
SOFT_LOOP_ENGINE = "mujoco"
