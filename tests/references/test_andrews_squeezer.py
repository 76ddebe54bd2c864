"""The Andrews squeezer reference against the IVP test set: its printed equations (mass matrix,
forces, closure Jacobian), its consistent initial state, and its published state at t = 0.03 s."""

import numpy as np
import pytest

from harness.model.builders import andrews_squeezer as builder
from harness.model.errors import InputError
from harness.engines import load_scene
from harness.references import andrews_squeezer as ref


@pytest.fixture(scope="module")
def params():
    return {k: float(v) for k, v in load_scene("andrews_squeezer").params.items()}


def _printed_terms(p, q, v):
    """M(q), f(q, q') (without gravity) and G(q) as the test set prints them (Fortran F, gp)."""
    sibe, sith, siga, siph, side, siom, siep = np.sin(q)
    cobe, coth, coga, coph, code, coom, coep = np.cos(q)
    sibeth, cobeth = np.sin(q[0] + q[1]), np.cos(q[0] + q[1])
    siphde, cophde = np.sin(q[3] + q[4]), np.cos(q[3] + q[4])
    siomep, coomep = np.sin(q[5] + q[6]), np.cos(q[5] + q[6])
    bep, thp, _, php, dep, omp, epp = v
    g = {k: p[k] for k in p}
    m1, m2, m3, m4, m5, m6, m7 = (g[f"m{k}"] for k in range(1, 8))
    i1, i2, i3, i4, i5, i6, i7 = (g[f"i{k}"] for k in range(1, 8))
    rr, ra, d, da, e, ea, zf, fa, zt, u = (g[k] for k in ("rr", "ra", "d", "da", "e", "ea", "zf", "fa", "zt", "u"))
    ss, sa, sb, sc, sd, ta, tb, ua, ub = (g[k] for k in ("ss", "sa", "sb", "sc", "sd", "ta", "tb", "ua", "ub"))
    M = np.zeros((7, 7))
    M[0, 0] = m1 * ra**2 + m2 * (rr**2 - 2 * da * rr * coth + da**2) + i1 + i2
    M[1, 0] = m2 * (da**2 - da * rr * coth) + i2
    M[1, 1] = m2 * da**2 + i2
    M[2, 2] = m3 * (sa**2 + sb**2) + i3
    M[3, 3] = m4 * (e - ea) ** 2 + i4
    M[4, 3] = m4 * ((e - ea) ** 2 + zt * (e - ea) * siph) + i4
    M[4, 4] = m4 * (zt**2 + 2 * zt * (e - ea) * siph + (e - ea) ** 2) + m5 * (ta**2 + tb**2) + i4 + i5
    M[5, 5] = m6 * (zf - fa) ** 2 + i6
    M[6, 5] = m6 * ((zf - fa) ** 2 - u * (zf - fa) * siom) + i6
    M[6, 6] = m6 * ((zf - fa) ** 2 - 2 * u * (zf - fa) * siom + u**2) + m7 * (ua**2 + ub**2) + i6 + i7
    M = np.tril(M) + np.tril(M, -1).T
    xd = sd * coga + sc * siga + g["xb"]
    yd = sd * siga - sc * coga + g["yb"]
    lang = np.hypot(xd - g["xc"], yd - g["yc"])
    force = -g["c0"] * (lang - g["l0"]) / lang
    fx, fy = force * (xd - g["xc"]), force * (yd - g["yc"])
    f = np.array([
        g["mom"] - m2 * da * rr * thp * (thp + 2 * bep) * sith,
        m2 * da * rr * bep**2 * sith,
        fx * (sc * coga - sd * siga) + fy * (sd * coga + sc * siga),
        m4 * zt * (e - ea) * dep**2 * coph,
        -m4 * zt * (e - ea) * php * (php + 2 * dep) * coph,
        -m6 * u * (zf - fa) * epp**2 * coom,
        m6 * u * (zf - fa) * omp * (omp + 2 * epp) * coom,
    ])
    G = np.zeros((6, 7))
    G[0, :3] = [-rr * sibe + d * sibeth, d * sibeth, -ss * coga]
    G[1, :3] = [rr * cobe - d * cobeth, -d * cobeth, -ss * siga]
    G[2, [0, 1, 3, 4]] = [-rr * sibe + d * sibeth, d * sibeth, -e * cophde, -e * cophde + zt * side]
    G[3, [0, 1, 3, 4]] = [rr * cobe - d * cobeth, -d * cobeth, -e * siphde, -e * siphde - zt * code]
    G[4, [0, 1, 5, 6]] = [-rr * sibe + d * sibeth, d * sibeth, zf * siomep, zf * siomep - u * coep]
    G[5, [0, 1, 5, 6]] = [rr * cobe - d * cobeth, -d * cobeth, -zf * coomep, -zf * coomep - u * siep]
    return M, f, G


