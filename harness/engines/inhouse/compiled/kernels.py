"""Compiled kernels of the in-house Newton-Euler equations and their integrators (Numba).

The same physics as ``newton_euler.make_dynamics`` and ``constraints.project`` (maximal
coordinates, joints as KKT constraint forces, projection onto the constraints after each
step), written as plain loops that Numba compiles to machine code once (``cache=True`` keeps
the compiled code on disk between processes). Nothing here allocates per right-hand-side
call: every buffer lives in a workspace made once per trajectory (``workspace``). Each kernel
advances one trajectory; a batch of initial states is these kernels run one trajectory after
another on each of several threads (``erk_rows``; the kernels release the GIL).

Integrators (drivers): ``erk``, any explicit Runge-Kutta method given as its Butcher table
(A, b, c) with a fixed step (``solver.integrate_fixed`` passes ``integrators.RK4`` for
``rk4_compiled``), either as is or, given the ``dexp^-1`` coefficients ``series``, in
Runge-Kutta-Munthe-Kaas form with the orientations on SO(3) (``rkmk4_compiled``: the per-state
``lie_group.rkmk_step``, whose docstring states the method); ``erk_rows``, the same stepper
over rows of a batch of initial states;
``dop853``, DOP853 with SciPy's coefficient tables, step-size control and dense output.
``erk`` and ``dop853`` also return, when asked, the constraint multipliers at the saved samples
(``_multipliers``), from which the engine forms the joint reactions and contact forces.

Why compiled loops and not NumPy: a rigid-body right-hand side is a few hundred flops on
3-vectors and 3x3 matrices; as NumPy calls each costs 1-2 us of interpreter overhead, as
compiled code the whole right-hand side of a double pendulum costs about a microsecond. Why
a hand-written Cholesky: LAPACK's call overhead exceeds the work at these sizes (<= 50 rows).

Scope: every model the per-state engine builds (``model.build``): free, ball, hinge and slide
joints, loop (cut) joints, rolling contacts, gravity, springs on slide joints, hinge torques,
point springs, and prescribed point forces whose time law is a ``HarmonicForce``
(``harness.model.forces``; ``solver.pack`` refuses a force given only as a Python function).
Dependent constraint rows (``NEModel.redundant``: loop joints, a rolling body the world holds
through joints alone) are factored by Cholesky with diagonal pivoting, which drops the pivots at
round-off (``_DEPENDENT`` of the largest diagonal entry: rows that depend on the others exactly;
``_pivoted_cholesky``), of the row-scaled matrix ``S = D^-1/2 A D^-1/2`` (A = J M^-1 J^T,
D = diag A; ``_factor``): every rank decision is taken on S, as the per-state pseudo-inverse
takes it (``constraints.pseudo_inverse``), and the solves scale by 1/sqrt(D) in and out
(``_solve``; the multipliers, and so the reactions, are A's). Unscaled, a slender rod's spin
about its own axis (inertia m r^2 / 2) made the largest diagonal entry of A 1e4 to 1e5 times
a window's in-plane rows (four_bar_chain, r = 5 mm), and near a flat position of its
parallelograms those rows' pivots fell to the round-off floor: measured along four_bar_chain
(N = 2, 20 s, every step), unscaled kept pivots down to 2.9e-13 of the largest and dropped ones
up to 4.2e-14 (a real row dropped), the projection stalled at the first flat position (0.715 s,
"position projection did not converge", rk4_compiled and dop853_compiled alike); scaled, dropped
pivots at most 2.1e-15 on every loop scene, rolling_cone and four_bar_chain, kept ones at least
7.7e-4 (bricard) on the loop scenes and 2.4e-9 on four_bar_chain.
Near a singular configuration (a kept pivot of S below ``_WELL_CONDITIONED``: the unit
parallelogram four-bar within about 7e-5 rad of its flat positions, pivot ~2 theta^2, where the
loop loses an in-plane row; unscaled the band was about 1e-2 rad wide) a pivot is not an
eigenvalue, and a rank decision by pivots differs from the per-state pseudo-inverse's
(eigenvalues of S below ``RANK_RTOL`` of the largest dropped, theta below about 2e-5 rad there)
in a band around the singular position: there S is eigen-decomposed (``_jacobi_eigen``) and
both the accelerations and the projection apply the per-state pseudo-inverse itself
(``_factor``, ``_eigen_solve``). Measured on that parallelogram (a = b = c = d = 1 m, 1 kg
bars, IFToMM A02 with N = 1), unscaled and before the stage projection below, deciding by
pivots: within 2e-3 rad of the flat positions the accelerations left the per-state ones by up
to 3e-6 of the largest on the manifold and 1.3e-3 at a Runge-Kutta stage 1e-6 off it, and the
projection by 1.2e-7; one passage added 3.5e-10 J of energy; rk4_compiled ended 10 s 4.3e-9
rad from the exact motion (per-state rk4 2.0e-10), 2.1e-9 at dt 2.5e-4 (no convergence), and
dop853_compiled (rtol 1e-10) took 1174 steps for 1.5 s. With the eigen-decomposition: within
4e-11 of the per-state accelerations there and 2e-15 of its projection, 1.9e-10 and 7.8e-13
rad, 160 steps. Away from such configurations the factor and every result of a model without
dependent rows are unchanged (bit for bit). Otherwise the accelerations take the
minimum-norm least-squares multipliers from that factor (``_least_squares_solve``), as the
per-state pseudo-inverse (``constraints.solve_rows``) does: off the constraint manifold (a Runge-Kutta
stage) the dependent rows' bias is inconsistent, and holding the kept rows exactly instead made
the right-hand side jump where the pivot order changes (measured on bricard: rk4_compiled left
rk4 at 0.44 s, 8e-8 over 5 s, energy drift 2.3e-8; with least squares 1.4e-13 over 1 s and
2.1e-12 J over 5 s). The projection solves its kept rows exactly (``_pivoted_solve``, the
others' multipliers zero): its result is the manifold either way. Position rows are pivoted before the rolling
contacts' no-slip rows, so the Gauss-Newton projection corrects every position error in one
step (the per-state pseudo-inverse splits the error of a joint row with the no-slip row that
repeats it, and converges linearly). A model without dependent rows takes plain Cholesky of A
itself (a non-positive pivot is SINGULAR).

Stage projection: a model with loop joints (``NEModel.loops``; ``stage_tol`` in the model
tuple) evaluates every right-hand side, so every stage of every method (``erk``, its Lie-group
form, ``erk_rows``, ``dop853``), at the projection of its state onto the constraint manifold
(``rhs``), as the per-state ``projected_stages`` (whose docstring says why: near a flat
position a stage's velocity error became a folding velocity). Measured on four_bar_chain
(N = 2, 20 s, error of the crank tips against the exact motion at the end of the run):
rk4_compiled 3.1e-8 / 3.5e-9 / 1.8e-9 m at dt 2e-3 / 1e-3 / 5e-4 s (per-state rk4 1.6e-8 /
2.0e-9 / 1.5e-9; without the stage projection 8.4e-9 / 7.8e-10 / 7.4e-5); dop853_compiled
(rtol 1e-13) 2.0e-8 m in 1277 steps (N = 3: 1.0e-7 m, 1490 steps), without the stage
projection a step size underflow at 4.6 s (N = 3: 5.2 s). The two forms agree to 1e-11 m until
a passage very close to flat (t ~ 15 s), which amplifies any round-off difference: a relative
perturbation of 1e-15 of the initial state moves either form's end error by as much (dt 2e-3:
per-state 5.0e-9 to 2.5e-8 m, compiled 2.5e-8 to 3.1e-8 m). It costs a Gauss-Newton step (an
evaluation of the rows and a factor) or two more per stage: the default runs of bricard,
andrews_squeezer, four_bar and slider_crank took 1.4 / 1.3 / 1.8 / 1.8 times the wall time with
rk4_compiled, 1.2 / 1.2 / 1.7 / 1.8 with dop853_compiled.

Units and frames: as ``harness.engines.inhouse.model`` (state ``y = [p_WCm_W | quat_WB (wxyz)
| v_WCm_W | w_WB_B]``: centre-of-mass positions (m) and velocities (m/s) in the world frame,
body -> world quaternions, angular velocities (rad/s) in the BODY frame; times in s). The model
is a tuple of arrays (``solver.pack`` makes it)::

    mass (nb,) kg, I_B (nb,3,3) and Iinv_B (nb,3,3) kg m^2 about the COM in the body frame,
    grav (nb,3) m/s^2 (world), jc (nj,) child body, jp (nj,) parent body (nb = world),
    rc (nj,3) joint point from the child's COM (child frame), rp (nj,3) joint point from the
    parent's COM (parent frame) or in world for a world parent, hinge (nj,) 0/1,
    axis (nj,3) unit hinge axis (child frame), b1, b2 (nj,3) unit perpendiculars of the axis
    (parent frame), row (nj,) first constraint row of each joint, nc number of rows;
    slide joints: sc, sp (ns,) child and parent, src, srp (ns,3) joint points as rc, rp,
    sb1, sb2 (ns,3) unit perpendiculars of the axis (parent frame), saxis (ns,3) unit axis
    (child frame), srow (ns,) first row (after all ball and hinge rows); springs on slides:
    kslide (nk,) slide index, k (nk,) N/m, qref (nk,) m;
    rank_rtol: 0 for independent rows (plain Cholesky), else ``constraints.RANK_RTOL`` (pivoted
    Cholesky, and the eigenvalue floor of the pseudo-inverse near a singular configuration);
    flat: ``rolling_contact.FLAT``; elements (forces, torques, point springs, rolling
    contacts, one table: every array of the tuple costs compile time) elem (ne,3) [kind | a |
    b] and edata (ne,13), by kind:
    FORCE, a prescribed point force on body a (b = nb): edata [r_B (3, m, from the COM, body
    frame) | f_const_W | f_cos_W | f_sin_W (3 each, N) | omega (rad/s)];
    TORQUE, a hinge torque on child a, parent b (nb = world): [unit axis (child frame) |
    torque N m];
    POINT_SPRING, ends on bodies a and b (b = nb: the world): [r_a | r_b (m, from the COM,
    body frame; the world point for the world) | k N/m | rest length m | damping c N s/m];
    ROLLING, a rolling contact of body a whose 3 rows start at row b: [radius m |
    half-thickness m | circle_z m | 1 for one rolling circle, 0 for two rim edges];
    slip: the first rolling-contact row (nc without contacts);
    stage_tol: m, the tolerance of the stage projection of a model with loop joints (``rhs``;
    ``projection_tolerance``), 0 for a model without.

Loop joints are ball/hinge joints like the tree's (jc the cut joint's ``body_a`` with its own
axis, jp its ``body_b`` or the world with the perpendiculars of its axis), after them. Rows in
order: ball/hinge joints, slide joints, rolling contacts (3 each, the last ``3 ncon`` rows).

Constraint rows of joint j (child c, parent p; s = R r the joint point's offset in world,
omega = R w the world angular velocity):

* ball (3 rows): ``C = p_c + s_c - p_p - s_p``; ``J u = v_c - [s_c]x omega_c - v_p +
  [s_p]x omega_p``; bias ``gamma = omega_c x (omega_c x s_c) - omega_p x (omega_p x s_p)``;
* hinge (2 more rows, k = 1, 2): ``C = A . N_k`` with ``A = R_c a``, ``N_k = R_p b_k``;
  ``J u = (A x N_k) . (omega_c - omega_p)``; ``gamma = [(omega_c x A) x N_k + A x (omega_p x
  N_k)] . (omega_c - omega_p)``.

* slide (5 rows; x = p + s the joint points, d = x_c - x_p, n_k = R_p b_k): ``C = d . n_k``
  (k = 1, 2) with ``J u = n_k . (v_c + omega_c x s_c - v_p) + (n_k x (s_p + d)) . omega_p``
  and ``gamma = [omega_c x (omega_c x s_c) - omega_p x (omega_p x s_p)] . n_k
  + 2 d' . (omega_p x n_k) + d . (omega_p x (omega_p x n_k))``, d' the rate of d; and three
  orientation rows ``(R_c e_(k+1)) . (R_p e_(k+2))`` of the hinge rows' form
  (``constraints`` derives them);
* spring on a slide: force ``-k (d . a - qref) a`` (a = R_c saxis) on the child at x_c, its
  opposite on the parent at the same point.
* rolling contact (3 rows: x, y no slip, z height; ``harness.engines.inhouse.rolling``): r the
  offset from the COM to the contact point and r' its rate (``rolling_contact.offset_and_rate``:
  the lower rim edge, or the one circle of ``circle_z``), ``J u = v + omega x r``,
  ``gamma = omega x r'``, C = 0, 0 and the contact's height ``p_z + r_z``;
* applied forces (``newton_euler``): a prescribed force f at r_B, ``f / m`` and
  ``r_B x R^T f``; a hinge torque ``torque a`` on the child (body frame), its opposite on the
  parent; a point spring ``-(k (L - L0) + c L') d / L`` at end a (d = x_a - x_b, L = |d|,
  L' = d . (v_a - v_b) / L with the ends' world velocities v = v_WCm_W + R (w_WB_B x r)), its
  opposite at end b.

Status codes returned by the integrators (``solver.STATUS`` words them): 0 ok, 1 non-finite
state, 2 singular constraint matrix, 3 projection did not converge, 4 step size underflow,
5 too many steps, 6 non-finite error estimate, 7 a rolling disk lies flat (the contact point is
undefined: the per-state ``rolling.FlatDiskError``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

_JIT = dict(cache=True, nogil=True, error_model="numpy")
_KERNEL = dict(_JIT, _nrt=False)  # the work below the drivers: no reference counting (below)
_INNER = dict(_KERNEL, no_cpython_wrapper=True)  # called from compiled code only: no Python entry point

OK, NONFINITE, SINGULAR, NO_PROJECTION, UNDERFLOW, TOO_MANY_STEPS, BAD_ERROR, FLAT_DISK = 0, 1, 2, 3, 4, 5, 6, 7
FORCE, TORQUE, POINT_SPRING, ROLLING = 0, 1, 2, 3  # kinds of the model's elements (module docstring)
_QUADRATIC = 1e-9  # as constraints.project: below this a Gauss-Newton step is not re-evaluated
_PROJECTION_ITERATIONS = 8
# The pivoted Cholesky of the row-scaled J M^-1 J^T (``_factor``: unit diagonal), as fractions of
# its largest diagonal entry: pivots at or below _DEPENDENT are rows that depend on the others
# exactly (round-off: at most 2.1e-15 on the loop scenes, rolling_cone and four_bar_chain at
# N = 2, at every step of their runs; unscaled 8.2e-16 on the first ones, but 4.2e-14 on
# four_bar_chain, a real row), and a factor whose every kept pivot is at least _WELL_CONDITIONED
# is used as it is (the smallest on those runs: 7.7e-4, bricard; four_bar_chain 2.4e-9, one step
# in 20000 in the band; unscaled 6.4e-7 on four_bar_near_singular and 2.9e-13 on four_bar_chain,
# 217 steps); in between, a near-singular configuration, the per-state pseudo-inverse's rank
# decision by eigenvalues (``_jacobi_eigen``). Near a flat parallelogram the smallest eigenvalue
# of the scaled matrix is about 1/10 of the smallest pivot (A02 at theta 1e-2 to 3e-6 rad), so
# the band starts 10 times above the eigenvalue the pseudo-inverse drops (``RANK_RTOL``).
_DEPENDENT = 1e-13
_WELL_CONDITIONED = 1e-8
# A projected stage within the band of a singular position (``rhs``, ``_residual``,
# ``_across_singular_position``): the per-state ``newton_euler`` constants, which say why.
_SINGULAR_RESIDUAL = 1e-9
_NEIGHBOUR_SHIFT = 1e-4
_NEIGHBOUR_DOUBLINGS = 6
_JACOBI_SWEEPS = 30  # a cap: Jacobi converges quadratically, 5-10 sweeps for these sizes
_JACOBI_OFF = 1e-32  # stop when the off-diagonal part's squared norm is below this of |S|^2 (eps^2)


# ---------------------------------------------------------------------------------------------
# Borrowed arrays: the drivers hand the physics arrays without reference counts
#
# Every call of a compiled function that is not inlined increments and decrements the
# reference count of each array it receives (an atomic operation, about 6 ns each), and ``rhs``
# and ``project`` receive the model and workspace tuples (40 arrays): measured, that was most of
# a right-hand side's time (torque_free: 0.6 us per call for 0.05 us of arithmetic). So each
# driver (``erk``, ``erk_rows``, ``dop853``) allocates its buffers, keeps them alive itself
# (``_hold`` after the work) and passes ``_borrow``-ed copies (the same data, no reference
# count) down to the work. Views of a borrowed array are borrowed too. A borrowed array must
# never outlive the driver call that made it: nothing here returns or stores one.
#
# The work below the drivers (every function but ``workspace``, the three drivers and ``_hold``)
# is compiled without reference counting at all (``_KERNEL``: Numba's ``_nrt=False``): it never
# allocates, and Numba would otherwise emit reference-count code for every array of the model
# and workspace tuples in every function that receives them, code that LLVM optimises again at
# each level of calls (measured: 16% less cold compile time of ``erk``; the calls are faster
# too). For the same reason the helpers of ``rhs`` and ``_constraints`` take the arrays they use
# rather than the tuples. Without reference counting Numba cannot assign one array to another
# (``a[:] = b``): ``_copy`` does it.


@intrinsic
def _borrow(typingctx, arrays):
    """The same array (or tuple of arrays), without reference counting (meminfo NULL)."""

    def strip(context, builder, aty, value):
        ary = context.make_array(aty)(context, builder, value)
        ary.meminfo = context.get_constant_null(types.MemInfoPointer(types.voidptr))
        return ary._getvalue()

    def codegen(context, builder, sig, args):
        ty, value = sig.args[0], args[0]
        if isinstance(ty, types.Array):
            return strip(context, builder, ty, value)
        for i, aty in enumerate(ty):
            if isinstance(aty, types.Array):
                value = builder.insert_value(value, strip(context, builder, aty, builder.extract_value(value, i)), i)
        return value

    if not (isinstance(arrays, types.Array) or isinstance(arrays, types.BaseTuple)):
        return None
    return arrays(arrays), codegen


@njit(**_JIT)
def _hold(buffers):
    """Nothing: a use of ``buffers`` that keeps them alive until this point of the caller."""
    return None


# ---------------------------------------------------------------------------------------------
# Small vector algebra (3-vectors as the rows of larger arrays)


@njit(**_INNER)
def _rotation(q0, q1, q2, q3, R):
    """R (3x3) of the unit quaternion (w, x, y, z) = (q0, q1, q2, q3)."""
    R[0, 0] = 1.0 - 2.0 * (q2 * q2 + q3 * q3)
    R[0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    R[0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    R[1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    R[1, 1] = 1.0 - 2.0 * (q1 * q1 + q3 * q3)
    R[1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    R[2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    R[2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    R[2, 2] = 1.0 - 2.0 * (q1 * q1 + q2 * q2)


@njit(**_INNER)
def _cross(a, b, out):
    """out = a x b (3-vectors; out may alias a or b)."""
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    out[0], out[1], out[2] = x, y, z


@njit(**_INNER)
def _matvec(R, x, out):
    """out = R x (3x3 matrix, 3-vector)."""
    for i in range(3):
        out[i] = R[i, 0] * x[0] + R[i, 1] * x[1] + R[i, 2] * x[2]


@njit(**_INNER)
def _quat_rate(q, w, out, scale):
    """out = scale * 1/2 q (x) (0, w) (q wxyz, w body frame)."""
    h = 0.5 * scale
    out[0] = h * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2])
    out[1] = h * (q[0] * w[0] + q[2] * w[2] - q[3] * w[1])
    out[2] = h * (q[0] * w[1] + q[3] * w[0] - q[1] * w[2])
    out[3] = h * (q[0] * w[2] + q[1] * w[1] - q[2] * w[0])


@njit(**_INNER)
def _cholesky(A, n):
    """A = L L^T in place (n x n symmetric positive definite; the lower triangle becomes L).
    Returns OK, SINGULAR (a pivot <= 0: not positive definite) or NONFINITE (a NaN pivot)."""
    for k in range(n):
        d = A[k, k]
        for m in range(k):
            d -= A[k, m] * A[k, m]
        if not d > 0.0:
            return SINGULAR if d <= 0.0 else NONFINITE
        d = np.sqrt(d)
        A[k, k] = d
        for i in range(k + 1, n):
            s = A[i, k]
            for m in range(k):
                s -= A[i, m] * A[k, m]
            A[i, k] = s / d
    return OK


@njit(**_INNER)
def _cholesky_solve(L, b, x, n):
    """x = (L L^T)^-1 b with the factor of ``_cholesky``."""
    for i in range(n):  # L z = b
        s = b[i]
        for m in range(i):
            s -= L[i, m] * x[m]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = z
        s = x[i]
        for m in range(i + 1, n):
            s -= L[m, i] * x[m]
        x[i] = s / L[i, i]


@njit(**_INNER)
def _pivoted_cholesky(A, n, perm, rtol, slip):
    """P^T A P = L L^T in place for a symmetric positive semi-definite A (n x n; its lower
    triangle becomes L, n x rank): Cholesky with diagonal pivoting (LAPACK's dpstf2), the
    largest remaining pivot first, stopping when it falls to ``rtol`` times A's largest diagonal
    entry (dependent rows). ``perm`` (n,) receives the permutation (row i of P^T A P is row
    perm[i] of A). Rows from ``slip`` on, but for every third (the rolling contacts' no-slip
    rows), are velocity-level: their error C is 0 by definition, so a projection that kept one
    of them in place of a position row it depends on would never correct that row's error; they
    are pivoted after every position-level row above the floor. Returns (status, rank, dmax):
    OK, SINGULAR (A is zero) or NONFINITE, and A's largest diagonal entry."""
    dmax = 0.0
    for i in range(n):
        perm[i] = i
        if not np.isfinite(A[i, i]):
            return NONFINITE, 0, dmax
        dmax = max(dmax, A[i, i])
    if not dmax > 0.0:
        return SINGULAR, 0, dmax
    floor = rtol * dmax
    for k in range(n):
        p = -1
        for i in range(k, n):  # the largest position-level pivot, ...
            if (perm[i] < slip or (perm[i] - slip) % 3 == 2) and (p < 0 or A[i, i] > A[p, p]):
                p = i
        if p < 0 or not A[p, p] > floor:  # ... else the largest of all
            p = k
            for i in range(k + 1, n):
                if A[i, i] > A[p, p]:
                    p = i
        d = A[p, p]
        if not d > floor:
            return (OK if d <= floor else NONFINITE), k, dmax
        if p != k:  # swap k and p in P, in L's rows, and in the trailing lower triangle
            perm[k], perm[p] = perm[p], perm[k]
            A[k, k], A[p, p] = A[p, p], A[k, k]
            for m in range(k):
                A[k, m], A[p, m] = A[p, m], A[k, m]
            for i in range(k + 1, p):
                A[i, k], A[p, i] = A[p, i], A[i, k]
            for i in range(p + 1, n):
                A[i, k], A[i, p] = A[i, p], A[i, k]
        d = np.sqrt(d)
        A[k, k] = d
        for i in range(k + 1, n):
            A[i, k] /= d
            A[k, i] = A[i, k]  # column k also in row k (the unused upper triangle): read along rows below
        for i in range(k + 1, n):  # the Schur complement of the trailing rows, row by row
            lik = A[i, k]
            for j in range(k + 1, i + 1):
                A[i, j] -= lik * A[k, j]
    return OK, n, dmax


@njit(**_INNER)
def _pivoted_solve(L, b, x, n, rank, perm):
    """x = a solution of A x = b from ``_pivoted_cholesky``'s factor (``rank``, ``perm``): the
    rows of the ``rank`` pivots solved exactly, the multipliers of the dropped (dependent) rows
    zero. For a right-hand side in the range of A (the KKT and projection systems) every row
    holds and M^-1 J^T x, the accelerations or the correction, is the unique one. b is
    overwritten (scratch)."""
    for i in range(rank):  # P^T b, solved on the leading rank x rank block of the factor
        x[i] = b[perm[i]]
    _cholesky_solve(L, x, b, rank)
    for i in range(n):
        x[i] = 0.0
    for i in range(rank):
        x[perm[i]] = b[i]


@njit(**_INNER)
def _least_squares_solve(L, b, x, n, rank, perm, S):
    """x = the minimum-norm least-squares solution of A x = b, A ~ G G^T with G = P L (n x rank,
    ``_pivoted_cholesky``'s factor): x = G (G^T G)^-2 G^T b, as the per-state pseudo-inverse
    (``constraints.solve_rows``) gives it. A right-hand side outside A's range (the bias of
    dependent rows at a state off the constraint manifold, such as a Runge-Kutta stage) is
    projected onto it, so x is continuous in the state; ``_pivoted_solve`` would hold the kept
    rows exactly and change the answer when a pivot changes. S (n x n, scratch) receives
    G^T G and its factor; b is overwritten (scratch)."""
    for i in range(rank):  # S = L^T L (lower triangle), z = L^T P^T b into x, summed over k ...
        x[i] = 0.0
        for j in range(i + 1):
            S[i, j] = 0.0
    for k in range(n):  # ... in ascending order, along L's rows
        bk = b[perm[k]]
        for i in range(min(k + 1, rank)):
            lki = L[k, i]
            x[i] += lki * bk
            for j in range(i + 1):
                S[i, j] += lki * L[k, j]
    _cholesky(S, rank)
    _cholesky_solve(S, x, b, rank)
    _cholesky_solve(S, b, x, rank)
    for k in range(n):  # P^T x = L w
        acc = 0.0
        for i in range(min(k + 1, rank)):
            acc += L[k, i] * x[i]
        b[k] = acc
    for k in range(n):
        x[perm[k]] = b[k]


@njit(**_INNER)
def _jacobi_eigen(S, V, n):
    """The eigen-decomposition S = V diag(w) V^T of a symmetric S (n x n, both triangles) in
    place: cyclic Jacobi (Golub & Van Loan, Matrix Computations, "Jacobi methods": sweeps of the
    symmetric 2x2 Schur rotation over every pair) until the off-diagonal part is below round-off
    of S's Frobenius norm, so that small eigenvalues carry an absolute error of order eps |S|, as
    those of ``np.linalg.eigh``. S's diagonal becomes w (unordered), V (n x n) the eigenvectors
    as columns. Returns OK, or NONFINITE for a non-finite S."""
    norm2 = 0.0
    for i in range(n):
        for j in range(n):
            V[i, j] = 0.0
            norm2 += S[i, j] * S[i, j]
        V[i, i] = 1.0
    if not np.isfinite(norm2):
        return NONFINITE
    for _ in range(_JACOBI_SWEEPS):
        off = 0.0
        for p in range(n - 1):
            for q in range(p + 1, n):
                off += S[p, q] * S[p, q]
        if not off > _JACOBI_OFF * norm2:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = S[p, q]
                if apq == 0.0:
                    continue
                tau = (S[q, q] - S[p, p]) / (2.0 * apq)  # the symmetric 2x2 Schur decomposition
                if tau >= 0.0:
                    t = 1.0 / (tau + np.sqrt(1.0 + tau * tau))
                else:
                    t = -1.0 / (-tau + np.sqrt(1.0 + tau * tau))
                c = 1.0 / np.sqrt(1.0 + t * t)
                sn = t * c
                for k in range(n):  # S <- S G, then G^T S, and V <- V G (G the rotation in p, q)
                    skp, skq = S[k, p], S[k, q]
                    S[k, p] = c * skp - sn * skq
                    S[k, q] = sn * skp + c * skq
                for k in range(n):
                    spk, sqk = S[p, k], S[q, k]
                    S[p, k] = c * spk - sn * sqk
                    S[q, k] = sn * spk + c * sqk
                for k in range(n):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p] = c * vkp - sn * vkq
                    V[k, q] = sn * vkp + c * vkq
    return OK


