"""Scene runs against their closed-form references (``references/``).

``exact_error(scene, engine, traj, settings)`` returns ``(error, unit, detail)``:

* torque_free: max over samples of |w_B(t) - w_B_exact(t)| / |omega0|, body-frame angular
  velocity against the Jacobi-elliptic solution of Euler's equations.
* heavy_top: max |cos theta(t) - u_exact(t)| (dimensionless), the nutation, where
  cos theta = e3 . z is the vertical component of the symmetry axis.
* double_pendulum: max relative error of the two small-oscillation frequencies. The engine is
  run again from each mode shape at 1e-3 rad (rest, no force), and the frequency is measured
  from the zero crossings of the upper bar's angle.
* plate_pendulum: max |phi(t) - phi_exact(t)| (rad), the angle of the centre of mass from the
  downward vertical through the pivot against the Jacobi-elliptic closed form
  (``references.plate_pendulum``); the detail gives the largest angular velocity (Ex. 4.5.1).
"""

from __future__ import annotations

import numpy as np

from harness import rotations
from harness.engines.base import RunSettings
from harness.scene import Scene
from harness.trajectory import Trajectory

MODAL_AMPLITUDE = 1e-3  # rad
MODAL_PERIODS = 8       # periods of the slow mode measured


def exact_error(scene: Scene, engine: str, traj: Trajectory, settings: RunSettings) -> tuple[float, str, str]:
    """Error of ``traj`` against the scene's exact solution (see module docstring)."""
    handler = _HANDLERS.get(scene.name)
    if handler is None:
        raise ValueError(f"no exact solution for scene {scene.name!r}")
    return handler(scene, engine, traj, settings)


def _torque_free(scene, engine, traj, settings):
    from references.torque_free import omega_body

    p = scene.params
    R = rotations.matrix(traj.quat_WB[:, 0])
    w_B = np.einsum("tji,tj->ti", R, traj.w_WB_W[:, 0])
    exact = omega_body(traj.t, (p["I1"], p["I2"], p["I3"]), p["omega0"])
    err = float(np.max(np.abs(w_B - exact)))
    scale = float(np.linalg.norm(p["omega0"])) or 1.0
    return err / scale, "rel", f"body-frame angular velocity vs Jacobi elliptic solution: {err:.2e} rad/s over |omega0|"


def _heavy_top(scene, engine, traj, settings):
    from references.heavy_top import cos_theta, nutation_bounds

    p = scene.params
    model = scene.multibody()
    R0 = rotations.matrix(model.q0["top"])
    params = {k: p[k] for k in ("mass", "l", "I1", "I3", "g")}
    R = rotations.matrix(traj.quat_WB[:, 0])
    u = R[:, 2, 2]
    exact = cos_theta(traj.t, params, R0, p["omega0"])
    lo, hi = nutation_bounds(params, R0, p["omega0"])
    return (float(np.max(np.abs(u - exact))), "",
            f"cos(theta) vs elliptic solution; nutation between {np.degrees(lo):.3f} and {np.degrees(hi):.3f} deg")


def _double_pendulum(scene, engine, traj, settings):
    from harness.engines import get_engine
    from harness.systems.double_pendulum import bar_inertia
    from references.double_pendulum import modes

    p = scene.params
    I_c = bar_inertia(p["m"], p["L"], p["r"])[0, 0]
    omegas, vectors = modes(p["m"], p["L"], I_c, p["g"])
    errors, measured = [], []
    for k in range(2):
        u = vectors[:, k] / np.max(np.abs(vectors[:, k])) * MODAL_AMPLITUDE
        modal = scene.with_params(theta0=u[0], phi0=u[1], dtheta0=0.0, dphi0=0.0, F0=0.0)
        t_end = MODAL_PERIODS * 2 * np.pi / omegas[0]
        save = settings.dt * max(1, int(round(0.02 * (2 * np.pi / omegas[1]) / settings.dt)))
        n_saves = int(np.ceil(t_end / save))
        run = get_engine(engine).simulate(modal, RunSettings(n_saves * save, settings.dt, save, settings.integrator,
                                                             settings.rtol, settings.atol))
        if not run.ok:
            raise RuntimeError(f"modal run {k + 1} {run.status}: {run.message}")
        # upper bar angle from the vertical, signed toward +x
        r = run.p_WCm_W[:, 0]
        theta = np.arctan2(r[:, 0], -r[:, 2])
        w = _frequency_from_zero_crossings(run.t, theta)
        measured.append(w)
        errors.append(abs(w - omegas[k]) / omegas[k])
    detail = (f"omega = {measured[0]:.6f}, {measured[1]:.6f} rad/s measured; exact {omegas[0]:.6f}, {omegas[1]:.6f} "
              f"= {omegas[0] / np.sqrt(p['g'] / p['L']):.4f}, {omegas[1] / np.sqrt(p['g'] / p['L']):.4f} sqrt(g/L)")
    return float(max(errors)), "rel", detail


def _plate_pendulum(scene, engine, traj, settings):
    from references.plate_pendulum import largest_angular_velocity, pendulum_motion, natural_frequency

    p = scene.params
    phi0 = float(np.arctan2(p["a"], p["b"])) + p["theta0"]
    r = traj.p_WCm_W[:, 0]
    phi = np.unwrap(np.arctan2(r[:, 0], -r[:, 2]))
    phi += 2.0 * np.pi * np.round((phi0 - phi[0]) / (2.0 * np.pi))
    exact, _, _ = pendulum_motion(traj.t, natural_frequency(p["a"], p["b"], p["g"]), phi0, p["dtheta0"])
    w_max = largest_angular_velocity(p["a"], p["b"], p["g"], phi0, p["dtheta0"])
    w_seen = float(np.max(np.linalg.norm(traj.w_WB_W[:, 0], axis=-1)))
    return (float(np.max(np.abs(phi - exact))), "rad",
            f"angle of the centre of mass vs elliptic solution; largest angular velocity {w_max:.6f} rad/s exact "
            f"(Ex. 4.5.1), {w_seen:.6f} rad/s largest sample")


def _frequency_from_zero_crossings(t: np.ndarray, x: np.ndarray) -> float:
    """Angular frequency (rad/s) of a near-harmonic signal from its first and last zero
    crossings (linear interpolation; the signal's curvature vanishes at a crossing)."""
    s = np.sign(x)
    idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
    if len(idx) < 3:
        raise RuntimeError("too few zero crossings to measure a frequency")
    tc = t[idx] - x[idx] * (t[idx + 1] - t[idx]) / (x[idx + 1] - x[idx])
    half_periods = len(tc) - 1
    return float(np.pi * half_periods / (tc[-1] - tc[0]))


_HANDLERS = {"torque_free": _torque_free, "heavy_top": _heavy_top, "double_pendulum": _double_pendulum,
             "plate_pendulum": _plate_pendulum}
