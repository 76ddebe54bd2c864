"""The rolling-disk study (``harness rolling-study``)."""

#: The engine whose contact settings the study measures: the study is about MuJoCo's options for a
#: soft frictional contact (solref, solimp, cone, impratio, noslip, condim), which no other engine
#: has, so it names that engine here, once (``tests/engines/test_engine_names.py`` lists this
#: exception); every other engine comes from the registry (``harness.engines.with_rolling``).
SETTINGS_ENGINE = "mujoco"