@njit(**_INNER)
def _eigen_solve(S, V, b, x, n, rtol):
    """x = the pseudo-inverse of A = V diag(S) V^T (``_jacobi_eigen``) applied to b: the
    eigenvalues at or below ``rtol`` times the largest dropped, the minimum-norm least-squares
    solution, as ``constraints.solve_rows`` computes it (b is left as it is)."""
    wmax = 0.0
    for k in range(n):
        wmax = max(wmax, S[k, k])
    floor = rtol * wmax
    for i in range(n):
        x[i] = 0.0
    for k in range(n):
        w = S[k, k]
        if not w > floor:
            continue
        acc = 0.0
        for i in range(n):
            acc += V[i, k] * b[i]
        acc /= w
        for i in range(n):
            x[i] += acc * V[i, k]


@njit(**_INNER)
def _scale(A, n, d):
    """A <- D^-1/2 A D^-1/2 in place (n x n, both triangles) with d = sqrt(diag A) (each row's own
    mobility; 1 for a zero row) into d: the row-scaled matrix, unit diagonal, on which the rank is
    decided (``_factor``)."""
    for i in range(n):
        di = np.sqrt(abs(A[i, i]))
        d[i] = di if di != 0.0 else 1.0
    for i in range(n):
        for j in range(n):
            A[i, j] = A[i, j] / (d[i] * d[j])


