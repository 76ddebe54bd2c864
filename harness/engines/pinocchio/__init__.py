"""The Pinocchio engine: URDF loading and editing, Lie-group integrators, the ideal rolling contact."""
