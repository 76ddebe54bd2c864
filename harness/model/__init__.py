"""The system as the harness holds it: scene descriptions, the multibody, its physical sanity, kinematics, rotations, rolling-contact geometry, per-system builders."""
