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

Joints become constraints between a child body c and its parent p (p = world when ``parent`` is
None; the world is handled as an extra body, index nb, at rest at the origin with identity
orientation). Rows are built from the conditions each joint kind imposes
(``harness.model.joints``: ``JointType.conditions``), in two blocks (``_BLOCKS``): joint points
that coincide, with or without aligned axes (ball, hinge), and a joint point on the axis line
with parallel frames (slide):

* ``ball``: the joint point coincides in world, 3 rows. In the child it is the body-frame
  origin, i.e. ``r_c = -p_BCm_B`` from the child's centre of mass (child frame); in the parent it
  is ``p_PB_P``, i.e. ``r_p = p_PB_P - p_PCm_P`` from the parent's centre of mass (parent frame),
  or the world point ``p_PB_P`` for a world parent.
* ``hinge``: ball + 2 rows ``(R_c a)·(R_p b_k) = 0``, k = 1, 2, where ``a`` is the unit hinge
  axis in the child frame and ``b_1, b_2`` are unit vectors perpendicular to the same axis
  fixed in the parent frame (the frames are parallel at zero joint angle).
* ``slide`` (prismatic): 5 rows, appended after all ball/hinge rows (``SlideJoint``): the
  child's joint origin x_c (its body-frame origin) stays on the line through the parent's point
  x_p along the axis, ``(x_c - x_p)·(R_p b_k) = 0`` for the two unit perpendiculars b_1, b_2 of
  the axis (parent frame), and the frames stay parallel, ``(R_c u_k)·(R_p v_k) = 0`` for
  (u_k, v_k) = (e_y, e_z), (e_z, e_x), (e_x, e_y).
* ``free``: no constraint.

Force elements (``harness.model.forces``): prescribed point forces enter ``NEModel.forces``;
joint springs (slide joints only) are ``SpringElement``s, hinge torques ``TorqueElement``s and
springs between body points (with their dampers) ``PointSpringElement``s (see ``newton_euler``),
not constraints.
A force type the in-house engine does not model is refused when the model is built.

Rolling contacts (``harness.model.multibody.RollingContact``: a rim edge rolling without slip on the
plane z = 0) are constraints of 3 rows each, appended after the slide rows (``rolling``).