@njit(**_INNER)
def _factor(A, n, perm, rtol, slip, mass, Iinv, J, B, S, V, d):
    """Factor A = J M^-1 J^T (n x n, formed by ``_minv_jt`` from J, with B = M^-1 J^T) in place.
    Cholesky when ``rtol`` is 0 (independent rows; a failure is SINGULAR; d is not used). Else
    (rows that may be dependent, loop joints or a rolling body the world holds through joints;
    ``slip`` the first rolling-contact row) the row-scaled matrix ``D^-1/2 A D^-1/2`` (``_scale``,
    D = diag A, sqrt(diag A) into d) is factored: the rank is decided on it, as the per-state
    pseudo-inverse decides it (``constraints.pseudo_inverse``), and ``_solve`` scales its
    right-hand side and solution by 1/d. Unscaled, a slender rod's spin about its own axis made
    A's largest diagonal entry and eigenvalue 1e4 to 1e5 times those of a window's in-plane rows
    (four_bar_chain, r = 5 mm), and near a flat position those rows fell below the thresholds
    relative to the largest (below). The scaled matrix is factored by Cholesky with diagonal
    pivoting (``_pivoted_cholesky``), which drops the pivots at round-off (``_DEPENDENT`` of the
    largest diagonal entry, 1 once scaled: rows that depend on the others exactly). When every
    kept pivot is above ``_WELL_CONDITIONED`` that factor is the answer. A smaller kept pivot is a
    near-singular configuration (a four-bar parallelogram passing its flat position, where the
    loop loses an in-plane row): there dropping a pivot is not dropping an eigenvalue, and the
    factor's rank decision would differ from the per-state pseudo-inverse's (eigenvalues of the
    scaled matrix below ``rtol`` of the largest dropped) in a band around the singular position,
    its truncation error along a row rather than an eigenvector. So A is formed again into S,
    scaled by the same d and eigen-decomposed (``_jacobi_eigen``, eigenvectors into V), and
    ``_solve`` applies the pseudo-inverse with the per-state rank decision. Returns (status,
    rank, eigen): eigen true when S and V hold the decomposition (rank is then the Cholesky's)."""
    if not rtol > 0.0:
        return _cholesky(A, n), n, False
    _scale(A, n, d)
    st, rank, dmax = _pivoted_cholesky(A, n, perm, _DEPENDENT, slip)
    if st != OK:
        return st, rank, False
    smallest = dmax
    for k in range(rank):
        smallest = min(smallest, A[k, k] * A[k, k])
    if smallest >= _WELL_CONDITIONED * dmax:
        return OK, rank, False
    _minv_jt(mass, Iinv, n, J, S, B)  # A again (the factor overwrote it), into S
    for i in range(n):
        for j in range(n):
            S[i, j] = S[i, j] / (d[i] * d[j])
    return _jacobi_eigen(S, V, n), rank, True


@njit(**_INNER)
def _solve(A, b, x, n, rank, perm, rtol, eigen, least_squares, S, V, d):
    """x = (J M^-1 J^T)^-1 b with ``_factor``'s factor in A, or with its eigen-decomposition in
    S and V when ``eigen`` (the pseudo-inverse, ``_eigen_solve``); with ``least_squares`` and
    dropped rows, the minimum-norm least-squares solution from the factor
    (``_least_squares_solve``; S is scratch), else the kept rows solved exactly
    (``_pivoted_solve``). For rows that may be dependent (``rtol`` > 0) the factor is the
    row-scaled matrix's: b is scaled by 1/d first and x by 1/d after (x = D^-1/2 S^+ D^-1/2 b,
    the unscaled multipliers). b is overwritten."""
    if not rtol > 0.0:
        _cholesky_solve(A, b, x, n)
        return
    for i in range(n):
        b[i] /= d[i]
    if eigen:
        _eigen_solve(S, V, b, x, n, rtol)
    elif least_squares and rank < n:
        _least_squares_solve(A, b, x, n, rank, perm, S)
    else:
        _pivoted_solve(A, b, x, n, rank, perm)
    for i in range(n):
        x[i] /= d[i]


