"""PyBullet engine: the scene's URDF as a Bullet btMultiBody (Featherstone), stepped by semi-implicit Euler (``engine``)."""
