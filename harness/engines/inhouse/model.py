"""The in-house model: everything constant about a ``Multibody`` precomputed once, and the
layout of the maximal-coordinate state vector.

State vector ``y`` (length 13 * nb, nb = number of bodies, bodies in ``Multibody`` order)::

    y = [ p_WCm_W (nb*3) | quat_WB (nb*4) | v_WCm_W (nb*3) | w_WB_B (nb*3) ]

* ``p_WCm_W``: centre-of-mass position in world (m);
* ``quat_WB``: unit quaternion body -> world, ``wxyz``;
* ``v_WCm_W``: centre-of-mass velocity in world (m/s);
* ``w_WB_B``: angular velocity of the body relative to world, expressed in the BODY frame (rad/s).

The generalised velocity of the Newton-Euler equations is the contiguous tail
``u = y[7nb:] = [v_WCm_W (nb*3) | w_WB_B (nb*3)]``; the mass matrix in these coordinates is
``M = blockdiag(m_1 I3, ..., m_nb I3, I_1, ..., I_nb)`` with ``I_i`` the inertia about the
centre of mass in the body frame (kg m^2).

Joints (``harness.multibody``) become constraints between a child body c and its parent p
(p = world when ``parent`` is None; the world is handled as an extra body, index nb, at rest at
the origin with identity orientation):

* ``ball``: the joint point coincides in world, 3 rows. In the child it is the body-frame
  origin, i.e. ``r_c = -p_BCm_B`` from the child's centre of mass (child frame); in the parent it
  is ``p_PB_P``, i.e. ``r_p = p_PB_P - p_PCm_P`` from the parent's centre of mass (parent frame),
  or the world point ``p_PB_P`` for a world parent.
* ``hinge``: ball + 2 rows ``(R_c a)·(R_p b_k) = 0``, k = 1, 2, where ``a`` is the unit hinge
  axis in the child frame and ``b_1, b_2`` are unit vectors perpendicular to the same axis
  fixed in the parent frame (the frames are parallel at zero joint angle).
* ``free``: no constraint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from harness import kinematics, rotations
from harness.multibody import Multibody


@dataclass(frozen=True)
class NEModel:
    """Constant data of the Newton-Euler model of one ``Multibody`` (SI units).

    Attributes:
        body_names: body order of the state vector.
        nb: number of bodies.
        mass: (nb,) kg.
        I_B, Iinv_B: (nb, 3, 3) inertia about the centre of mass in the body frame, and inverse.
        weight_W: (nb, 3) gravity force m g in world (N).
        Minv: (6nb, 6nb) inverse mass matrix for ``u = [v_WCm_W..., w_WB_B...]``.
        joint_names: child body name of each constrained joint (ball or hinge), in body order.
        joint_types: ``"ball"`` or ``"hinge"`` per constrained joint.
        ends: (2*nj,) body index of the child ends then of the parent ends (nb = world).
        r_end: (2*nj, 3) joint point relative to the end body's centre of mass, in that body's
            frame (for a world parent: the joint point in world), m.
        hinge_joint: (nh,) index into the constrained joints of each hinge.
        hinge_child, hinge_parent: (nh,) body indices (nb = world).
        a_c: (nh, 3) unit hinge axis, child frame. b_p: (nh, 2, 3) unit vectors perpendicular
            to the axis, parent frame.
        nc: number of constraint rows, 3 nj + 2 nh (ball rows first, joint by joint, then the
            two orientation rows of each hinge).
        J_template: (nc, 6(nb+1)) constant part of the Jacobian (the +-I3 translational blocks),
            columns ``[v bodies | w bodies | v world | w world]``.
        J_rows, J_cols: index arrays of the configuration-dependent Jacobian entries, in the
            order ``newton_euler`` writes their values.
        forces: ``(body index, r_B, force_W)`` per prescribed point force, ``r_B`` the point
            relative to the centre of mass in the body frame (m).
    """

    body_names: tuple[str, ...]
    nb: int
    mass: np.ndarray
    I_B: np.ndarray
    Iinv_B: np.ndarray
    weight_W: np.ndarray
    Minv: np.ndarray
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    ends: np.ndarray
    r_end: np.ndarray
    end_sign: np.ndarray
    hinge_joint: np.ndarray
    hinge_child: np.ndarray
    hinge_parent: np.ndarray
    a_c: np.ndarray
    b_p: np.ndarray
    nc: int
    J_template: np.ndarray
    J_rows: np.ndarray
    J_cols: np.ndarray
    forces: tuple[tuple[int, np.ndarray, Callable[[float], np.ndarray]], ...]

    @property
    def nj(self) -> int:
        """Number of constrained joints (ball or hinge)."""
        return len(self.joint_names)

    @property
    def nh(self) -> int:
        """Number of hinges."""
        return len(self.hinge_joint)

    @property
    def ny(self) -> int:
        """Length of the state vector."""
        return 13 * self.nb


def perpendiculars(axis: np.ndarray) -> np.ndarray:
    """Two unit vectors (2, 3) perpendicular to ``axis`` and to each other (right-handed with
    the axis: b1 x b2 = axis / |axis|)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    b1 = np.cross(helper, a)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(a, b1)
    return np.stack([b1, b2])


