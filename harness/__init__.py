"""harness: a cross-check harness for rigid-body dynamics (in-house Newton-Euler, MuJoCo, Pinocchio,
Exudyn, Drake)."""

__version__ = "0.1.0"
