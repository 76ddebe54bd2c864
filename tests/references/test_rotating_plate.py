"""harness.references.rotating_plate (Ex. 4.6.1) against the angular momentum of mass points.

The plate is a set of Gauss-Legendre mass points (exact second moments); it turns about the
fixed vertical axis at constant rate, and the bearings' couple is the time derivative of the
points' total angular momentum about the centre of mass (fourth-order central differences),
independent of the reference's principal-moment formula.
"""

from __future__ import annotations

import numpy as np
import pytest

from harness.references import rotating_plate as rp


def mass_points(m, a, h, n=3):
    x, w = np.polynomial.legendre.leggauss(n)
    X, Y, Z = np.meshgrid(a * x, 0.5 * a * x, 0.5 * h * x, indexing="ij")  # sides 2a, a, h
    W = np.einsum("i,j,k->ijk", w, w, w) / 8.0
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1), m * W.ravel()


def R_y(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def R_z(t):
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def angular_momentum(pts, dm, phi, omega, t):
    """L about the centre (world) when the plate turns about world z at rate omega; at t = 0 the
    plate's principal frame is tilted so that its normal makes the angle phi with z in its x-z
    plane."""
    R = R_z(omega * t) @ R_y(-phi)
    r = pts @ R.T
    v = np.cross([0.0, 0.0, omega], r)
    return np.sum(dm[:, None] * np.cross(r, v), axis=0), R


@pytest.mark.parametrize("m, a, h, phi, omega", [(1.0, 0.2, 0.005, 0.5, 10.0), (3.0, 0.5, 0.0, 1.1, -4.0), (2.0, 0.3, 0.1, -0.3, 7.0)])
def test_couple_is_the_rate_of_angular_momentum(m, a, h, phi, omega):
    pts, dm = mass_points(m, a, h)
    assert np.allclose(np.einsum("p,pi,pj->ij", dm, pts, pts).diagonal(),
                       [np.sum(dm * pts[:, 0] ** 2), np.sum(dm * pts[:, 1] ** 2), np.sum(dm * pts[:, 2] ** 2)])
    I = rp.principal_moments(m, a, h)
    second = np.array([np.sum(dm * pts[:, k] ** 2) for k in range(3)])
    assert np.allclose(I, second.sum() - second, rtol=1e-13)
    hstep = 1e-3 / abs(omega)
    for t in (0.0, 0.37, 1.9):
        Ls = [angular_momentum(pts, dm, phi, omega, t + k * hstep)[0] for k in (-2, -1, 1, 2)]
        dL = (Ls[0] - 8 * Ls[1] + 8 * Ls[2] - Ls[3]) / (12 * hstep)
        R = angular_momentum(pts, dm, phi, omega, t)[1]
        expected = rp.couple(m, a, h, phi, omega) * R[:, 1]  # along the plate's turning y axis
        assert np.allclose(dL, expected, atol=1e-9 * m * a * a * omega * omega)


def test_textbook_ex461_bearing_force():
    """F = m a^2 w^2 cos(phi) sin(phi) / (6 d) for the thin plate (h -> 0)."""
    m, a, phi, omega, d = 1.5, 0.25, 0.6, 12.0, 0.2
    assert rp.textbook_bearing_force(m, a, phi, omega, d) == pytest.approx(rp.bearing_force(m, a, 0.0, phi, omega, d), rel=1e-14)
    I = rp.principal_moments(m, a)
    assert I == pytest.approx([m * a * a / 12, m * a * a / 3, 5 * m * a * a / 12], rel=1e-14)
