"""The Pinocchio engine's fast stepping: the written-out RKMK4 stages and the direct LAPACK calls
give the numbers of the textbook form (tableau sums, ``np.linalg``) to round-off.

SciPy's LAPACK and NumPy's ``np.linalg`` are two bundled OpenBLAS builds whose kernels are chosen
by CPU (and ``OPENBLAS_CORETYPE``): their results agree to the forward-error bound of the routine,
not bitwise, so every comparison here is to a stated bound of round-off (``EPS`` times the
problem's size and condition number)."""

import numpy as np
import pinocchio as pin
import pytest

from harness.engines.pinocchio import linalg
from harness.engines.pinocchio.lie_group_integrators import RK4_A, RK4_B, RK4_C, curved_blocks, rkmk4_step, stepper


def _textbook_rkmk4(model, accel, t, q, v, h):
    """RKMK4 as the tableau states it: stage sums over all a_ij, ``np.linalg.solve`` on the whole
    ``dIntegrate`` matrix."""
    kq, kv = [], []
    for a_row, c in zip(RK4_A, RK4_C):
        theta = h * sum((a * k for a, k in zip(a_row, kq)), np.zeros(model.nv))
        v_i = v + h * sum((a * k for a, k in zip(a_row, kv)), np.zeros(model.nv))
        q_i = pin.integrate(model, q, theta)
        if a_row and np.any(theta):
            kq.append(np.linalg.solve(pin.dIntegrate(model, q, theta, pin.ArgumentPosition.ARG1), v_i))
        else:
            kq.append(v_i)
        kv.append(accel(t + c * h, q_i, v_i))
    theta = h * sum(b * k for b, k in zip(RK4_B, kq))
    return pin.integrate(model, q, theta), v + h * sum(b * k for b, k in zip(RK4_B, kv))


EPS = np.finfo(float).eps


def assert_roundoff_close(actual, expected, bound: float) -> None:
    """``actual`` equals ``expected`` to ``bound`` relative to the largest entry of ``expected``."""
    scale = max(float(np.max(np.abs(expected))), np.finfo(float).tiny)
    np.testing.assert_allclose(actual, expected, rtol=0, atol=bound * scale)


def _humanoid():
    model = pin.buildSampleModelHumanoidRandom()  # free flyer and revolute joints
    data = model.createData()

    def accel(t, q, v):
        return pin.aba(model, data, q, v, np.sin(3.0 * t) * np.ones(model.nv)).copy()

    return model, accel


def test_curved_blocks_are_the_free_flyer_and_spherical_joints():
    model, _ = _humanoid()
    assert curved_blocks(model) == [(0, 6)]
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "a")
    j = m.addJoint(j, pin.JointModelSpherical(), pin.SE3.Identity(), "b")
    m.addJoint(j, pin.JointModelPY(), pin.SE3.Identity(), "c")
    assert curved_blocks(m) == [(1, 4)]


def test_rkmk4_stages_equal_the_textbook_form_to_roundoff():
    model, accel = _humanoid()
    rng = np.random.default_rng(0)
    q0 = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v0 = rng.normal(size=model.nv)
    step = stepper("rkmk4", model)
    qa, va, qb, vb, qc, vc = q0, v0, q0, v0, q0, v0
    for k in range(50):
        t = k * 1e-3
        qa, va = _textbook_rkmk4(model, accel, t, qa, va, 1e-3)
        qb, vb = step(accel, t, qb, vb, 1e-3)
        qc, vc = rkmk4_step(model, accel, t, qc, vc, 1e-3)
    # 50 steps of a 27-DOF humanoid whose stage solves differ only in the LAPACK build: the
    # states agree to round-off accumulated over the steps (measured 0 to 1e-15 relative)
    for q, v in ((qb, vb), (qc, vc)):
        assert_roundoff_close(q, qa, 1e-12)
        assert_roundoff_close(v, va, 1e-12)


@pytest.mark.parametrize("n,m", [(3, 6), (7, 18), (5, 3)])
def test_linalg_equals_numpy_to_roundoff(n, m):
    """Each routine against ``np.linalg``'s, to its forward-error bound: ``n eps kappa`` for the
    Cholesky factor and the solve, ``m n eps kappa^2`` for least squares (the normal equations'
    condition, the loose end of the SVD solver's bound); kappa from ``np.linalg.cond``."""
    rng = np.random.default_rng(n)
    for _ in range(50):
        B = rng.normal(size=(n, n))
        M = B @ B.T + n * np.eye(n)
        upper = np.triu(M)
        assert np.array_equal(linalg.symmetric_from_upper(upper.copy()), M)  # copies, no arithmetic
        kappa = np.linalg.cond(M)
        L = linalg.cholesky(upper.T)
        assert L.flags.c_contiguous and np.array_equal(L, np.tril(L))
        assert_roundoff_close(L, np.linalg.cholesky(M), 4 * n * EPS * kappa)
        J = rng.normal(size=(m, n))
        X = linalg.solve(L, J.T)
        assert X.flags.c_contiguous
        assert_roundoff_close(X, np.linalg.solve(L, J.T), 4 * n * EPS * np.linalg.cond(L))
        A = X.T
        b = rng.normal(size=m)
        assert_roundoff_close(linalg.lstsq(A, b, 1e-10), np.linalg.lstsq(A, b, rcond=1e-10)[0],
                              4 * m * n * EPS * np.linalg.cond(A) ** 2)
    with pytest.raises(np.linalg.LinAlgError):
        linalg.cholesky(-np.eye(n))
    with pytest.raises(np.linalg.LinAlgError):
        linalg.solve(np.zeros((n, n)), np.ones(n))


def test_svd_u_equals_numpy_to_roundoff():
    rng = np.random.default_rng(7)
    for rows in (rng.normal(size=(3, 3)), rng.normal(size=(6, 4))):
        rows[-1] = rows[0] + rows[1]  # a dependent row, as on the rolling cone
        U, s, _ = np.linalg.svd(rows, full_matrices=False)
        U2, s2 = linalg.svd_u(rows)
        assert U2.flags.c_contiguous
        n = min(rows.shape)
        assert_roundoff_close(s2, s, 4 * n * EPS)  # singular values: backward stable, absolute in s[0]
        # singular vectors of the kept (non-zero) values, each up to its sign; their error grows
        # with the inverse gap to the neighbouring singular values
        kept = s > 1e-12 * s[0]
        gap = min(np.min(np.abs(np.diff(s))), s[kept][-1])
        signs = np.sign(np.sum(U[:, kept] * U2[:, kept], axis=0))
        assert_roundoff_close(U2[:, kept] * signs, U[:, kept], 4 * n * EPS * s[0] / gap)
