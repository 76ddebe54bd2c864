"""The MuJoCo engine: MJCF loading and editing, stepping, rolling-contact settings, ``mujoco.rollout``."""