def build(model: Multibody) -> NEModel:
    """Precompute the constant data of ``model`` (a checked ``Multibody``)."""
    names = tuple(model.body_names)
    nb = len(names)
    index = {name: i for i, name in enumerate(names)}
    mass = np.array([b.mass for b in model.bodies], dtype=float)
    I_B = np.stack([np.asarray(b.I_Cm_B, dtype=float) for b in model.bodies])
    I_B = 0.5 * (I_B + np.swapaxes(I_B, -1, -2))
    Iinv_B = np.linalg.inv(I_B)
    Iinv_B = 0.5 * (Iinv_B + np.swapaxes(Iinv_B, -1, -2))
    gravity = np.asarray(model.gravity_W, dtype=float)
    weight = mass[:, None] * gravity[None, :]

    Minv = np.zeros((6 * nb, 6 * nb))
    for i in range(nb):
        Minv[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = np.eye(3) / mass[i]
        k = 3 * nb + 3 * i
        Minv[k : k + 3, k : k + 3] = Iinv_B[i]

    joints = [b for b in model.bodies if b.joint in ("ball", "hinge")]
    nj = len(joints)
    child = np.array([index[b.name] for b in joints], dtype=int)
    parent = np.array([nb if b.parent is None else index[b.parent] for b in joints], dtype=int)
    r_c = np.array([-np.asarray(b.p_BCm_B, dtype=float) for b in joints]).reshape(nj, 3)
    r_p = []
    for b in joints:
        p_PB_P = np.asarray(b.p_PB_P, dtype=float)
        if b.parent is None:
            r_p.append(p_PB_P)
        else:
            r_p.append(p_PB_P - np.asarray(model.body(b.parent).p_BCm_B, dtype=float))
    r_p = np.array(r_p).reshape(nj, 3)
    hinges = [k for k, b in enumerate(joints) if b.joint == "hinge"]
    nh = len(hinges)
    a_c = np.array([np.asarray(joints[k].axis_B, float) / np.linalg.norm(joints[k].axis_B) for k in hinges]).reshape(nh, 3)
    b_p = np.array([perpendiculars(joints[k].axis_B) for k in hinges]).reshape(nh, 2, 3)
    nc = 3 * nj + 2 * nh

    # Columns [v bodies (3nb) | w bodies (3nb) | v world (3) | w world (3)].
    def vcol(body: int) -> int:
        return 3 * body if body < nb else 6 * nb

    def wcol(body: int) -> int:
        return 3 * nb + 3 * body if body < nb else 6 * nb + 3

    ends = np.concatenate([child, parent])
    end_sign = np.concatenate([np.ones(nj), -np.ones(nj)])
    J_template = np.zeros((nc, 6 * nb + 6))
    rows, cols = [], []
    # Ball rows: +I3 on the child's v, -I3 on the parent's v (constant); the rotational blocks
    # (3x3 per end, entries [row i, column k]) vary with the configuration.
    for e, body in enumerate(ends):
        j = e % nj
        J_template[3 * j : 3 * j + 3, vcol(body) : vcol(body) + 3] += end_sign[e] * np.eye(3)
    for e, body in enumerate(ends):
        j = e % nj
        for i in range(3):
            for k in range(3):
                rows.append(3 * j + i)
                cols.append(wcol(body) + k)
    # Hinge rows: a 1x3 rotational block per end (child, then parent) and per row k = 1, 2.
    for end_of in (child, parent):
        for h, j in enumerate(hinges):
            for kk in range(2):
                for k in range(3):
                    rows.append(3 * nj + 2 * h + kk)
                    cols.append(wcol(end_of[j]) + k)

    forces = []
    for f in model.forces:
        i = index[f.body]
        r_B = np.asarray(f.p_BQ_B, dtype=float) - np.asarray(model.bodies[i].p_BCm_B, dtype=float)
        forces.append((i, r_B, f.force_W))

    return NEModel(
        body_names=names,
        nb=nb,
        mass=mass,
        I_B=I_B,
        Iinv_B=Iinv_B,
        weight_W=weight,
        Minv=Minv,
        joint_names=tuple(b.name for b in joints),
        joint_types=tuple(b.joint for b in joints),
        ends=ends,
        r_end=np.concatenate([r_c, r_p]).reshape(2 * nj, 3),
        end_sign=end_sign,
        hinge_joint=np.array(hinges, dtype=int),
        hinge_child=child[hinges] if nh else np.zeros(0, dtype=int),
        hinge_parent=parent[hinges] if nh else np.zeros(0, dtype=int),
        a_c=a_c,
        b_p=b_p,
        nc=nc,
        J_template=J_template,
        J_rows=np.array(rows, dtype=int),
        J_cols=np.array(cols, dtype=int),
        forces=tuple(forces),
    )


def split(nem: NEModel, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Views ``(p_WCm_W (nb,3), quat_WB (nb,4), v_WCm_W (nb,3), w_WB_B (nb,3))`` of a state
    vector (or of a stack of them, ``[..., 13 nb]``)."""
    nb = nem.nb
    lead = y.shape[:-1]
    return (
        y[..., : 3 * nb].reshape(lead + (nb, 3)),
        y[..., 3 * nb : 7 * nb].reshape(lead + (nb, 4)),
        y[..., 7 * nb : 10 * nb].reshape(lead + (nb, 3)),
        y[..., 10 * nb :].reshape(lead + (nb, 3)),
    )


def join(p_WCm_W: np.ndarray, quat_WB: np.ndarray, v_WCm_W: np.ndarray, w_WB_B: np.ndarray) -> np.ndarray:
    """The state vector from per-body arrays (nb,3), (nb,4), (nb,3), (nb,3)."""
    return np.concatenate([np.ravel(p_WCm_W), np.ravel(quat_WB), np.ravel(v_WCm_W), np.ravel(w_WB_B)]).astype(float)


def initial_state(model: Multibody, nem: NEModel | None = None) -> np.ndarray:
    """State vector at the model's initial joint coordinates ``q0, v0`` (forward kinematics;
    the world-frame angular velocity it returns is rotated into the body frame)."""
    states = kinematics.forward(model, model.q0, model.v0)
    names = nem.body_names if nem is not None else tuple(model.body_names)
    p = np.stack([states[n].p_WCm_W for n in names])
    q = np.stack([states[n].quat_WB for n in names])
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    v = np.stack([states[n].v_WCm_W for n in names])
    R = rotations.matrix(q).reshape(len(names), 3, 3)
    w_B = np.einsum("nji,nj->ni", R, np.stack([states[n].w_WB_W for n in names]))
    return join(p, q, v, w_B)