Loop (cut) joints (``harness.model.multibody.LoopJoint``) are rows of the ball/hinge block like any
tree joint: maximal coordinates need no tree, so a cut joint is one more joint whose "child" end is
its ``body_a`` and whose "parent" end is its ``body_b`` (or the world), each with its own axis
(``axis_A`` for the child end, the perpendiculars of ``axis_B`` for the parent end). They come after
the tree's ball/hinge joints. A loop's rows may be redundant (a planar loop closed by a hinge: 3 of
its 5 rows are implied), so ``J M^-1 J^T`` is singular: a model with loops (``NEModel.redundant``)
solves it by the pseudo-inverse (``constraints.solve_rows``), which gives the motion uniquely and the
minimum-norm multipliers (the reactions in redundant directions are not determined by rigid-body
mechanics; the others are). So does a model with a rolling contact on a body the world holds
through joints alone (``harness.model.rolling_contact.dependent_rows``): a cone held at its apex by
a ball joint and rolling on its base rim has its apex and rim both at rest, and the velocities of
two points of a rigid body along the line joining them are equal, so one of the rim's no-slip rows
(along the contact generator) repeats the joint's; the split of the force along that line between
apex and rim is not determined, the normal force is. A rolling body on a joint to a free body (a
bicycle's wheels) adds independent rows: Cholesky, as for a tree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from harness.model import kinematics, rolling_contact
from harness.model import rotations
from harness.model.forces import FORCES, JOINT_SPRINGS, JOINT_TORQUES, POINT_FORCES, POINT_SPRINGS
from harness.model.joints import ALIGNED, JOINTS, ON_AXIS, PARALLEL, POINT
from harness.engines.inhouse import algebra
from harness.engines.inhouse.rolling import RollingRows, build_contacts
from harness.model.multibody import Multibody
from harness.measure.trajectory import Trajectory


@dataclass(frozen=True)
class SlideJoint:
    """A prismatic joint of the in-house model (SI units).

    Attributes:
        name: child body name.
        child, parent: body indices (parent ``nb`` for the world).
        r_c: the joint point (the child's body-frame origin) from the child's centre of mass,
            child frame (m).
        r_p: the parent's point ``p_PB_P`` from the parent's centre of mass, parent frame, or
            the world point for a world parent (m).
        axis: unit slide axis (child frame = parent frame; the frames stay parallel).
        b: (2, 3) unit perpendiculars b_1, b_2 of the axis (parent frame).
    """

    name: str
    child: int
    parent: int
    r_c: np.ndarray
    r_p: np.ndarray
    axis: np.ndarray
    b: np.ndarray


@dataclass(frozen=True)
class SpringElement:
    """A linear spring along a slide joint: force ``-k (q - q_ref) a_W`` on the child at its
    joint point and the opposite on the parent at the same point, q = (x_c - x_p)·a_W.

    Attributes: ``slide`` (index into ``NEModel.slides``), ``k`` (N/m), ``q_ref`` (m).
    """

    slide: int
    k: float
    q_ref: float


@dataclass(frozen=True)
class TorqueElement:
    """A constant hinge torque (``harness.model.forces.JointTorque``): ``torque axis_B`` (N m, the
    child's frame) on body ``child``, its opposite on ``parent`` (index ``nb``: the world)."""

    child: int
    parent: int
    axis_B: np.ndarray
    torque: float


@dataclass(frozen=True)
class PointSpringElement:
    """A spring between two body points (``harness.model.forces.PointSpring``): ends at ``r_a``
    from body ``body_a``'s centre of mass (its frame, m) and ``r_b`` from ``body_b``'s (index
    ``nb``: the world, ``r_b`` the world point); stiffness ``k`` (N/m), ``rest_length`` (m), and
    the damping ``c`` (N s/m) of its damper in parallel (0: none)."""

    body_a: int
    r_a: np.ndarray
    body_b: int
    r_b: np.ndarray
    k: float
    rest_length: float
    c: float = 0.0


_ROT_U = np.eye(3)[[1, 2, 0]]  # (u_k, v_k) = (e_y, e_z), (e_z, e_x), (e_x, e_y)
_ROT_V = np.eye(3)[[2, 0, 1]]

# The in-house row blocks, by the conditions a joint kind imposes (``harness.model.joints``):
# "point": 3 rows for the joint point, plus 2 orientation rows for aligned axes (the vectorised
# ball/hinge block); "line": 2 rows for the point on the axis line and 3 for parallel frames
# (``SlideJoint``, rows in ``constraints.slide_rows``); "none": a free joint.
_BLOCKS = {(): "none", (POINT,): "point", (POINT, ALIGNED): "point", (ON_AXIS, PARALLEL): "line"}
_MODELLED_FORCES = (POINT_FORCES, JOINT_SPRINGS, JOINT_TORQUES, POINT_SPRINGS)


def row_block(kind: str) -> str:
    """The in-house row block of a joint kind (``_BLOCKS``); NotImplementedError for a kind whose
    conditions have no rows here."""
    conditions = JOINTS[kind].conditions
    if conditions not in _BLOCKS:
        raise NotImplementedError(f"the in-house engine has no constraint rows for a {kind} joint "
                                  f"({', '.join(c.name for c in conditions)})")
    return _BLOCKS[conditions]


@dataclass(frozen=True)
class NEModel:
    """Constant data of the Newton-Euler model of one ``Multibody`` (SI units).

    Constrained joints (ball or hinge) are numbered j = 0..nj-1 in body order; each has two
    *ends*: its child body (ends 0..nj-1) and its parent body (ends nj..2nj-1, index nb for the
    world). Each joint owns ``rpj`` candidate rows (3 ball rows, then, when the model has a
    hinge, 2 orientation rows); ``keep`` selects the rows that exist (a ball joint has no
    orientation rows).

    Attributes:
        body_names: body order of the state vector.
        nb: number of bodies.
        mass: (nb,) kg.
        I_B, Iinv_B: (nb, 3, 3) inertia about the centre of mass in the body frame, and inverse.
        weight_W: (nb, 3) gravity force m g in world (N).
        Minv: (6nb, 6nb) inverse mass matrix for ``u = [v_WCm_W..., w_WB_B...]``.
        joint_names: child body name of each constrained tree joint, then the name of each loop
            joint (``Multibody.loops``).
        joint_types: the joint kind (``Body.joint`` or ``LoopJoint.kind``: ball or hinge) per
            constrained joint.
        ends: (2nj,) body index of each end (child ends, then parent ends; nb = world).
        K_end: (2nj, 3, 3) constant factor of the ball rows' body-frame rotational blocks,
            ``-[r]x`` for a child end and ``+[r]x`` for a parent end (r = first column of D_end),
            so that the block is ``R_end @ K_end``.
        D_end: (2nj, 3, 3) per end, columns in the end body's frame: the joint point relative to
            the body's centre of mass (m; for a world end the joint point in world), then for a
            child end the unit hinge axis a and a zero column, for a parent end the two unit
            vectors b_1, b_2 perpendicular to the axis (zero columns for a ball joint).
        has_hinge: whether any joint is a hinge (rpj = 5, else 3).
        rpj: candidate rows per joint.
        keep: (nc,) indices of the existing rows among the nj * rpj candidates, or None when all
            exist.
        nc: number of constraint rows.
        J_template: (nc, 6nb + 6) constant part of the Jacobian (the +-I3 translational blocks);
            columns ``[v bodies | w bodies | v world | w world]``.
        J_rows, J_cols: where the configuration-dependent rotational entries go.
        J_take: indices of those entries in the flattened (2nj, rpj, 3) per-end blocks, or None
            when they are all of them, in order.
        forces: ``(body index, r_B, force_W)`` per prescribed point force, ``r_B`` the point
            relative to the centre of mass in the body frame (m).
        slides: prismatic joints; their 5 rows each come after the ball/hinge rows, so ``nc``
            counts them and ``nc_fast`` does not (``J_template``, ``keep`` and the per-end
            arrays describe the ball/hinge rows only).
        springs: spring elements on slide joints.
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
    K_end: np.ndarray
    D_end: np.ndarray
    has_hinge: bool
    rpj: int
    keep: np.ndarray | None
    nc: int
    J_template: np.ndarray
    J_rows: np.ndarray
    J_cols: np.ndarray
    J_take: np.ndarray | None
    forces: tuple[tuple[int, np.ndarray, Callable[[float], np.ndarray]], ...]
    slides: tuple[SlideJoint, ...] = ()
    springs: tuple[SpringElement, ...] = ()
    contacts: tuple[RollingRows, ...] = ()  # rolling contacts: 3 rows each, after the slide rows (``rolling``)
    torques: tuple[TorqueElement, ...] = ()
    point_springs: tuple[PointSpringElement, ...] = ()
    redundant: bool = False  # loop joints, or a rolling contact on an anchored body: rows may be dependent (``constraints.solve_rows``)
    loops: bool = False  # loop joints: singular positions may exist (``constraints.project`` at every stage)
    Minv_sparse: Any = None  # Minv as a SciPy sparse matrix, for a model of ``SPARSE_ROWS`` rows or more
    J_fixed: tuple | None = None  # with Minv_sparse and only ball/hinge rows: J_template's entries (rows, cols, values) and the mask of (J_rows, J_cols) on bodies, for a sparse J

    @property
    def nc_fast(self) -> int:
        """Number of ball/hinge constraint rows (the rows before the slide rows)."""
        return self.nc - 5 * len(self.slides) - 3 * len(self.contacts)

    @property
    def nj(self) -> int:
        """Number of constrained joints (ball or hinge)."""
        return len(self.joint_names)

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

    for ft in FORCES.values():
        if ft not in _MODELLED_FORCES and ft.elements(model):
            raise NotImplementedError(f"the in-house engine does not model {ft.label}s ({ft.name})")
    block = {b.name: row_block(b.joint) for b in model.bodies}
    tree = [b for b in model.bodies if block[b.name] == "point"]
    loops = tuple(model.loops)
    # Each ball/hinge row joint as (name, kind, child, parent, child point, parent point, child axis,
    # parent axis); points from the end body's centre of mass in its frame (world point for the world).
    def com(body):
        return np.zeros(3) if body is None else np.asarray(model.body(body).p_BCm_B, dtype=float)

    joints = [(b.name, b.joint, b.name, b.parent, np.zeros(3) - com(b.name), np.asarray(b.p_PB_P, float) - com(b.parent),
               np.asarray(b.axis_B, float), np.asarray(b.axis_B, float)) for b in tree]
    joints += [(lp.name, lp.kind, lp.body_a, lp.body_b, np.asarray(lp.p_A, float) - com(lp.body_a),
                np.asarray(lp.p_B, float) - com(lp.body_b), np.asarray(lp.axis_A, float), np.asarray(lp.axis_B, float))
               for lp in loops]
    aligned = [ALIGNED in JOINTS[kind].conditions for _, kind, *_ in joints]
    nj = len(joints)
    has_hinge = any(aligned)
    rpj = 5 if has_hinge else 3
    child = [index[jt[2]] for jt in joints]
    parent = [nb if jt[3] is None else index[jt[3]] for jt in joints]
    ends = np.array(child + parent, dtype=int)
    D_end = np.zeros((2 * nj, 3, 3))
    for j, (_, _, _, _, r_c, r_p, axis_c, axis_p) in enumerate(joints):
        D_end[j, :, 0] = r_c
        D_end[nj + j, :, 0] = r_p
        if aligned[j]:
            D_end[j, :, 1] = axis_c / np.linalg.norm(axis_c)
            D_end[nj + j, :, 1:] = perpendiculars(axis_p).T
    exists = np.ones((nj, rpj), dtype=bool)
    if has_hinge:
        for j in range(nj):
            exists[j, 3:] = aligned[j]
    keep_all = np.flatnonzero(exists.ravel())
    nc = len(keep_all)
    row_of = -np.ones(nj * rpj, dtype=int)
    row_of[keep_all] = np.arange(nc)

    # Columns [v bodies (3nb) | w bodies (3nb) | v world (3) | w world (3)].
    def vcol(body: int) -> int:
        return 3 * body if body < nb else 6 * nb

    def wcol(body: int) -> int:
        return 3 * nb + 3 * body if body < nb else 6 * nb + 3

    J_template = np.zeros((nc, 6 * nb + 6))
    sign = np.concatenate([np.ones(nj), -np.ones(nj)])
    for e, body in enumerate(ends):
        j = e % nj
        rows3 = row_of[j * rpj : j * rpj + 3]
        J_template[rows3, vcol(body) : vcol(body) + 3] += sign[e] * np.eye(3)
    rows, cols, take = [], [], []
    for e, body in enumerate(ends):
        j = e % nj
        for r in range(rpj):
            if row_of[j * rpj + r] < 0:
                continue
            for k in range(3):
                rows.append(row_of[j * rpj + r])
                cols.append(wcol(body) + k)
                take.append((e * rpj + r) * 3 + k)
    take = np.array(take, dtype=int)
    all_taken = len(take) == 2 * nj * rpj * 3 and np.array_equal(take, np.arange(len(take)))

    forces = []
    for f in POINT_FORCES.elements(model):
        i = index[f.body]
        r_B = np.asarray(f.p_BQ_B, dtype=float) - np.asarray(model.bodies[i].p_BCm_B, dtype=float)
        forces.append((i, r_B, f.force_W))

    slides = []
    for b in model.bodies:
        if block[b.name] != "line":
            continue
        axis = np.asarray(b.axis_B, dtype=float)
        axis = axis / np.linalg.norm(axis)
        p_PB_P = np.asarray(b.p_PB_P, dtype=float)
        r_p = p_PB_P if b.parent is None else p_PB_P - np.asarray(model.body(b.parent).p_BCm_B, dtype=float)
        slides.append(SlideJoint(b.name, index[b.name], nb if b.parent is None else index[b.parent],
                                 -np.asarray(b.p_BCm_B, dtype=float), r_p, axis, perpendiculars(axis)))
    slide_of = {sl.name: k for k, sl in enumerate(slides)}
    springs = tuple(SpringElement(slide_of[sp.body], float(sp.stiffness), float(sp.q_ref))
                    for sp in JOINT_SPRINGS.elements(model))

    contacts = build_contacts(model, index)
    def torque(tq):
        body = model.body(tq.body)
        axis = np.asarray(body.axis_B, dtype=float)
        return TorqueElement(index[body.name], nb if body.parent is None else index[body.parent],
                             axis / np.linalg.norm(axis), float(tq.torque))

    torques = tuple(torque(tq) for tq in JOINT_TORQUES.elements(model))

    def spring_end(body, p):
        if body is None:
            return nb, np.asarray(p, dtype=float)
        return index[body], np.asarray(p, dtype=float) - np.asarray(model.body(body).p_BCm_B, dtype=float)

    point_springs = tuple(PointSpringElement(*spring_end(ps.body_a, ps.p_A), *spring_end(ps.body_b, ps.p_B),
                                             float(ps.stiffness), float(ps.rest_length), float(ps.damping))
                          for ps in POINT_SPRINGS.elements(model))

    return NEModel(
        body_names=names,
        nb=nb,
        mass=mass,
        I_B=I_B,
        Iinv_B=Iinv_B,
        weight_W=weight,
        Minv=Minv,
        joint_names=tuple(jt[0] for jt in joints),
        joint_types=tuple(jt[1] for jt in joints),
        ends=ends,
        K_end=-sign[:, None, None] * np.array([rotations.skew(r) for r in D_end[:, :, 0]]).reshape(2 * nj, 3, 3),
        D_end=D_end,
        has_hinge=has_hinge,
        rpj=rpj,
        keep=None if nc == nj * rpj else keep_all,
        nc=nc + 5 * len(slides) + 3 * len(contacts),
        J_template=J_template,
        J_rows=np.array(rows, dtype=int),
        J_cols=np.array(cols, dtype=int),
        J_take=None if all_taken else take,
        forces=tuple(forces),
        slides=tuple(slides),
        springs=springs,
        contacts=contacts,
        torques=torques,
        point_springs=point_springs,
        redundant=bool(loops) or rolling_contact.dependent_rows(model),
        loops=bool(loops),
        Minv_sparse=sparse_inverse_mass(Minv, nc + 5 * len(slides) + 3 * len(contacts)),
        J_fixed=sparse_template(J_template, np.array(cols, dtype=int), 6 * nb)
        if nc >= SPARSE_ROWS and not slides and not contacts else None,
    )


def sparse_template(J_template: np.ndarray, cols: np.ndarray, ncol: int) -> tuple:
    """The constant entries of ``J_template`` on the bodies' columns (< ``ncol``) as
    ``(rows, cols, values)``, and the mask of the varying entries' columns ``cols`` on them: what
    ``constraints.evaluate`` assembles a sparse J from."""
    r, c = np.nonzero(J_template[:, :ncol])
    return r, c, J_template[r, c], cols < ncol


#: From this many constraint rows on, ``constraints.RowSystem`` forms and factors J M^-1 J^T as a
#: sparse matrix (SciPy's SuperLU) instead of a dense one: each row acts on at most two bodies, so
#: the dense products and factor (O(nc^3)) dominate a large model's step. Measured on
#: four_bar_chain (N = 40: 81 bodies, 605 rows) and N = 8 (17 bodies, 125 rows): see
#: ``constraints.RowSystem``.
SPARSE_ROWS = 200


def sparse_inverse_mass(Minv: np.ndarray, nc: int):
    """``Minv`` (block diagonal, 6 nb x 6 nb) as a SciPy CSR matrix for a model whose constraint
    rows are many enough for the sparse solve (``SPARSE_ROWS``), else None."""
    if nc < SPARSE_ROWS:
        return None
    from scipy import sparse

    return sparse.csr_matrix(Minv)


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
    return state_at(model, model.q0, model.v0, nem)


def state_at(model: Multibody, q: dict[str, np.ndarray], v: dict[str, np.ndarray], nem: NEModel | None = None) -> np.ndarray:
    """State vector at joint coordinates ``q, v`` (per body name, ``harness.model.joints``):
    ``initial_state`` at any joint state."""
    states = kinematics.forward(model, q, v)
    names = nem.body_names if nem is not None else tuple(model.body_names)
    p = np.stack([states[n].p_WCm_W for n in names])
    quat = np.stack([states[n].quat_WB for n in names])
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    vel = np.stack([states[n].v_WCm_W for n in names])
    R = rotations.matrix(quat).reshape(len(names), 3, 3)
    w_B = np.einsum("nji,nj->ni", R, np.stack([states[n].w_WB_W for n in names]))
    return join(p, quat, vel, w_B)


def to_trajectory(nem: NEModel, t: np.ndarray, ys: np.ndarray, engine: str = "inhouse", integrator: str = "") -> Trajectory:
    """A ``Trajectory`` from state vectors ``ys`` (n, 13 nb) at times ``t`` (n,) s: quaternions
    renormalised, body-frame angular velocities rotated to world (``w_WB_W = R w_WB_B``)."""
    n = len(t)
    ys = np.asarray(ys, dtype=float).reshape(n, nem.ny)
    P, Q, V, W_B = split(nem, ys)
    Q = Q / np.linalg.norm(Q, axis=-1, keepdims=True)
    w_W = (algebra.quat_matrix(Q) @ W_B[..., None])[..., 0]
    return Trajectory(
        engine=engine,
        integrator=integrator,
        body_names=nem.body_names,
        t=np.array(t, dtype=float),
        p_WCm_W=P.copy(),
        quat_WB=Q,
        v_WCm_W=V.copy(),
        w_WB_W=w_W,
    )


def from_trajectory(nem: NEModel, traj: Trajectory) -> np.ndarray:
    """State vectors (n, 13 nb) of a trajectory's samples (bodies in the model's order; the
    world-frame angular velocities rotated back into the body frames)."""
    idx = [traj.body_index(name) for name in nem.body_names]
    Q = traj.quat_WB[:, idx]
    Q = Q / np.linalg.norm(Q, axis=-1, keepdims=True)
    w_B = np.einsum("tbji,tbj->tbi", algebra.quat_matrix(Q), traj.w_WB_W[:, idx])
    n = len(traj.t)
    return np.concatenate(
        [traj.p_WCm_W[:, idx].reshape(n, -1), Q.reshape(n, -1), traj.v_WCm_W[:, idx].reshape(n, -1), w_B.reshape(n, -1)], axis=1
    )
