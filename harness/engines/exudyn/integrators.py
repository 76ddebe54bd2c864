"""The Exudyn time integrators the harness runs, and the rotation parameters each needs.

Exudyn solves the equations of motion of bodies in redundant (absolute) coordinates: six
coordinates per rigid body (position of its reference point and a rotation parameterisation),
joints as algebraic constraints with Lagrange multipliers. Which solver handles which
constraints, and on which rotation nodes (measured here: generalized-alpha on Euler-parameter
nodes stops with a Newton failure on the spinning heavy top; on rotation-vector nodes, Exudyn's
Lie-group form, it runs):

* ``GeneralizedAlpha``: Lie-group generalized-alpha on rotation-vector nodes, spectral radius
  0.9 (``harness.engines.exudyn.engine.SPECTRAL_RADIUS``: at 1 the undamped index-3 multipliers
  wander), constraints at position level (index 3), full Newton iteration per step (one
  Jacobian per step with the sparse LU of a large system: ``engine.linear_solver``). Order 2;
  its Lagrange multipliers (the joint reactions and contact forces) order 1 (``reaction_order``:
  the order reduction of index-3 generalized-alpha without perturbed starting values, Arnold &
  Bruls 2007; measured on the spring pendulum's joint moment at a sampled set (m = 1.99 kg, k = 301
  N/m, theta0 = -1.54 rad): 3.1e-6, 1.6e-6 of the force scale
  at dt 1e-3, 5e-4 s).
* ``TrapezoidalIndex2``: the implicit trapezoidal rule on Euler-parameter nodes (their unit-norm
  condition one more algebraic equation), constraints at velocity level (index 2: the position
  constraints drift slowly). Order 2.
* ``RK44``, ``RK67``: explicit Runge-Kutta of order 4 and 6 with Lie-group updates of
  rotation-vector nodes. Exudyn's explicit solvers take no algebraic equations, hence no joint,
  no loop joint and no rolling contact: they run only scenes whose bodies are all free and
  unconnected (else the run is "unsupported").
"""

from __future__ import annotations

from harness.engines.base import Integrator, integrator_table

METHODS = integrator_table(
    Integrator("GeneralizedAlpha", "fixed", 2, None,
               "Lie-group generalized-alpha, spectral radius 0.9, index-3 constraints, rotation-vector nodes",
               reaction_order=1),
    Integrator("TrapezoidalIndex2", "fixed", 2, None,
               "implicit trapezoidal rule, index-2 (velocity-level) constraints, Euler-parameter nodes"),
    Integrator("RK44", "fixed", 4, 4, "classical Runge-Kutta, Lie-group rotation-vector nodes; free bodies only"),
    Integrator("RK67", "fixed", 6, 7, "explicit Runge-Kutta of order 6, Lie-group rotation-vector nodes; free bodies only"),
)

#: Methods that solve algebraic equations (joints, rolling contacts); the others run free bodies only.
IMPLICIT = ("GeneralizedAlpha", "TrapezoidalIndex2")

#: Exudyn node type (rotation parameterisation) per method (see the module docstring).
NODE_TYPE = {"GeneralizedAlpha": "RotationRotationVector", "TrapezoidalIndex2": "RotationEulerParameters",
             "RK44": "RotationRotationVector", "RK67": "RotationRotationVector"}