# ---------------------------------------------------------------------------------------------
# Model evaluation


@njit(**_JIT)
def workspace(model):
    """Buffers for one trajectory: (R, omega, s, J, A, B, u0, lam, bias, C, tmp, qn, vec, perm, S,
    V, d, ys): rotations and world angular velocities (the world last), joint offsets, the
    constraint Jacobian, J M^-1 J^T, M^-1 J^T, accelerations, multipliers, bias, error, scratch,
    the pivot order of ``_pivoted_cholesky``, the scratch of ``_least_squares_solve`` or the
    eigenvalues of ``_factor``'s eigen-decomposition, its eigenvectors, the row scales
    sqrt(diag J M^-1 J^T) of ``_factor``, and the projected stage state of ``rhs`` (13 nb) followed
    by the buffers of ``_across_singular_position`` (3 x 13 nb + nc) and the fixed-step flag
    (last entry: 0, 1 when a fixed-step driver, ``erk`` or ``erk_rows``, made it)."""
    mass, nc = model[0], model[13]
    nb = mass.shape[0]
    R = np.zeros((nb + 1, 3, 3))
    for i in range(3):
        R[nb, i, i] = 1.0  # the world
    return (R, np.zeros((nb + 1, 3)), np.zeros((2, 3)), np.zeros((max(nc, 1), 6 * nb)),
            np.zeros((max(nc, 1), max(nc, 1))), np.zeros((6 * nb, max(nc, 1))), np.zeros(6 * nb),
            np.zeros(max(nc, 1)), np.zeros(max(nc, 1)), np.zeros(max(nc, 1)), np.zeros(8), np.zeros((nb, 4)),
            np.zeros((16, 3)), np.zeros(max(nc, 1), dtype=np.int64), np.zeros((max(nc, 1), max(nc, 1))),
            np.zeros((max(nc, 1), max(nc, 1))), np.ones(max(nc, 1)), np.zeros(4 * 13 * nb + max(nc, 1) + 1))


@njit(**_INNER)
def _unit_quaternions(y, nb, Q):
    """Q (nb,4) = the quaternions of state y divided by their norms (Q may be y's own
    quaternion entries: each norm is taken before its quaternion is written)."""
    for i in range(nb):
        k = 3 * nb + 4 * i
        n = np.sqrt(y[k] ** 2 + y[k + 1] ** 2 + y[k + 2] ** 2 + y[k + 3] ** 2)
        for m in range(4):
            Q[i, m] = y[k + m] / n


@njit(**_INNER)
def _frames(y, nb, R, qn):
    """Unit quaternions qn and rotations R of every body (ws qn, R)."""
    _unit_quaternions(y, nb, qn)
    for i in range(nb):
        _rotation(qn[i, 0], qn[i, 1], qn[i, 2], qn[i, 3], R[i])


@njit(**_INNER)
def _angular_velocities(y, nb, R, omega):
    """World angular velocities omega = R w_B of every body (ws omega; after ``_frames``)."""
    for i in range(nb):
        _matvec(R[i], y[10 * nb + 3 * i: 10 * nb + 3 * i + 3], omega[i])


@njit(**_INNER)
def _position(y, nb, body, m):
    """Component m of a body's centre-of-mass position (m, world); 0 for the world (nb)."""
    return y[3 * body + m] if body < nb else 0.0


@njit(**_INNER)
def _constraints(model, y, ws):
    """Fill J (ws J, nc x 6nb, columns [v bodies | w_B bodies]), the bias gamma (ws bias) and the
    position error C (ws C). Needs ``_frames`` and ``_angular_velocities`` first. Both are always
    computed: the right-hand side needs gamma and the projection C, and a flag for each would
    compile this function (and ``_slides``, ``_rolling``) twice, once per constant value, for a
    few flops. Returns OK, or FLAT_DISK from a rolling contact (``_rolling``)."""
    mass, jc, jp, rc, rp, hinge, axis, b1, b2, row = (model[0], model[4], model[5], model[6], model[7], model[8],
                                                      model[9], model[10], model[11], model[12])
    nb = mass.shape[0]
    R, omega, s, J, bias, C, tmp = ws[0], ws[1], ws[2], ws[3], ws[8], ws[9], ws[10]
    J[:, :] = 0.0
    vec = ws[12]
    a, nk, ck, u, v = vec[0], vec[1], vec[2], vec[3], vec[4]
    for j in range(jc.shape[0]):
        c, p, r0 = jc[j], jp[j], row[j]
        _matvec(R[c], rc[j], s[0])
        _matvec(R[p], rp[j], s[1])
        for m in range(3):
            J[r0 + m, 3 * c + m] = 1.0
            if p < nb:
                J[r0 + m, 3 * p + m] = -1.0
        # rotational blocks: -[s_c]x R_c (child), +[s_p]x R_p (parent), acting on w_B
        for m in range(3):
            m1, m2 = (m + 1) % 3, (m + 2) % 3
            for col in range(3):
                J[r0 + m, 3 * nb + 3 * c + col] = -(s[0, m1] * R[c, m2, col] - s[0, m2] * R[c, m1, col])
                if p < nb:
                    J[r0 + m, 3 * nb + 3 * p + col] = s[1, m1] * R[p, m2, col] - s[1, m2] * R[p, m1, col]
        for m in range(3):
            C[r0 + m] = _position(y, nb, c, m) + s[0, m] - _position(y, nb, p, m) - s[1, m]
        _cross(omega[c], s[0], u)
        _cross(omega[c], u, v)
        for m in range(3):
            bias[r0 + m] = v[m]
        if p < nb:
            _cross(omega[p], s[1], u)
            _cross(omega[p], u, v)
            for m in range(3):
                bias[r0 + m] -= v[m]
        if hinge[j]:
            _matvec(R[c], axis[j], a)
            for k in range(2):
                r = r0 + 3 + k
                if k == 0:
                    _matvec(R[p], b1[j], nk)
                else:
                    _matvec(R[p], b2[j], nk)
                _cross(a, nk, ck)
                for col in range(3):
                    J[r, 3 * nb + 3 * c + col] = ck[0] * R[c, 0, col] + ck[1] * R[c, 1, col] + ck[2] * R[c, 2, col]
                    if p < nb:
                        J[r, 3 * nb + 3 * p + col] = -(ck[0] * R[p, 0, col] + ck[1] * R[p, 1, col] + ck[2] * R[p, 2, col])
                C[r] = a[0] * nk[0] + a[1] * nk[1] + a[2] * nk[2]
                # d/dt (A x N_k) at constant velocities, dotted with omega_c - omega_p
                _cross(omega[c], a, u)
                _cross(u, nk, v)  # (omega_c x A) x N_k
                for m in range(3):
                    tmp[m] = v[m]
                    tmp[3 + m] = omega[c, m] - omega[p, m]
                _cross(omega[p], nk, u)
                _cross(a, u, v)  # A x (omega_p x N_k)
                bias[r] = ((tmp[0] + v[0]) * tmp[3] + (tmp[1] + v[1]) * tmp[4] + (tmp[2] + v[2]) * tmp[5])
    _slides(y, nb, model[14], model[15], model[16], model[17], model[18], model[19], model[21], R, omega, J, bias, C,
            ws[12])
    if model[27].shape[0] > 0:
        return _rolling(y, nb, R, omega, J, bias, C, ws[12], model[27], model[28], model[26])
    return OK


@njit(**_INNER)
def _velocity(y, nb, body, m):
    """Component m of a body's centre-of-mass velocity (m/s, world); 0 for the world (nb)."""
    return y[7 * nb + 3 * body + m] if body < nb else 0.0


