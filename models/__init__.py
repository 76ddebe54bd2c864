"""The systems as data: one folder per scene with its ``scene.toml``, MJCF, URDF and README.

Installed as the package ``harness.models`` (``pyproject.toml``) so that a wheel carries every
scene; ``harness.model.scene.MODELS_DIR`` finds this folder with ``importlib.resources``.
"""
