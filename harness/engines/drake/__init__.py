"""Drake engine: the scene's URDF in a continuous-time MultibodyPlant, Drake's own integrators (``engine``)."""
