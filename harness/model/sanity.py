"""Physical sanity of a ``Multibody``: positive masses, valid inertia tensors, finite state; the
joint rules come from the joint table (``harness.model.joints``), the force elements' rules from
the force table (``harness.model.forces``)."""

from __future__ import annotations

import numpy as np

from harness.model.errors import InputError
from harness.model.forces import check_forces
from harness.model.joints import JOINTS, TRANSLATIONAL, keeps_axis, loop_kinds
from harness.model.loop_closure import initial_residuals
from harness.model.multibody import Multibody


def check_inertia(I: np.ndarray, what: str, source: str) -> None:
    """Raise InputError unless ``I`` is a finite, symmetric, positive definite inertia tensor
    whose principal moments satisfy the triangle inequality (each <= sum of the other two)."""
    I = np.asarray(I, dtype=float)
    if I.shape != (3, 3) or not np.all(np.isfinite(I)):
        raise InputError(f"{source}: {what}: inertia must be a finite 3x3 matrix")
    if not np.allclose(I, I.T, rtol=1e-12, atol=1e-15 * max(1.0, np.abs(I).max())):
        raise InputError(f"{source}: {what}: inertia tensor is not symmetric")
    moments = np.linalg.eigvalsh(I)
    if moments[0] <= 0.0:
        raise InputError(f"{source}: {what}: inertia is not positive definite (principal moments {moments.tolist()})")
    slack = 1e-12 * moments.sum()
    if moments[2] > moments[0] + moments[1] + slack:
        raise InputError(
            f"{source}: {what}: principal moments {moments.tolist()} violate the triangle inequality"
            " (largest must not exceed the sum of the other two)"
        )


def check_multibody(model: Multibody, source: str) -> None:
    """Raise InputError naming the first non-physical quantity in ``model``."""
    names = set()
    for b in model.bodies:
        jt = JOINTS.get(b.joint)
        if jt is None:
            raise InputError(f"{source}: body {b.name!r}: unknown joint type {b.joint!r}")
        if b.parent is not None and b.parent not in names:
            raise InputError(f"{source}: body {b.name!r}: parent {b.parent!r} must come first")
        if jt.root_only and b.parent is not None:
            raise InputError(f"{source}: body {b.name!r}: a {jt.name} joint must attach to the world")
        names.add(b.name)
        if not (np.isfinite(b.mass) and b.mass > 0.0):
            raise InputError(f"{source}: body {b.name!r}: mass must be positive and finite, got {b.mass!r}")
        check_inertia(b.I_Cm_B, f"body {b.name!r}", source)
        for label, vec in (("p_PB_P", b.p_PB_P), ("p_BCm_B", b.p_BCm_B), ("axis_B", b.axis_B)):
            if not np.all(np.isfinite(vec)):
                raise InputError(f"{source}: body {b.name!r}: {label} is not finite")
        if jt.axis == TRANSLATIONAL and abs(float(np.linalg.norm(b.axis_B)) - 1.0) > 1e-9:  # q is a length along it
            raise InputError(f"{source}: body {b.name!r}: a {jt.name} axis must be a unit vector, got {np.asarray(b.axis_B).tolist()}")
        q, v = np.asarray(model.q0[b.name], float), np.asarray(model.v0[b.name], float)
        if q.shape != (jt.nq,) or v.shape != (jt.nv,):
            raise InputError(f"{source}: body {b.name!r}: initial state has the wrong size for a {b.joint} joint")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            raise InputError(f"{source}: body {b.name!r}: initial state is not finite")
    if not np.all(np.isfinite(model.gravity_W)):
        raise InputError(f"{source}: gravity is not finite")
    check_forces(model, source)
    check_loops(model, source)
    check_contacts(model, source)


def check_contacts(model: Multibody, source: str) -> None:
    """Raise InputError unless every rolling contact (``Multibody.contacts``) names a body of the
    model (any body: a root or one deep in the tree) and has a positive finite radius, a
    half-thickness >= 0, a finite ``circle_z`` if any, and a name no other contact has (its force
    columns ``<name>.Fx`` ...)."""
    bodies = set(model.body_names)
    seen = set()
    for c in getattr(model, "contacts", ()):
        where = f"rolling contact {c.name!r}"
        if c.name in seen:
            raise InputError(f"{source}: {where}: name used twice")
        seen.add(c.name)
        if c.body not in bodies:
            raise InputError(f"{source}: {where}: unknown body {c.body!r}")
        if not (np.isfinite(c.radius) and c.radius > 0.0):
            raise InputError(f"{source}: {where}: radius must be positive and finite, got {c.radius!r}")
        if not (np.isfinite(c.half_thickness) and c.half_thickness >= 0.0):
            raise InputError(f"{source}: {where}: half_thickness must be >= 0 and finite, got {c.half_thickness!r}")
        if c.circle_z is not None and not np.isfinite(c.circle_z):
            raise InputError(f"{source}: {where}: circle_z must be finite, got {c.circle_z!r}")


#: How far (m, rad; m/s, rad/s) the initial state may be from closing a loop: a builder assembles
#: it to round-off, a hand-typed initial state that does not close is refused.
LOOP_ASSEMBLY_TOL = 1e-9


def check_loops(model: Multibody, source: str) -> None:
    """Raise InputError unless every cut joint (``Multibody.loops``) names known bodies and a loop
    kind, has finite points and unit axes, and the initial state closes it (``LOOP_ASSEMBLY_TOL``
    times the larger of 1 and the model's size; ``harness.model.loop_closure``)."""
    if not model.loops:
        return
    bodies = set(model.body_names)
    seen = set()
    for loop in model.loops:
        where = f"loop joint {loop.name!r}"
        if loop.name in seen or loop.name in bodies:
            raise InputError(f"{source}: {where}: name used twice")
        seen.add(loop.name)
        if loop.kind not in loop_kinds():
            raise InputError(f"{source}: {where}: kind must be one of {', '.join(loop_kinds())}, got {loop.kind!r}")
        for body in (loop.body_a, loop.body_b):
            if body is not None and body not in bodies:
                raise InputError(f"{source}: {where}: unknown body {body!r}")
        if loop.body_a == loop.body_b:
            raise InputError(f"{source}: {where}: both ends on body {loop.body_a!r}")
        for label, vec in (("p_A", loop.p_A), ("p_B", loop.p_B), ("axis_A", loop.axis_A), ("axis_B", loop.axis_B)):
            if np.shape(vec) != (3,) or not np.all(np.isfinite(vec)):
                raise InputError(f"{source}: {where}: {label} must be three finite numbers")
        if keeps_axis(loop.kind):
            for label, vec in (("axis_A", loop.axis_A), ("axis_B", loop.axis_B)):
                if abs(float(np.linalg.norm(vec)) - 1.0) > 1e-9:
                    raise InputError(f"{source}: {where}: {label} must be a unit vector")
            if not (np.isfinite(loop.hinge_span) and loop.hinge_span > 0.0):
                raise InputError(f"{source}: {where}: hinge_span must be positive")
    size = max([1.0] + [float(np.linalg.norm(b.p_PB_P)) for b in model.bodies])
    for name, res in initial_residuals(model).items():
        for kind, value in res.items():
            if not value <= LOOP_ASSEMBLY_TOL * size:
                raise InputError(f"{source}: loop joint {name!r}: the initial state does not close the loop "
                                 f"({kind} residual {value:.3g})")
