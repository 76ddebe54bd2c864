"""Measurements on sampled signals: the frequency of an oscillation from its zero crossings.

Generic helpers of the exact checks (``references/<scene>.py``): they know nothing of scenes.
"""

from __future__ import annotations

import numpy as np


def frequency_from_zero_crossings(t: np.ndarray, x: np.ndarray) -> float:
    """Angular frequency (rad/s) of a near-harmonic signal from its first and last zero
    crossings (linear interpolation; the signal's curvature vanishes at a crossing).

    Raises RuntimeError with fewer than three crossings.
    """
    s = np.sign(x)
    idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
    if len(idx) < 3:
        raise RuntimeError("too few zero crossings to measure a frequency")
    tc = t[idx] - x[idx] * (t[idx + 1] - t[idx]) / (x[idx + 1] - x[idx])
    half_periods = len(tc) - 1
    return float(np.pi * half_periods / (tc[-1] - tc[0]))


def frequency_from_hermite_crossings(t: np.ndarray, x: np.ndarray, dx: np.ndarray) -> float:
    """Angular frequency (rad/s) of an oscillation from its first and last zero crossings, each
    located on the cubic Hermite interpolant of the samples and their derivatives ``dx``
    (error ~ h^4 x^(4) instead of the h^2 x" of a chord, so the save interval need not be small).

    Raises RuntimeError with fewer than three crossings.
    """
    s = np.sign(x)
    idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
    if len(idx) < 3:
        raise RuntimeError("too few zero crossings to measure a frequency")
    tc = []
    for k in idx:
        h = t[k + 1] - t[k]
        x1, x2, d1, d2 = x[k], x[k + 1], h * dx[k], h * dx[k + 1]
        tau = x1 / (x1 - x2)
        for _ in range(8):  # Newton on p(tau) = 0, started at the chord's root
            t2, t3 = tau * tau, tau * tau * tau
            p = (2 * t3 - 3 * t2 + 1) * x1 + (t3 - 2 * t2 + tau) * d1 + (-2 * t3 + 3 * t2) * x2 + (t3 - t2) * d2
            dp = (6 * t2 - 6 * tau) * x1 + (3 * t2 - 4 * tau + 1) * d1 + (-6 * t2 + 6 * tau) * x2 + (3 * t2 - 2 * tau) * d2
            tau = min(max(tau - p / dp, 0.0), 1.0)
        tc.append(t[k] + tau * h)
    return float(np.pi * (len(tc) - 1) / (tc[-1] - tc[0]))