def test_the_derived_equations_are_the_test_sets_printed_ones(params):
    rng = np.random.default_rng(7)
    for _ in range(20):
        q, v = rng.uniform(-np.pi, np.pi, 7), rng.uniform(-100.0, 100.0, 7)
        M, f, g, G, _ = ref.dynamics_terms(params, q, v)
        Mp, fp, Gp = _printed_terms(params, q, v)
        assert np.allclose(M, Mp, rtol=1e-12, atol=1e-18)
        assert np.allclose(f, fp, rtol=1e-10, atol=1e-12 * np.max(np.abs(fp)))
        assert np.allclose(G, Gp, rtol=1e-12, atol=1e-16)
        assert np.allclose(G, builder.closure(params, q)[1], rtol=1e-12, atol=1e-16)


def test_all_points_at_once_are_each_points_chain(params):
    """``all_point_kinematics`` (what the dynamics use) is ``point_kinematics`` of each chain."""
    rng = np.random.default_rng(11)
    chains = ref.points(params)
    names = ("c1", "c2", "c3", "c4", "c5", "c6", "c7", "D", "E2", "E3", "E4", "E6")
    assert set(chains) == set(names)
    for _ in range(10):
        q, v = rng.uniform(-np.pi, np.pi, 7), rng.uniform(-100.0, 100.0, 7)
        P, J, b = ref.all_point_kinematics(params, q, v)
        for k, name in enumerate(names):
            Pk, Jk, bk = ref.point_kinematics(chains[name], q, v)
            assert np.allclose(P[k], Pk, rtol=0, atol=1e-15) and np.allclose(J[k], Jk, rtol=0, atol=1e-15)
            assert np.allclose(b[k], bk, rtol=1e-14, atol=1e-12)


def test_the_velocity_product_term_of_the_closure_is_its_second_derivative(params):
    """b_g = d(G q')/dt at constant q'': a finite difference of G(q + h q') q' along the motion."""
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-np.pi, np.pi, 7), rng.uniform(-10.0, 10.0, 7)
    _, _, _, G, bg = ref.dynamics_terms(params, q, v)
    h = 1e-6
    Gp = ref.dynamics_terms(params, q + h * v, v)[3]
    Gm = ref.dynamics_terms(params, q - h * v, v)[3]
    assert np.allclose((Gp - Gm) @ v / (2 * h), bg, rtol=1e-6, atol=1e-9 * np.max(np.abs(bg)))


def test_the_assembly_is_the_test_sets_consistent_initial_state(params):
    q0 = np.array([-0.0617138900142764496358948458001, 0.0, 0.455279819163070380255912382449,
                   0.222668390165885884674473185609, 0.487364979543842550225598953530,
                   -0.222668390165885884674473185609, 1.23054744454982119249735015568])
    q, v = ref.initial_state(params)
    assert np.max(np.abs(q - q0)) < 1e-14
    assert not np.any(v)
    a, lam = ref.accelerations(params, q, v)  # the test set's initial q'' and lambda
    assert a[:2] == pytest.approx([14222.4439199541138705911625887, -10666.8329399655854029433719415], rel=1e-12)
    assert lam[:2] == pytest.approx([98.5668703962410896057654982170, -6.12268834425566265503114393122], rel=1e-12)
    assert np.max(np.abs(a[2:])) < 1e-9 and np.max(np.abs(lam[2:])) < 1e-12


def test_the_integration_reproduces_the_published_state_at_t_003(params):
    """Converged (DOP853 at rtol 1e-11 and 1e-13 agree to 1e-9 relative in q'), and 9.5 digits of
    the published positions, 7 of its velocities, 5.8 of its accelerations and multipliers: the
    published state carries ~1e-9 relative error in q (its own integration's), ours ~1e-12."""
    t = np.array([0.0, ref.PUBLISHED["t"]])
    tight = ref.reference_solution(params, t)
    loose = ref.reference_solution(params, t, rtol=1e-11, atol=1e-11)
    assert ref.correct_digits(loose.q[-1], tight.q[-1]) > 11.0
    assert ref.correct_digits(loose.v[-1], tight.v[-1]) > 9.0
    assert ref.correct_digits(tight.q[-1], ref.PUBLISHED["q"]) > 9.3
    assert ref.correct_digits(tight.v[-1], ref.PUBLISHED["v"]) > 7.0
    a, lam = ref.accelerations(params, tight.q[-1], tight.v[-1])
    assert ref.correct_digits(a, ref.PUBLISHED["a"]) > 5.5
    assert ref.correct_digits(lam, ref.PUBLISHED["lambda"]) > 5.5
    assert abs(ref.energy(params, tight.q[-1], tight.v[-1]) / ref.energy(params, tight.q[0], tight.v[0]) - 1.0) < 1e-10


def test_geometry_that_cannot_close_is_refused_with_one_line(params):
    with pytest.raises(InputError, match="cannot assemble"):
        builder.assemble({**params, "ss": 0.2}, 0.0)