@njit(**_INNER)
def _dot(a, b):
    """a . b of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(**_INNER)
def _row_times_rotation(x, R, J, r, col0, sign):
    """J[r, col0:col0+3] = sign x^T R (a body-frame angular-velocity block)."""
    for col in range(3):
        J[r, col0 + col] = sign * (x[0] * R[0, col] + x[1] * R[1, col] + x[2] * R[2, col])


@njit(**_INNER)
def _slides(y, nb, sc, sp, src, srp, sb1, sb2, srow, R, omega, J, bias, C, vec):
    """The 5 rows of each slide joint (module docstring) into J, with their bias and error (the
    arrays of ``model`` and ``ws`` it needs). Needs ``_frames`` and ``_angular_velocities``."""
    n, x, t1, t2, wn = vec[0], vec[1], vec[2], vec[3], vec[4]
    s_c, s_p, d, wsc, wsp, dd = vec[8], vec[9], vec[10], vec[11], vec[12], vec[13]
    for j in range(sc.shape[0]):
        c, p, r0 = sc[j], sp[j], srow[j]
        _matvec(R[c], src[j], s_c)
        _matvec(R[p], srp[j], s_p)
        for m in range(3):
            d[m] = _position(y, nb, c, m) + s_c[m] - _position(y, nb, p, m) - s_p[m]
        _cross(omega[c], s_c, wsc)
        _cross(omega[p], s_p, wsp)
        for m in range(3):
            dd[m] = (_velocity(y, nb, c, m) + wsc[m]) - (_velocity(y, nb, p, m) + wsp[m])
        for k in range(2):  # the joint point stays on the axis line
            r = r0 + k
            _matvec(R[p], sb1[j] if k == 0 else sb2[j], n)
            for m in range(3):
                J[r, 3 * c + m] = n[m]
                if p < nb:
                    J[r, 3 * p + m] = -n[m]
            _cross(s_c, n, x)
            _row_times_rotation(x, R[c], J, r, 3 * nb + 3 * c, 1.0)
            if p < nb:
                for m in range(3):
                    t1[m] = s_p[m] + d[m]
                _cross(n, t1, x)
                _row_times_rotation(x, R[p], J, r, 3 * nb + 3 * p, 1.0)
            C[r] = _dot(d, n)
            _cross(omega[c], wsc, t1)
            _cross(omega[p], wsp, t2)
            g = (t1[0] - t2[0]) * n[0] + (t1[1] - t2[1]) * n[1] + (t1[2] - t2[2]) * n[2]
            _cross(omega[p], n, wn)
            _cross(omega[p], wn, t1)
            bias[r] = g + 2.0 * _dot(dd, wn) + _dot(d, t1)
        a, nr = vec[5], vec[6]
        for k in range(3):  # the frames stay parallel: (R_c e_(k+1)) . (R_p e_(k+2)) = 0
            r = r0 + 2 + k
            for m in range(3):  # columns e_(k+1) of R_c and e_(k+2) of R_p, copied contiguous
                a[m] = R[c, m, (k + 1) % 3]
                nr[m] = R[p, m, (k + 2) % 3]
            _cross(a, nr, x)
            _row_times_rotation(x, R[c], J, r, 3 * nb + 3 * c, 1.0)
            if p < nb:
                _row_times_rotation(x, R[p], J, r, 3 * nb + 3 * p, -1.0)
            C[r] = _dot(a, nr)
            _cross(omega[c], a, t1)
            _cross(t1, nr, t2)  # (omega_c x a) x nr
            _cross(omega[p], nr, t1)
            _cross(a, t1, wn)  # a x (omega_p x nr)
            bias[r] = ((t2[0] + wn[0]) * (omega[c, 0] - omega[p, 0]) + (t2[1] + wn[1]) * (omega[c, 1] - omega[p, 1])
                       + (t2[2] + wn[2]) * (omega[c, 2] - omega[p, 2]))


@njit(**_INNER)
def _springs(y, mass, Iinv, sc, sp, src, srp, saxis, kslide, stiffness, qref, R, vec, u0):
    """Add the slide springs' accelerations to u0 ([dv_WCm_W | dw_WB_B], free part; the arrays
    of ``model`` and ``ws`` it needs). Needs ``_frames``."""
    nb = mass.shape[0]
    s_c, s_p, d, a, f, fB, arm, mom = vec[8], vec[9], vec[10], vec[11], vec[12], vec[13], vec[14], vec[15]
    for e in range(kslide.shape[0]):
        j = kslide[e]
        c, p = sc[j], sp[j]
        _matvec(R[c], src[j], s_c)
        _matvec(R[p], srp[j], s_p)
        for m in range(3):
            d[m] = _position(y, nb, c, m) + s_c[m] - _position(y, nb, p, m) - s_p[m]
        _matvec(R[c], saxis[j], a)
        magnitude = -stiffness[e] * (_dot(d, a) - qref[e])
        for m in range(3):
            f[m] = magnitude * a[m]
            u0[3 * c + m] += f[m] / mass[c]
        for m in range(3):  # f in the child frame, at the joint point src from its centre of mass
            fB[m] = R[c, 0, m] * f[0] + R[c, 1, m] * f[1] + R[c, 2, m] * f[2]
        _cross(src[j], fB, mom)
        for m in range(3):
            u0[3 * nb + 3 * c + m] += Iinv[c, m, 0] * mom[0] + Iinv[c, m, 1] * mom[1] + Iinv[c, m, 2] * mom[2]
        if p < nb:
            for m in range(3):
                u0[3 * p + m] -= f[m] / mass[p]
                fB[m] = R[p, 0, m] * f[0] + R[p, 1, m] * f[1] + R[p, 2, m] * f[2]
                arm[m] = R[p, 0, m] * (s_p[0] + d[0]) + R[p, 1, m] * (s_p[1] + d[1]) + R[p, 2, m] * (s_p[2] + d[2])
            _cross(arm, fB, mom)
            for m in range(3):
                u0[3 * nb + 3 * p + m] -= Iinv[p, m, 0] * mom[0] + Iinv[p, m, 1] * mom[1] + Iinv[p, m, 2] * mom[2]


@njit(**_INNER)
def _rolling(y, nb, R, omega, J, bias, C, vec, elem, edata, flat):
    """The 3 rows of each rolling contact (elements of kind ROLLING) into J, with their bias and
    error; the contact offset r and its rate as ``harness.model.rolling_contact.offset_and_rate``.
    Needs ``_frames`` and ``_angular_velocities`` (the arrays of ``model`` and ``ws`` it needs).
    Returns OK, or FLAT_DISK when a disk lies flat (s below ``flat``)."""
    r, d, rdot, g = vec[8], vec[9], vec[10], vec[11]
    for e in range(elem.shape[0]):
        if elem[e, 0] != ROLLING:
            continue
        i, r0, radius = elem[e, 1], elem[e, 2], edata[e, 0]
        n0, n1, nz = R[i, 0, 2], R[i, 1, 2], R[i, 2, 2]  # the symmetry axis n = R e_z
        s = np.sqrt(max(1.0 - nz * nz, 0.0))
        if s < flat:
            return FLAT_DISK
        si = 1.0 / max(s, flat)
        u0, u1, u2 = -nz * n0 * si, -nz * n1 * si, (1.0 - nz * nz) * si  # up in the disk plane
        if edata[e, 3] > 0.0:  # one rolling circle at body z = circle_z
            hs = -edata[e, 2]
        else:  # the lower of the two rim edges
            hs = edata[e, 1] * (1.0 if nz > 0.0 else (-1.0 if nz < 0.0 else 0.0))
        r[0], r[1], r[2] = -radius * u0 - hs * n0, -radius * u1 - hs * n1, -radius * u2 - hs * nz
        for m in range(3):  # [ I3 | -[r]x R ]
            m1, m2 = (m + 1) % 3, (m + 2) % 3
            J[r0 + m, 3 * i + m] = 1.0
            for col in range(3):
                J[r0 + m, 3 * nb + 3 * i + col] = -(r[m1] * R[i, m2, col] - r[m2] * R[i, m1, col])
        # no slip has no position error; the height row's is z_C
        C[r0] = 0.0
        C[r0 + 1] = 0.0
        C[r0 + 2] = y[3 * i + 2] + r[2]
        # gamma = w x r', r' the rate of the contact offset
        w = omega[i]
        d[0], d[1], d[2] = w[1] * nz - w[2] * n1, w[2] * n0 - w[0] * nz, w[0] * n1 - w[1] * n0  # n' = w x n
        kk = nz * d[2] * si
        rdot[0] = -radius * ((-d[2] * n0 - nz * d[0] + u0 * kk) * si) - hs * d[0]
        rdot[1] = -radius * ((-d[2] * n1 - nz * d[1] + u1 * kk) * si) - hs * d[1]
        rdot[2] = -radius * ((-d[2] * nz - nz * d[2] + u2 * kk) * si) - hs * d[2]
        _cross(w, rdot, g)
        for m in range(3):
            bias[r0 + m] = g[m]
    return OK


@njit(**_INNER)
def _push(mass, Iinv, R, i, r_B, f, sign, fB, mom, u0):
    """Add to u0 the accelerations of body i under ``sign`` f (N, world) at r_B from its centre
    of mass (body frame, m): ``f / m`` and ``I^-1 (r_B x R^T f)`` (fB, mom: scratch 3-vectors)."""
    nb = mass.shape[0]
    for m in range(3):
        u0[3 * i + m] += sign * f[m] / mass[i]
        fB[m] = R[i, 0, m] * f[0] + R[i, 1, m] * f[1] + R[i, 2, m] * f[2]
    _cross(r_B, fB, mom)
    for m in range(3):
        u0[3 * nb + 3 * i + m] += sign * (Iinv[i, m, 0] * mom[0] + Iinv[i, m, 1] * mom[1] + Iinv[i, m, 2] * mom[2])


@njit(**_INNER)
def _point_velocity(y, nb, R, i, r_B, wr, out):
    """out = the world velocity (m/s) of the point ``r_B`` (m, from body i's centre of mass, body
    frame): ``v_WCm_W + R (w_WB_B x r_B)`` (wr: a scratch 3-vector). Needs ``_frames``."""
    w0 = 10 * nb + 3 * i
    _cross(y[w0: w0 + 3], r_B, wr)
    _matvec(R[i], wr, out)
    for m in range(3):
        out[m] += y[7 * nb + 3 * i + m]


@njit(**_INNER)
def _applied(t, y, mass, Iinv, R, vec, elem, edata, u0):
    """Add the accelerations of the prescribed point forces (their time laws at t, s), hinge
    torques and point springs (elements of kinds FORCE, TORQUE, POINT_SPRING; module docstring)
    to u0 ([dv_WCm_W | dw_WB_B], free part). Needs ``_frames`` (ws R; vec: ws scratch)."""
    nb = mass.shape[0]
    f, m_B, m_W, arm_a, arm_b, d = vec[8], vec[9], vec[10], vec[11], vec[12], vec[13]
    for e in range(elem.shape[0]):
        kind, a, b = elem[e, 0], elem[e, 1], elem[e, 2]
        if kind == TORQUE:  # torque axis on the child (a), its opposite on the parent (b)
            for m in range(3):
                m_B[m] = edata[e, 3] * edata[e, m]
            for m in range(3):
                u0[3 * nb + 3 * a + m] += Iinv[a, m, 0] * m_B[0] + Iinv[a, m, 1] * m_B[1] + Iinv[a, m, 2] * m_B[2]
            if b < nb:
                _matvec(R[a], m_B, m_W)
                for m in range(3):  # R_b^T R_a m_B
                    m_B[m] = R[b, 0, m] * m_W[0] + R[b, 1, m] * m_W[1] + R[b, 2, m] * m_W[2]
                for m in range(3):
                    u0[3 * nb + 3 * b + m] -= Iinv[b, m, 0] * m_B[0] + Iinv[b, m, 1] * m_B[1] + Iinv[b, m, 2] * m_B[2]
            continue
        if kind == FORCE:  # f_W(t) = f_const + f_cos cos(omega t) + f_sin sin(omega t)
            wt = edata[e, 12] * t
            c, s = np.cos(wt), np.sin(wt)
            for m in range(3):
                f[m] = (edata[e, 3 + m] + edata[e, 6 + m] * c) + edata[e, 9 + m] * s
        elif kind == POINT_SPRING:  # -(k (L - L0) + c L') d / L at end a, its opposite at end b
            _matvec(R[a], edata[e, 0:3], arm_a)
            _matvec(R[b], edata[e, 3:6], arm_b)  # the world's R is the identity: the world point
            for m in range(3):
                d[m] = (_position(y, nb, a, m) + arm_a[m]) - (_position(y, nb, b, m) + arm_b[m])
            L = np.sqrt(_dot(d, d))
            magnitude = -edata[e, 6] * (L - edata[e, 7]) / L
            damping = edata[e, 8]
            if damping != 0.0:  # the damper: L' = d . (v_a - v_b) / L, the ends' world velocities
                _point_velocity(y, nb, R, a, edata[e, 0:3], m_B, m_W)
                rate = _dot(d, m_W)
                if b < nb:
                    _point_velocity(y, nb, R, b, edata[e, 3:6], m_B, m_W)
                    rate -= _dot(d, m_W)
                magnitude -= damping * rate / (L * L)
            for m in range(3):
                f[m] = magnitude * d[m]
        else:
            continue
        _push(mass, Iinv, R, a, edata[e, 0:3], f, 1.0, vec[14], vec[15], u0)
        if b < nb:  # a point spring's other end (a force's b is the world)
            _push(mass, Iinv, R, b, edata[e, 3:6], f, -1.0, vec[14], vec[15], u0)


@njit(**_INNER)
def _minv_jt(mass, Iinv, nc, J, A, B):
    """B = M^-1 J^T (6nb x nc) and A = J B (nc x nc), from J (ws J, A, B). A row of J acts on
    at most two bodies (a joint's child and parent, a contact's body), so each entry of A sums
    over their 12 columns: J B's products with zeros of J left out (an Andrews squeezer's 50
    rows: 84 -> 9 us per evaluation)."""
    nb = mass.shape[0]
    for r in range(nc):
        for i in range(nb):
            for m in range(3):
                B[3 * i + m, r] = J[r, 3 * i + m] / mass[i]
                w = 0.0
                for col in range(3):
                    w += Iinv[i, m, col] * J[r, 3 * nb + 3 * i + col]
                B[3 * nb + 3 * i + m, r] = w
    for r in range(nc):
        # the (at most two) bodies of row r: B's other bodies' entries meet zeros of J there
        first, second, more = -1, -1, False
        for i in range(nb):
            touched = False
            for m in range(3):
                if J[r, 3 * i + m] != 0.0 or J[r, 3 * nb + 3 * i + m] != 0.0:
                    touched = True
            if touched:
                if first < 0:
                    first = i
                elif second < 0:
                    second = i
                else:
                    more = True
        for s in range(r + 1):
            A[r, s] = 0.0
        if more:  # not a joint's, slide's or contact's row: every column
            for k in range(6 * nb):
                jrk = J[r, k]
                for s in range(r + 1):
                    A[r, s] += jrk * B[k, s]
        else:  # the same columns in the same (ascending) order, zeros of J skipped
            for half in range(2):
                for i in (first, second):
                    if i >= 0:
                        k0 = 3 * half * nb + 3 * i
                        for m in range(3):
                            jrk = J[r, k0 + m]
                            for s in range(r + 1):  # along the rows of A and B
                                A[r, s] += jrk * B[k0 + m, s]
        for s in range(r):
            A[s, r] = A[r, s]


@njit(**_KERNEL)
def rhs(t, y, dy, model, ws):
    """dy/dt of state y at time t (s) into dy. Returns a status code (OK, SINGULAR, NONFINITE,
    FLAT_DISK, or NO_PROJECTION from a stage projection).

    A model with loop joints (``stage_tol`` > 0 in the model tuple) evaluates it at y's
    projection onto the constraint manifold, as the per-state ``projected_stages``
    (``constraints.project_stage``): y is copied into the workspace (ws ys; y itself is never
    changed: DOP853 evaluates its candidate solution here), that copy gets unit quaternions,
    positions by Gauss-Newton re-evaluated after every step until max |C| <= ``stage_tol`` (no
    ``_QUADRATIC`` shortcut: the stage map must be a smooth function of y, the identity on the
    manifold) and velocities projected with J at those positions (``_project``), and the
    derivative is that of the copy, with the factor of the projection's last evaluation (the same
    positions, the same J and J M^-1 J^T). Under a fixed-step driver (``erk``, ``erk_rows``: the workspace's
    fixed-step flag) a stage within the band of a singular position (``_residual`` above
    ``_SINGULAR_RESIDUAL``) takes the mean of its neighbours (``_across_singular_position``), as
    the per-state fixed-step methods do; DOP853 keeps the stage's own, as the per-state DOP853
    (whose error control steps around the band: the mean, a jump of the right-hand side at the
    band's edge, made dop853_compiled take 132111 steps over four_bar_chain's first 1.5 s at
    N = 1, rtol 1e-10, instead of 160). Every compiled method (``erk`` with or without the
    Lie-group form, ``erk_rows``, ``dop853``) and the multipliers at the samples
    (``_multipliers``) go through it."""
    stage_tol = model[30]
    if stage_tol > 0.0 and model[13] > 0:
        ys = ws[17][: y.shape[0]]
        _copy(y, ys)
        st, rank, eigen = _project(ys, model, ws, stage_tol, True)
        if st != OK:
            return st
        st = _derivative(t, ys, dy, model, ws, True, rank, eigen)
        fixed_step = ws[17][ws[17].shape[0] - 1] != 0.0
        if st != OK or not fixed_step or _residual(model, ws) <= _SINGULAR_RESIDUAL:
            return st
        return _across_singular_position(t, ys, dy, model, ws)
    return _derivative(t, y, dy, model, ws, False, 0, False)


@njit(**_INNER)
def _residual(model, ws):
    """``max |J du - rhs| / max |rhs|`` of the rows' acceleration equation ``_derivative`` has
    just solved (ws J, B = M^-1 J^T, lam; the right-hand side it saved in ws C; du = B lam):
    round-off where the rows are solved, large where rows were dropped near a singular position
    (``newton_euler.SINGULAR_RESIDUAL``). The residual rows are summed into ws bias (scratch by
    then)."""
    nc, J, B, lam, rhs_rows, res = model[13], ws[3], ws[5], ws[7], ws[9], ws[8]
    for r in range(nc):
        res[r] = -rhs_rows[r]
    for k in range(J.shape[1]):
        du = 0.0
        for r in range(nc):
            du += B[k, r] * lam[r]
        for r in range(nc):
            res[r] += J[r, k] * du
    worst, scale = 0.0, 0.0
    for r in range(nc):
        worst = max(worst, abs(res[r]))
        scale = max(scale, abs(rhs_rows[r]))
    return worst / scale if scale > 0.0 else 0.0


@njit(**_INNER)
def _across_singular_position(t, ys, dy, model, ws):
    """dy/dt (into dy, which holds ys's own) and the multipliers (ws lam) of a projected stage
    ys within the band of a singular position: the mean of those at its two neighbours, ys moved
    by -tau and +tau along its own velocities and projected back, tau doubled from the shift of
    ``_NEIGHBOUR_SHIFT`` joint-offset lengths of the fastest joint point until both are out of
    the band, as the per-state ``make_dynamics`` (``across_singular_position``, which gives the
    measurements); ys's own when none is. Buffers: ws ys beyond ys itself (``workspace``)."""
    mass, nc = model[0], model[13]
    nb = mass.shape[0]
    ny = 13 * nb
    buf = ws[17]
    z, dz, mean = buf[ny: 2 * ny], buf[2 * ny: 3 * ny], buf[3 * ny: 4 * ny]
    lam_mean = buf[4 * ny: 4 * ny + nc]
    length = 0.0
    for a in (model[6], model[7]):
        for j in range(a.shape[0]):
            for m in range(3):
                length = max(length, abs(a[j, m]))
    if length == 0.0:
        length = 1.0
    speed = 0.0
    for i in range(nb):
        v, w = 0.0, 0.0
        for m in range(3):
            v += ys[7 * nb + 3 * i + m] ** 2
            w += ys[10 * nb + 3 * i + m] ** 2
        speed = max(speed, np.sqrt(v) + length * np.sqrt(w))
    if not speed > 0.0:
        return OK
    tau = _NEIGHBOUR_SHIFT * length / speed
    for _ in range(_NEIGHBOUR_DOUBLINGS):
        clean = True
        for k in range(ny):
            mean[k] = 0.0
        for r in range(nc):
            lam_mean[r] = 0.0
        for sign in (-1.0, 1.0):
            _copy(ys, z)
            for k in range(3 * nb):  # positions by tau v, quaternions by tau dq/dt (dy holds it)
                z[k] += sign * tau * ys[7 * nb + k]
            for k in range(3 * nb, 7 * nb):
                z[k] += sign * tau * dy[k]
            st, rank, eigen = _project(z, model, ws, model[30], True)
            if st == OK:
                st = _derivative(t, z, dz, model, ws, True, rank, eigen)
            if st != OK or _residual(model, ws) > _SINGULAR_RESIDUAL:
                clean = False
                break
            for k in range(ny):
                mean[k] += 0.5 * dz[k]
            for r in range(nc):
                lam_mean[r] += 0.5 * ws[7][r]
        if clean:
            _copy(mean, dy)
            for r in range(nc):
                ws[7][r] = lam_mean[r]
            return OK
        tau *= 2.0
    return OK


@njit(**_INNER)
def _derivative(t, y, dy, model, ws, factored, rank, eigen):
    """``rhs`` at state y itself: dy/dt into dy. With ``factored`` ws A (or S and V when
    ``eigen``), B and d already hold ``_factor``'s factor of J M^-1 J^T at y's positions
    (``_project``'s last), of ``rank``: it is not formed again."""
    mass, I_B, Iinv, grav, nc = model[0], model[1], model[2], model[3], model[13]
    nb = mass.shape[0]
    _frames(y, nb, ws[0], ws[11])
    if nc > 0:  # the constraints' bias needs them
        _angular_velocities(y, nb, ws[0], ws[1])
    qn, u0, vec = ws[11], ws[6], ws[12]
    Iw, tau = vec[5], vec[6]
    for i in range(nb):
        w = y[10 * nb + 3 * i: 10 * nb + 3 * i + 3]
        for m in range(3):
            dy[3 * i + m] = y[7 * nb + 3 * i + m]
            u0[3 * i + m] = grav[i, m]
        _quat_rate(qn[i], w, dy[3 * nb + 4 * i: 3 * nb + 4 * i + 4], 1.0)
        _matvec(I_B[i], w, Iw)
        _cross(Iw, w, tau)  # -w x I w
        _matvec(Iinv[i], tau, u0[3 * nb + 3 * i: 3 * nb + 3 * i + 3])
    if model[22].shape[0] > 0:
        _springs(y, mass, Iinv, model[14], model[15], model[16], model[17], model[20], model[22], model[23], model[24],
                 ws[0], ws[12], u0)
    if model[27].shape[0] > 0:
        _applied(t, y, mass, Iinv, ws[0], ws[12], model[27], model[28], u0)
    if nc > 0:
        J, A, B, lam, bias, perm, rtol = ws[3], ws[4], ws[5], ws[7], ws[8], ws[13], model[25]
        st = _constraints(model, y, ws)
        if st != OK:
            return st
        if not factored:
            _minv_jt(mass, model[2], nc, ws[3], ws[4], ws[5])
        for r in range(nc):  # rhs = -gamma - J u0
            acc = -bias[r]
            for k in range(6 * nb):
                acc -= J[r, k] * u0[k]
            bias[r] = acc
        if not factored:
            st, rank, eigen = _factor(A, nc, perm, rtol, model[29], mass, model[2], J, B, ws[14], ws[15], ws[16])
            if st != OK:
                return st
        for r in range(nc):  # the right-hand side, kept for ``_residual`` (_solve overwrites it)
            ws[9][r] = bias[r]
        # near a singular configuration the per-state pseudo-inverse (eigen); dependent rows:
        # least squares, as the per-state pseudo-inverse
        _solve(A, bias, lam, nc, rank, perm, rtol, eigen, True, ws[14], ws[15], ws[16])
        for k in range(6 * nb):
            acc = u0[k]
            for r in range(nc):
                acc += B[k, r] * lam[r]
            u0[k] = acc
    for k in range(6 * nb):
        dy[7 * nb + k] = u0[k]
    return OK


@njit(**_KERNEL)
def project(y, model, ws, tol):
    """In place: unit quaternions, positions on the constraint manifold (mass-weighted
    Gauss-Newton until max |C| <= tol), velocities in the null space of J (mass-weighted
    orthogonal projection); as ``constraints.project`` (``_project`` after a step: its
    ``_QUADRATIC`` shortcut). Returns a status code."""
    return _project(y, model, ws, tol, False)[0]


@njit(**_INNER)
def _project(y, model, ws, tol, stage):
    """``project``: y in place. Without ``stage`` (as ``constraints.project``, after a step) a
    Gauss-Newton step from an error at or below ``_QUADRATIC`` is not re-evaluated and the
    velocities take the Jacobian of its start; with ``stage`` (as ``constraints.project_stage``,
    a stage of a model with loop joints) the positions are re-evaluated after every step until
    max |C| <= tol and the velocities take J at the final positions. Both solve the kept rows
    exactly (``_pivoted_solve``, the dependent rows' multipliers zero) where the per-state
    pseudo-inverse takes least squares: the same correction wherever the right-hand side is in the
    range of J M^-1 J^T (always for J u; for C off the manifold, up to second order in the
    distance: measured, the same projections and stage accelerations to the digits printed on the
    unit parallelogram 1e-8 and 1e-6 off the manifold within 1e-2 rad of flat). Returns (status,
    rank, eigen): ws A (or S and V when eigen), B and d hold ``_factor``'s factor of the Jacobian
    the velocities were projected with, of that rank."""
    mass, nc = model[0], model[13]
    nb = mass.shape[0]
    _unit_quaternions(y, nb, y[3 * nb: 7 * nb].reshape(nb, 4))
    if nc == 0:
        return OK, 0, False
    J, A, B, lam, C, dq, dth, perm, rtol = ws[3], ws[4], ws[5], ws[7], ws[9], ws[10], ws[12][7], ws[13], model[25]
    S, V, d = ws[14], ws[15], ws[16]
    factored = False  # whether ws A (or S and V) holds the factor of the last Gauss-Newton step
    converged = False
    rank = nc
    eigen = False
    for _ in range(_PROJECTION_ITERATIONS):
        _frames(y, nb, ws[0], ws[11])
        _angular_velocities(y, nb, ws[0], ws[1])  # for the bias _constraints fills
        st = _constraints(model, y, ws)
        if st != OK:
            return st, rank, eigen
        _minv_jt(mass, model[2], nc, ws[3], ws[4], ws[5])
        factored = False
        err = 0.0
        for r in range(nc):
            err = max(err, abs(C[r]))
        if not np.isfinite(err):
            return NONFINITE, rank, eigen
        if err <= tol:
            converged = True
            break
        st, rank, eigen = _factor(A, nc, perm, rtol, model[29], mass, model[2], J, B, S, V, d)
        if st != OK:
            return st, rank, eigen
        _solve(A, C, lam, nc, rank, perm, rtol, eigen, False, S, V, d)
        factored = True
        for i in range(nb):  # dx = -M^-1 J^T lam: positions, then q <- q (x) (1, dtheta_B / 2)
            for m in range(3):
                acc = 0.0
                for r in range(nc):
                    acc += B[3 * i + m, r] * lam[r]
                y[3 * i + m] -= acc
            for m in range(3):
                acc = 0.0
                for r in range(nc):
                    acc += B[3 * nb + 3 * i + m, r] * lam[r]
                dth[m] = -acc
            k = 3 * nb + 4 * i
            _quat_rate(y[k: k + 4], dth, dq, 1.0)
            n = 0.0
            for m in range(4):
                y[k + m] += dq[m]
                n += y[k + m] ** 2
            n = np.sqrt(n)
            for m in range(4):
                y[k + m] /= n
        if not stage and err <= _QUADRATIC:
            converged = True
            break
    if not converged:
        return NO_PROJECTION, rank, eigen
    # velocities: u -= B (A^-1 J u), with J of the last evaluation (as constraints.project)
    if not factored:
        st, rank, eigen = _factor(A, nc, perm, rtol, model[29], mass, model[2], J, B, S, V, d)
        if st != OK:
            return st, rank, eigen
    for r in range(nc):
        acc = 0.0
        for k in range(6 * nb):
            acc += J[r, k] * y[7 * nb + k]
        C[r] = acc
    _solve(A, C, lam, nc, rank, perm, rtol, eigen, False, S, V, d)
    for k in range(6 * nb):
        acc = 0.0
        for r in range(nc):
            acc += B[k, r] * lam[r]
        y[7 * nb + k] -= acc
    return OK, rank, eigen


@njit(**_INNER)
def _copy(src, dst):
    """dst[:] = src (1-d arrays of the same length; as a loop: NumPy's array assignment needs
    reference counting, which the work below the drivers is compiled without)."""
    for k in range(src.shape[0]):
        dst[k] = src[k]


@njit(**_INNER)
def _finite(y):
    """Whether every entry of y is finite."""
    for k in range(y.shape[0]):
        if not np.isfinite(y[k]):
            return False
    return True


# ---------------------------------------------------------------------------------------------
# Explicit Runge-Kutta methods, fixed step, driven by a Butcher table


@njit(**_INNER)
def _exp_right(qw, qx, qy, qz, tx, ty, tz, out, o):
    """out[o:o+4] = q (x) exp_q(Theta) (wxyz) for q = (qw, qx, qy, qz) and Theta = (tx, ty, tz)
    (rad, body frame): ``lie_group.exp_right``. q's entries come by value: out may hold q."""
    angle = np.sqrt(tx * tx + ty * ty + tz * tz)
    c = np.cos(0.5 * angle)
    s = np.sin(0.5 * angle) / angle if angle > 0.0 else 0.5
    ex, ey, ez = s * tx, s * ty, s * tz
    out[o] = qw * c - qx * ex - qy * ey - qz * ez
    out[o + 1] = qw * ex + c * qx + (qy * ez - qz * ey)
    out[o + 2] = qw * ey + c * qy + (qz * ex - qx * ez)
    out[o + 3] = qw * ez + c * qz + (qx * ey - qy * ex)


@njit(**_INNER)
def _lie_stage(y, nb, i, h, A, series, KT, tmp):
    """The orientations of RKMK stage i (``lie_group.rkmk_step``): per body
    ``Theta_i = h sum_{m < i} A[i, m] KT[m]``, the stage quaternion ``q0 (x) exp_q(Theta_i)``
    into tmp (q0 from y) and ``KT[i] = sum_k series[k] ad_Theta_i^k (w_i)`` (the truncated
    ``dexp^-1``) from the stage's body angular velocity w_i in tmp."""
    for body in range(nb):
        tx = ty = tz = 0.0
        for m in range(i):
            a = h * A[i, m]
            tx += a * KT[m, body, 0]
            ty += a * KT[m, body, 1]
            tz += a * KT[m, body, 2]
        q = 3 * nb + 4 * body
        _exp_right(y[q], y[q + 1], y[q + 2], y[q + 3], tx, ty, tz, tmp, q)
        w = 10 * nb + 3 * body
        ux, uy, uz = tmp[w], tmp[w + 1], tmp[w + 2]
        ox, oy, oz = ux, uy, uz
        for k in range(1, series.shape[0]):
            ux, uy, uz = ty * uz - tz * uy, tz * ux - tx * uz, tx * uy - ty * ux  # u <- Theta x u
            ox += series[k] * ux
            oy += series[k] * uy
            oz += series[k] * uz
        KT[i, body, 0] = ox
        KT[i, body, 1] = oy
        KT[i, body, 2] = oz


@njit(**_INNER)
def _erk_steps(model, ws, y, t0, h, nsteps, proj_tol, A, b, c, series, K, KT, tmp):
    """``nsteps`` steps of ``h`` s from time ``t0`` s of the explicit Runge-Kutta method with
    Butcher table ``A`` (s x s, strictly lower triangular), ``b`` (s,), ``c`` (s,), y in place,
    projection after each step; with ``series`` (the ``dexp^-1`` coefficients, non-empty) in
    Runge-Kutta-Munthe-Kaas form (``_lie_stage``). K (s x ny), KT (s x nb x 3: the algebra
    rates) and tmp (ny,) are scratch. Returns (status, steps taken, counting a failed one)."""
    n = y.shape[0]
    s = b.shape[0]
    nb = n // 13
    lie = series.shape[0] > 0
    for j in range(nsteps):
        t = t0 + j * h
        for i in range(s):  # stage i at y + h sum_{m < i} A[i, m] K[m]
            for k in range(n):
                acc = 0.0
                for m in range(i):
                    acc += A[i, m] * K[m, k]
                tmp[k] = y[k] + h * acc
            if lie:
                _lie_stage(y, nb, i, h, A, series, KT, tmp)
            st = rhs(t + c[i] * h, tmp, K[i], model, ws)
            if st != OK:
                return st, j + 1
        if lie:  # the orientations: q0 (x) exp_q(h sum_i b_i KT[i]), in place
            for body in range(nb):
                tx = ty = tz = 0.0
                for i in range(s):
                    a = h * b[i]
                    tx += a * KT[i, body, 0]
                    ty += a * KT[i, body, 1]
                    tz += a * KT[i, body, 2]
                q = 3 * nb + 4 * body
                _exp_right(y[q], y[q + 1], y[q + 2], y[q + 3], tx, ty, tz, y, q)
        for k in range(n):
            if lie and 3 * nb <= k < 7 * nb:
                continue
            acc = 0.0
            for i in range(s):
                acc += b[i] * K[i, k]
            y[k] += h * acc
        st = project(y, model, ws, proj_tol)
        if st != OK:
            return st, j + 1
    return OK, nsteps


@njit(**_INNER)
def _erk(model, ws, y, K, KT, tmp, t_save, steps_per_save, proj_tol, out, A, b, c, series):
    """``erk`` on its (borrowed) buffers; y holds the initial state."""
    st = project(y, model, ws, proj_tol)
    if st != OK or not _finite(y):
        return (st if st != OK else NONFINITE), 0, 0
    _copy(y, out[0])
    steps = 0
    for s in range(1, t_save.shape[0]):
        t0 = t_save[s - 1]
        h = (t_save[s] - t0) / steps_per_save
        st, taken = _erk_steps(model, ws, y, t0, h, steps_per_save, proj_tol, A, b, c, series, K, KT, tmp)
        steps += taken
        if st != OK:
            return st, s, steps
        if not _finite(y):
            return NONFINITE, s, steps
        _copy(y, out[s])
    return OK, t_save.shape[0], steps


@njit(**_JIT)
def erk(model, y0, t_save, steps_per_save, proj_tol, out, A, b, c, series, lam_out):
    """The explicit Runge-Kutta method (A, b, c) with ``steps_per_save`` equal steps between
    the save times ``t_save`` (s), projection after each step (and of ``y0``); samples into
    ``out`` (len(t_save) x ny); in Runge-Kutta-Munthe-Kaas form when the ``dexp^-1``
    coefficients ``series`` are not empty (``_erk_steps``); the constraint multipliers at the
    samples into ``lam_out`` (len(t_save) x nc) unless it has no rows (``_multipliers``).
    Returns (status, samples, steps)."""
    n = y0.shape[0]
    ws, y, K, tmp = workspace(model), y0.copy(), np.empty((b.shape[0], n)), np.empty(n)
    ws[17][ws[17].shape[0] - 1] = 1.0  # fixed steps: a stage in a singular band takes its neighbours' mean (rhs)
    KT = np.empty((b.shape[0], n // 13, 3))
    result = _erk(_borrow(model), _borrow(ws), _borrow(y), _borrow(K), _borrow(KT), _borrow(tmp), t_save,
                  steps_per_save, proj_tol, out, A, b, c, series)
    _multipliers(_borrow(model), _borrow(ws), t_save, out, result[1], _borrow(tmp), lam_out)
    _hold((ws, y, K, KT, tmp))
    return result


@njit(**_INNER)
def _multipliers(model, ws, t_save, out, samples, dy, lam_out):
    """The constraint multipliers of ``rhs`` (ws lam: the KKT system's, the per-state
    ``make_dynamics``' second result) at each of the first ``samples`` saved states
    ``out[s]`` at ``t_save[s]``, into ``lam_out[s]`` (NaN where ``rhs`` fails there); nothing
    when ``lam_out`` has no rows. dy: scratch (ny)."""
    if lam_out.shape[0] == 0:
        return
    nc, lam = model[13], ws[7]
    for s in range(samples):
        st = rhs(t_save[s], out[s], dy, model, ws)
        for r in range(nc):
            lam_out[s, r] = lam[r] if st == OK else np.nan


@njit(**_INNER)
def _erk_rows(model, ws, y, K, KT, tmp, Y0, nstep, h, proj_tol, A, b, c, series, Yend, status, first, last):
    """``erk_rows`` on its (borrowed) buffers."""
    for r in range(first, last):
        _copy(Y0[r], y)
        st = project(y, model, ws, proj_tol)
        if st == OK:
            st, _ = _erk_steps(model, ws, y, 0.0, h, nstep, proj_tol, A, b, c, series, K, KT, tmp)
        if st == OK and not _finite(y):
            st = NONFINITE
        status[r] = st
        if st == OK:
            _copy(y, Yend[r])
        else:
            Yend[r] = np.nan


@njit(**_JIT)
def erk_rows(model, Y0, nstep, h, proj_tol, A, b, c, series, Yend, status, first, last):
    """Rows ``first .. last-1`` of a batch, one trajectory after the other: from each initial
    state ``Y0[r]`` (nbatch x ny; projected first), ``nstep`` steps of ``h`` s of the method
    (A, b, c; with ``series`` as ``erk``) from t = 0. The final state goes to ``Yend[r]`` (NaN
    for a trajectory that did not finish), its status code to ``status[r]``. A failing
    trajectory stops alone: the others never see it."""
    n = Y0.shape[1]
    ws, y, K, tmp = workspace(model), np.empty(n), np.empty((b.shape[0], n)), np.empty(n)
    ws[17][ws[17].shape[0] - 1] = 1.0  # fixed steps: a stage in a singular band takes its neighbours' mean (rhs)
    KT = np.empty((b.shape[0], n // 13, 3))
    _erk_rows(_borrow(model), _borrow(ws), _borrow(y), _borrow(K), _borrow(KT), _borrow(tmp), Y0, nstep, h, proj_tol,
              A, b, c, series, Yend, status, first, last)
    _hold((ws, y, K, KT, tmp))


# ---------------------------------------------------------------------------------------------
# DOP853, adaptive, with 7th-order dense output at the save times


@njit(**_INNER)
def _stage_state(y, K, A, s, h, out):
    """out = y + h sum_{m < s} A[s, m] K[m]: the state at which stage s is evaluated."""
    for i in range(y.shape[0]):
        acc = 0.0
        for m in range(s):
            acc += A[s, m] * K[m, i]
        out[i] = y[i] + h * acc


@njit(**_JIT)
def dop853(model, y0, t_save, rtol, atol, first_step, max_step, proj_tol, max_steps, out, coef, lam_out):
    """DOP853 (Hairer's coefficients ``coef = (A, B, C, E3, E5, D)``, SciPy's tables), step-size
    control as SciPy's ``DOP853``, projection after each accepted step (and of ``y0``), 7th-order
    dense output at the save times ``t_save`` (s) inside a step, samples into ``out``
    (len(t_save) x ny); the constraint multipliers at the samples into ``lam_out`` as ``erk``.
    ``first_step`` (s) <= 0 selects the first step as SciPy does;
    ``max_step`` (s) > 0 caps every step as SciPy's ``max_step`` (<= 0: no cap); more than
    ``max_steps`` accepted + rejected steps fail. Returns (status, samples, steps, rejected,
    rhs_evals)."""
    n = y0.shape[0]
    ws, y, K = workspace(model), y0.copy(), np.zeros((coef[0].shape[0], n))
    ynew, tmp, F, samp = np.empty(n), np.empty(n), np.empty((7, n)), np.empty(n)
    result = _dop853(_borrow(model), _borrow(ws), _borrow(y), _borrow(K), _borrow(ynew), _borrow(tmp), _borrow(F),
                     _borrow(samp), t_save, rtol, atol, first_step, max_step, proj_tol, max_steps, out, coef)
    _multipliers(_borrow(model), _borrow(ws), t_save, out, result[1], _borrow(tmp), lam_out)
    _hold((ws, y, K, ynew, tmp, F, samp))
    return result


@njit(**_INNER)
def _dop853(model, ws, y, K, ynew, tmp, F, samp, t_save, rtol, atol, first_step, max_step, proj_tol, max_steps, out,
            coef):
    """``dop853`` on its (borrowed) buffers; y holds the initial state."""
    A, Bw, Cn, E3, E5, D = coef
    n_stages = 12
    n_ext = A.shape[0]
    n = y.shape[0]
    evals = 0
    st = project(y, model, ws, proj_tol)
    if st != OK or not _finite(y):
        return (st if st != OK else NONFINITE), 0, 0, 0, evals
    _copy(y, out[0])
    t, t_end = t_save[0], t_save[t_save.shape[0] - 1]
    st = rhs(t, y, K[0], model, ws)
    evals += 1
    if st != OK:
        return st, 1, 0, 0, evals
    safety, min_factor, max_factor, exponent = 0.9, 0.2, 10.0, -1.0 / 8.0
    if first_step > 0.0:
        h_abs = first_step
    else:  # SciPy's select_initial_step (order 7)
        d0 = d1 = 0.0
        for i in range(n):
            sc = atol + abs(y[i]) * rtol
            d0 += (y[i] / sc) ** 2
            d1 += (K[0, i] / sc) ** 2
        d0, d1 = np.sqrt(d0 / n), np.sqrt(d1 / n)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, t_end - t)
        for i in range(n):
            tmp[i] = y[i] + h0 * K[0, i]
        st = rhs(t + h0, tmp, K[1], model, ws)
        evals += 1
        if st != OK:
            return st, 1, 0, 0, evals
        d2 = 0.0
        for i in range(n):
            sc = atol + abs(y[i]) * rtol
            d2 += ((K[1, i] - K[0, i]) / sc) ** 2
        d2 = np.sqrt(d2 / n) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        h_abs = min(100.0 * h0, h1)
        if max_step > 0.0:
            h_abs = min(h_abs, max_step)
    h_abs = min(h_abs, t_end - t)
    n_save = t_save.shape[0]
    k_next = 1
    steps = 0
    rejected = 0
    while t < t_end and k_next < n_save:
        step_rejected = False
        if max_step > 0.0 and h_abs > max_step:  # as SciPy, at the start of each step
            h_abs = max_step
        while True:
            h = min(h_abs, t_end - t)
            if h < 10.0 * np.abs(np.spacing(t)):
                return UNDERFLOW, k_next, steps, rejected, evals
            for s in range(1, n_stages):
                _stage_state(y, K, A, s, h, tmp)
                st = rhs(t + Cn[s] * h, tmp, K[s], model, ws)
                if st != OK:
                    return st, k_next, steps, rejected, evals
            for i in range(n):
                acc = 0.0
                for m in range(n_stages):
                    acc += Bw[m] * K[m, i]
                ynew[i] = y[i] + h * acc
            st = rhs(t + h, ynew, K[n_stages], model, ws)
            evals += n_stages
            if st != OK:
                return st, k_next, steps, rejected, evals
            e5 = e3 = 0.0
            for i in range(n):
                sc = atol + max(abs(y[i]), abs(ynew[i])) * rtol
                a5 = 0.0
                a3 = 0.0
                for m in range(n_stages + 1):
                    a5 += E5[m] * K[m, i]
                    a3 += E3[m] * K[m, i]
                e5 += (a5 / sc) ** 2
                e3 += (a3 / sc) ** 2
            denom = e5 + 0.01 * e3
            err = h * e5 / np.sqrt(denom * n) if denom > 0.0 else 0.0
            if not np.isfinite(err):
                return BAD_ERROR, k_next, steps, rejected, evals
            if err < 1.0:
                factor = max_factor if err == 0.0 else min(max_factor, safety * err ** exponent)
                if step_rejected:
                    factor = min(1.0, factor)
                h_abs = h * factor
                break
            h_abs = h * max(min_factor, safety * err ** exponent)
            step_rejected = True
            rejected += 1
            if steps + rejected > max_steps:
                return TOO_MANY_STEPS, k_next, steps, rejected, evals
        t_new = t + h
        tol_t = 1e-12 * max(1.0, abs(t_new))
        dense_ready = False
        while k_next < n_save and t_save[k_next] <= t_new + tol_t:
            if t_save[k_next] < t_new - tol_t:  # a save time inside the step: dense output
                if not dense_ready:
                    for s in range(n_stages + 1, n_ext):
                        _stage_state(y, K, A, s, h, tmp)
                        st = rhs(t + Cn[s] * h, tmp, K[s], model, ws)
                        if st != OK:
                            return st, k_next, steps, rejected, evals
                    evals += n_ext - n_stages - 1
                    for i in range(n):
                        dz = ynew[i] - y[i]
                        F[0, i] = dz
                        F[1, i] = h * K[0, i] - dz
                        F[2, i] = 2.0 * dz - h * (K[n_stages, i] + K[0, i])
                        for r in range(4):
                            acc = 0.0
                            for m in range(n_ext):
                                acc += D[r, m] * K[m, i]
                            F[3 + r, i] = h * acc
                    dense_ready = True
                x = (t_save[k_next] - t) / h
                for i in range(n):
                    acc = 0.0
                    for r in range(6, -1, -1):
                        acc += F[r, i]
                        acc *= x if (6 - r) % 2 == 0 else (1.0 - x)
                    samp[i] = y[i] + acc
                st = project(samp, model, ws, proj_tol)
                if st != OK:
                    return st, k_next, steps, rejected, evals
                if not _finite(samp):
                    return NONFINITE, k_next, steps, rejected, evals
                _copy(samp, out[k_next])
                k_next += 1
            else:  # the step ends on this save time
                break
        st = project(ynew, model, ws, proj_tol)
        if st != OK:
            return st, k_next, steps, rejected, evals
        if not _finite(ynew):
            return NONFINITE, k_next, steps, rejected, evals
        if k_next < n_save and t_save[k_next] <= t_new + tol_t:
            _copy(ynew, out[k_next])
            k_next += 1
        steps += 1
        if steps + rejected > max_steps:
            return TOO_MANY_STEPS, k_next, steps, rejected, evals
        t = t_new
        _copy(ynew, y)
        st = rhs(t, y, K[0], model, ws)
        evals += 1
        if st != OK:
            return st, k_next, steps, rejected, evals
    return OK, k_next, steps, rejected, evals
