"""Scene runs against their closed-form references (``references/``).

``exact_error(scene, engine, traj, settings)`` returns ``(error, unit, detail)``:

* torque_free: max over samples of |w_B(t) - w_B_exact(t)| / |omega0|, body-frame angular
  velocity against the Jacobi-elliptic solution of Euler's equations.
* heavy_top: max |cos theta(t) - u_exact(t)| (dimensionless), the nutation, where
  cos theta = e3 . z is the vertical component of the symmetry axis.
* double_pendulum: max relative error of the two small-oscillation frequencies. The engine is
  run again from each mode shape at 1e-3 rad (rest, no force), and the frequency is measured
  from the zero crossings of the upper bar's angle. With a force (F0 != 0) a third run from rest,
  with the force scaled to a 1e-3 rad response at the scene's omega_f, is compared with the
  exact linear response (Ex. 6.2.1, ``harness.references.double_pendulum.linear_response``), relative
  to that peak.
* plate_pendulum: max |phi(t) - phi_exact(t)| (rad), the angle of the centre of mass from the
  downward vertical through the pivot against the Jacobi-elliptic closed form
  (``harness.references.plate_pendulum``); the detail gives the largest angular velocity (Ex. 4.5.1).
* cart_pendulum: the largest of three relative errors: (1) the square of the cart velocity
  relative to the centre-of-mass drift, (Xdot - P/S)^2, at every sample against its exact value
  at the run's own pendulum angle from the conservation of energy and horizontal momentum
  (``harness.references.cart_pendulum.relative_speed_squared``; at the vertical this is Ex. 1.6.1),
  over the squared velocity scale (squared because the speed is ill-conditioned where it
  vanishes); (2) the period of the run's pendulum (zero crossings of
  theta) against the exact period (Gauss-Legendre quadrature); (3) the small-oscillation
  frequency (Ex. 1.5.1), measured on a second run of 2 periods from rest at theta = 1e-3 rad (the exact
  period at that amplitude is the reference, so no amplitude bias enters).
* spring_pendulum: the largest of two relative errors, each on a run of its own from the scene's
  parameters: (1) the purely radial motion (theta = 0, r0 = 1.1 r*, 1.2 periods), exact at any
  amplitude: max |r(t) - r_exact(t)| over the amplitude; (2) the swing frequency measured on a
  run from rest at theta = 1e-4 rad, r = r* (1.6 periods, Hermite zero crossings) against
  omega2 = sqrt(m g r* / (m r*^2 + J)). The detail adds the spring and swing frequencies (Ex. 5.3.1) and how much of the
  scene run's energy reached the swing mode (the 2:1 internal resonance).
* rotating_plate: max geodesic angle (rad) between the run's orientation and the exact uniform
  rotation R_z(omega t) about the fixed axis (the rate stays constant: no moment about the axis).
"""

from __future__ import annotations

import numpy as np

from harness.model import rotations
from harness.engines.base import RunSettings
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory

MODAL_AMPLITUDE = 1e-3  # rad
MODAL_PERIODS = 8       # periods of the slow mode measured
FORCED_AMPLITUDE = 1e-3  # rad, peak of double_pendulum's small-amplitude forced run
SWING_AMPLITUDE = 1e-4  # rad, spring_pendulum's swing run: amplitude shift ~ theta^2/16 ~ 6e-10


def exact_error(scene: Scene, engine: str, traj: Trajectory, settings: RunSettings) -> tuple[float, str, str]:
    """Error of ``traj`` against the scene's exact solution (see module docstring)."""
    handler = _HANDLERS.get(scene.name)
    if handler is None:
        raise ValueError(f"no exact solution for scene {scene.name!r}")
    return handler(scene, engine, traj, settings)


def exact_reaction(scene: Scene, traj: Trajectory) -> tuple[float, str] | None:
    """Max over samples of |F(t) - F_exact(t)| (N) of the joint reaction force against the
    scene's exact support force, and a detail line; None when the scene has none.

    * plate_pendulum: the pivot force m a_cm + m g z of the elliptic solution
      (``harness.references.plate_pendulum.support_force``); the detail adds the largest reaction
      moment (exact: zero) and the textbook's instant of Ex. 4.5.2.
    * heavy_top: the tip force m a_cm + m g z in the cylindrical components of the run's own
      symmetry axis (``harness.references.heavy_top.tip_force``).
    * rotating_plate: the larger of the force error and the couple error over 2d (the bearing
      forces' error): force m g z, couple -omega^2 sin(phi) cos(phi) (I_z - I_x) along the
      plate's turning y axis (``harness.references.rotating_plate``; Ex. 4.6.1).
    """
    handler = _REACTION_HANDLERS.get(scene.name)
    if handler is None or not traj.reactions:
        return None
    return handler(scene, traj)


def _plate_pendulum_reaction(scene, traj):
    from harness.references.plate_pendulum import support_force, support_force_at_largest_velocity

    p = scene.params
    phi0 = float(np.arctan2(p["a"], p["b"])) + p["theta0"]
    force, moment = traj.reactions["plate"]
    exact = support_force(traj.t, p["m"], p["a"], p["b"], p["g"], phi0, p["dtheta0"])
    err = float(np.max(np.linalg.norm(force - exact, axis=-1)))
    at_bottom = support_force_at_largest_velocity(p["m"], p["a"], p["b"], p["g"], phi0, p["dtheta0"])
    return err, (f"pivot force vs m a_cm + m g of the elliptic solution; largest moment {np.max(np.linalg.norm(moment, axis=-1)):.1e} N m "
                 f"(exact 0); at the bottom F_z = {at_bottom[2]:.6f} N (Ex. 4.5.2)")


def _rotating_plate_reaction(scene, traj):
    from harness.references import rotating_plate as rp

    p = scene.params
    force, moment = traj.reactions["plate"]
    c, s = np.cos(p["omega"] * traj.t), np.sin(p["omega"] * traj.t)
    y_W = np.stack([-s, c, np.zeros_like(c)], axis=1)  # the plate's y axis turns about z
    M_exact = rp.couple(p["m"], p["a"], p["h"], p["phi"], p["omega"]) * y_W
    F_exact = np.array([0.0, 0.0, p["m"] * p["g"]])
    err_f = float(np.max(np.linalg.norm(force - F_exact, axis=-1)))
    err_m = float(np.max(np.linalg.norm(moment - M_exact, axis=-1)))
    F_run = float(np.max(np.linalg.norm(moment, axis=-1))) / (2.0 * p["d"])
    return max(err_f, err_m / (2.0 * p["d"])), (
        f"force vs m g z, couple/(2d) vs the exact bearing forces; bearing force {F_run:.9f} N in the run, "
        f"{rp.bearing_force(p['m'], p['a'], p['h'], p['phi'], p['omega'], p['d']):.9f} N exact, "
        f"{rp.textbook_bearing_force(p['m'], p['a'], p['phi'], p['omega'], p['d']):.9f} N Ex. 4.6.1 (thin plate)")


def _heavy_top_reaction(scene, traj):
    from harness.references.heavy_top import tip_force

    p = scene.params
    model = scene.multibody()
    R0 = rotations.matrix(model.q0["top"])
    params = {k: p[k] for k in ("mass", "l", "I1", "I3", "g")}
    exact = tip_force(traj.t, params, R0, p["omega0"])
    e3 = rotations.matrix(traj.quat_WB[:, 0])[:, :, 2]
    h = np.hypot(e3[:, 0], e3[:, 1])
    e_rho = np.stack([e3[:, 0] / h, e3[:, 1] / h, np.zeros_like(h)], axis=1)
    e_phi = np.stack([-e_rho[:, 1], e_rho[:, 0], np.zeros_like(h)], axis=1)
    exact_W = exact[:, :1] * e_rho + exact[:, 1:2] * e_phi + exact[:, 2:3] * np.array([0.0, 0.0, 1.0])
    force = traj.reactions["top"][0]
    ok = h > 1e-6  # the horizontal components need the axis off the vertical
    err_h = float(np.max(np.linalg.norm(force[ok] - exact_W[ok], axis=-1), initial=0.0))
    err_z = float(np.max(np.abs(force[:, 2] - exact[:, 2])))
    return max(err_h, err_z), "tip force vs m a_cm + m g from the elliptic u(t) (cylindrical components about the run's own axis)"


def _torque_free(scene, engine, traj, settings):
    from harness.references.torque_free import omega_body

    p = scene.params
    R = rotations.matrix(traj.quat_WB[:, 0])
    w_B = np.einsum("tji,tj->ti", R, traj.w_WB_W[:, 0])
    exact = omega_body(traj.t, (p["I1"], p["I2"], p["I3"]), p["omega0"])
    err = float(np.max(np.abs(w_B - exact)))
    scale = float(np.linalg.norm(p["omega0"])) or 1.0
    return err / scale, "rel", f"body-frame angular velocity vs Jacobi elliptic solution: {err:.2e} rad/s over |omega0|"


def _heavy_top(scene, engine, traj, settings):
    from harness.references.heavy_top import cos_theta, nutation_bounds

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
    from harness.model.builders.double_pendulum import bar_inertia
    from harness.references.double_pendulum import modes

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
    if p["F0"] != 0.0:
        err, note = _double_pendulum_forced(scene, engine, settings, I_c, omegas)
        errors.append(err)
        detail += "; " + note
    return float(max(errors)), "rel", detail


def _bar_angles(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Absolute angles (theta, phi) of the two bars from the downward vertical, toward +x, from
    the bars' orientations (each bar hangs along its body -z)."""
    out = []
    for i in range(2):
        d = -rotations.matrix(traj.quat_WB[:, i])[:, :, 2]
        out.append(np.arctan2(d[:, 0], -d[:, 2]))
    return out[0], out[1]


def _double_pendulum_forced(scene, engine, settings, I_c, omegas):
    """Small-amplitude forced response (Ex. 6.2.1, from rest) against the exact linear response
    ``harness.references.double_pendulum.linear_response`` at the scene's forcing frequency: the force
    is scaled so that the exact response peaks at FORCED_AMPLITUDE rad over two slow periods;
    error = max |(theta, phi) - exact| over that peak (nonlinear terms ~ amplitude^2)."""
    from harness.engines import get_engine
    from harness.references.double_pendulum import linear_response

    p = scene.params
    t_end = 2.0 * 2.0 * np.pi / omegas[0]
    save = settings.dt * max(1, int(round(0.01 * (2 * np.pi / omegas[1]) / settings.dt)))
    n_saves = int(np.ceil(t_end / save))
    t = np.arange(n_saves + 1) * save
    unit = np.abs(np.array(linear_response(t, p["m"], p["L"], I_c, p["g"], 0.0, 0.0, 0.0, 0.0, 1.0, p["omega_f"]))).max()
    F_small = FORCED_AMPLITUDE / unit
    forced = scene.with_params(theta0=0.0, phi0=0.0, dtheta0=0.0, dphi0=0.0, F0=F_small)
    run = get_engine(engine).simulate(forced, RunSettings(n_saves * save, settings.dt, save, settings.integrator,
                                                          settings.rtol, settings.atol))
    if not run.ok:
        raise RuntimeError(f"forced run {run.status}: {run.message}")
    theta, phi = _bar_angles(run)
    ex_theta, ex_phi = linear_response(run.t, p["m"], p["L"], I_c, p["g"], 0.0, 0.0, 0.0, 0.0, F_small, p["omega_f"])
    err = float(max(np.max(np.abs(theta - ex_theta)), np.max(np.abs(phi - ex_phi)))) / FORCED_AMPLITUDE
    return err, (f"forced from rest at omega_f = {p['omega_f']:g} rad/s with F0 = {F_small:.3e} N (peak {FORCED_AMPLITUDE:g} rad) "
                 f"vs the exact linear response (Ex. 6.2.1): {err:.1e} of the peak")


def _plate_pendulum(scene, engine, traj, settings):
    from harness.references.plate_pendulum import largest_angular_velocity, pendulum_motion, natural_frequency

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


def _cart_pendulum_angles(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Pendulum angle from the downward vertical (toward +x) and its rate, from maximal
    coordinates: the pivot is the cart's frame origin (its centre of mass); the rate is the
    pendulum's angular velocity about the hinge axis -y."""
    cart, bob = traj.p_WCm_W[:, 0], traj.p_WCm_W[:, 1]
    theta = np.unwrap(np.arctan2(bob[:, 0] - cart[:, 0], cart[:, 2] - bob[:, 2]))
    return theta, -traj.w_WB_W[:, 1, 1]


def _cart_pendulum(scene, engine, traj, settings):
    from harness.engines import get_engine
    from harness.references import cart_pendulum as cp

    p = scene.params
    M, m, L, g = p["M"], p["m"], p["L"], p["g"]
    I_c = 0.4 * m * p["r"] ** 2
    theta, dtheta = _cart_pendulum_angles(traj)
    P = cp.momentum(M, m, L, p["theta0"], p["dX0"], p["dtheta0"])
    E = cp.relative_energy(M, m, L, I_c, g, p["theta0"], p["dX0"], p["dtheta0"])
    w = traj.v_WCm_W[:, 0, 0] - P / (M + m)  # cart velocity relative to the centre-of-mass drift
    v_scale = max(float(np.max(np.abs(traj.v_WCm_W))), 1e-300)
    # compared squared: w itself is ill-conditioned at the turning points (w -> 0)
    err_speed = float(np.max(np.abs(w * w - cp.relative_speed_squared(theta, M, m, L, I_c, g, E)))) / v_scale**2
    T = cp.period(M, m, L, I_c, g, p["theta0"], p["dX0"], p["dtheta0"])
    w_run = _frequency_from_hermite_crossings(traj.t, theta, dtheta)
    err_period = abs(w_run * T / (2.0 * np.pi) - 1.0)
    # small oscillations: a second run from rest at MODAL_AMPLITUDE
    T_small = cp.period(M, m, L, I_c, g, MODAL_AMPLITUDE)
    modal = scene.with_params(theta0=MODAL_AMPLITUDE, dtheta0=0.0, dX0=0.0)
    save = settings.dt * max(1, int(round(0.02 * T_small / settings.dt)))
    n_saves = int(np.ceil(2 * T_small / save))  # 2 periods from a turning point: 4 zero crossings
    run = get_engine(engine).simulate(modal, RunSettings(n_saves * save, settings.dt, save, settings.integrator,
                                                         settings.rtol, settings.atol))
    if not run.ok:
        raise RuntimeError(f"small-oscillation run {run.status}: {run.message}")
    w_small = _frequency_from_hermite_crossings(run.t, *_cart_pendulum_angles(run))
    err_small = abs(w_small * T_small / (2.0 * np.pi) - 1.0)
    w_lin = cp.small_oscillation_frequency(M, m, L, I_c, g)
    at_vertical = cp.cart_speed_at_vertical(M, m, L, I_c, g, p["theta0"], p["dX0"], p["dtheta0"])
    detail = (f"(cart velocity)^2 vs energy+momentum closed form {err_speed:.1e} (|Xdot - P/S| at the vertical "
              f"{at_vertical:.6f} m/s, Ex. 1.6.1); period {2 * np.pi / w_run:.6f} s vs exact {T:.6f} s ({err_period:.1e}); "
              f"small-oscillation omega {w_small:.6f} rad/s vs exact {2 * np.pi / T_small:.6f} ({err_small:.1e}; "
              f"linearised {w_lin:.6f}, Ex. 1.5.1)")
    return max(err_speed, err_period, err_small), "rel", detail


def _rolling_disk(scene, engine, traj, settings):
    """Steady circular motion (Ex. 4.7.2): max |theta(t) - theta0| (rad), theta the angle of the
    symmetry axis from the vertical; the detail adds the centre's distance from the exact circle.
    NaN unless the scene's initial state is a steady motion (dpsi0 = the steady spin)."""
    from harness.references.rolling_disk import DiskParams, frame, steady_motion

    p = scene.params
    disk = DiskParams(p["mass"], p["R"], p["h"], p["g"])
    theta0, dphi0 = p["theta0"], p["dphi0"]
    if dphi0 == 0.0 or p["dtheta0"] != 0.0:
        return float("nan"), "rad", "no closed form: the initial state is not a steady circular motion (needs dphi0 != 0, dtheta0 = 0)"
    steady = steady_motion(disk, theta0, dphi0)
    if abs(p["dpsi0"] - steady["dpsi"]) > 1e-9 * max(1.0, abs(steady["dpsi"])):
        return float("nan"), "rad", (f"no closed form: dpsi0 = {p['dpsi0']:.10g} rad/s is not the steady spin "
                                     f"{steady['dpsi']:.15g} rad/s for theta0 = {theta0:g}, dphi0 = {dphi0:g}")
    R = rotations.matrix(traj.quat_WB[:, 0])
    theta = np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0))
    # circle centre: A0 - (v_y'/dphi) e_h at t = 0, e_h the horizontal of e_x' (phi0 = 0)
    e = frame(theta0, 0.0)
    vy = float(traj.v_WCm_W[0, 0] @ e[:, 1])
    centre = traj.p_WCm_W[0, 0, :2] - (vy / dphi0) * np.array([1.0, 0.0])
    radius = np.linalg.norm(traj.p_WCm_W[:, 0, :2] - centre, axis=-1)
    return (float(np.max(np.abs(theta - theta0))), "rad",
            f"lean (axis from vertical) vs constant theta0 = {theta0:g} rad; centre's circle radius "
            f"{steady['radius']:.6g} m exact, max deviation {np.max(np.abs(radius - steady['radius'])):.2e} m; "
            f"speed {steady['speed']:.6g} m/s")


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


def _spring_pendulum_polar(traj: Trajectory, model) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(r, theta, r', theta') of the bob from maximal coordinates: r the slide coordinate,
    theta the angle of the bob from the downward vertical (toward +x), rates from the bob's
    velocity and the hub's angular velocity about -y."""
    from harness.measure.invariants import slide_coordinate

    r = slide_coordinate(traj, model, "bob")
    p, v = traj.p_WCm_W[:, 1], traj.v_WCm_W[:, 1]
    theta = np.unwrap(np.arctan2(p[:, 0], -p[:, 2]))
    e_r = p / np.linalg.norm(p, axis=-1, keepdims=True)
    return r, theta, np.einsum("ti,ti->t", v, e_r), -traj.w_WB_W[:, 0, 1]


def _spring_pendulum(scene, engine, traj, settings):
    from harness.engines import get_engine
    from harness.model.builders.spring_pendulum import swing_inertia
    from harness.references import spring_pendulum as sp

    p = scene.params
    m, k, L, g = p["m"], p["k"], p["L"], p["g"]
    J = swing_inertia(p)
    w1, w2 = sp.frequencies(m, k, L, g, J)
    rs = sp.equilibrium_length(m, k, L, g)

    def run(periods, omega, **start):
        T = 2.0 * np.pi / omega
        save = settings.dt * max(1, int(round(0.02 * T / settings.dt)))
        n_saves = int(np.ceil(periods * T / save))
        case = scene.with_params(dr0=0.0, dtheta0=0.0, **start)
        out = get_engine(engine).simulate(case, RunSettings(n_saves * save, settings.dt, save, settings.integrator,
                                                            settings.rtol, settings.atol))
        if not out.ok:
            raise RuntimeError(f"modal run {out.status}: {out.message}")
        return out, case.multibody()

    amp = 0.1 * rs
    radial, model = run(1.2, w1, theta0=0.0, r0=rs + amp)
    r = _spring_pendulum_polar(radial, model)[0]
    err_radial = float(np.max(np.abs(r - sp.radial_motion(radial.t, m, k, L, g, rs + amp)[0]))) / amp
    swing, model = run(1.6, w2, theta0=SWING_AMPLITUDE, r0=rs)  # 1.6 periods: 3 zero crossings
    _, theta, _, dtheta = _spring_pendulum_polar(swing, model)
    w_swing = _frequency_from_hermite_crossings(swing.t, theta, dtheta)
    err_swing = abs(w_swing / w2 - 1.0)
    r, theta, dr, dtheta = _spring_pendulum_polar(traj, scene.multibody())
    E_r, E_t = sp.mode_energies(r, theta, dr, dtheta, m, k, L, g, J)
    share = E_t / (E_r + E_t)
    detail = (f"radial mode vs exact {err_radial:.1e} of its amplitude; swing omega {w_swing:.6f} rad/s vs exact {w2:.6f} "
              f"({err_swing:.1e}); spring omega1 = {w1:.6f} rad/s, ratio {w1 / w2:.6f}; textbook sqrt(g/r*) = "
              f"{np.sqrt(g / rs):.6f} (Ex. 5.3.1, J = 0); swing share of the modal energy {share[0]:.3f} at t = 0, "
              f"max {share.max():.3f} at t = {traj.t[int(np.argmax(share))]:.2f} s")
    return max(err_radial, err_swing), "rel", detail


def _rotating_plate(scene, engine, traj, settings):
    p = scene.params
    exact = np.stack([rotations.from_axis_angle(np.array([0.0, 0.0, 1.0]), p["omega"] * t) for t in traj.t])
    err = float(np.max(rotations.geodesic_angle(traj.quat_WB[:, 0], exact)))
    dw = float(np.max(np.linalg.norm(traj.w_WB_W[:, 0] - np.array([0.0, 0.0, p["omega"]]), axis=-1)))
    return err, "rad", f"orientation vs uniform rotation about the axis; |w - omega z| <= {dw:.1e} rad/s"


def _frequency_from_hermite_crossings(t: np.ndarray, x: np.ndarray, dx: np.ndarray) -> float:
    """Angular frequency (rad/s) of an oscillation from its first and last zero crossings, each
    located on the cubic Hermite interpolant of the samples and their derivatives ``dx``
    (error ~ h^4 x^(4) instead of the h^2 x" of a chord, so the save interval need not be small)."""
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



def _torque_free_symmetric(scene, engine, traj, settings):
    from harness.references.torque_free import cone_angles, omega_body

    p = scene.params
    I1, I3 = p["I1"], p["I3"]
    model = scene.multibody()
    R = rotations.matrix(traj.quat_WB[:, 0])
    w_W = traj.w_WB_W[:, 0]
    w_B = np.einsum("tji,tj->ti", R, w_W)
    w0 = np.asarray(p["omega0"], dtype=float)
    scale = float(np.linalg.norm(w0)) or 1.0
    w_err = float(np.max(np.abs(w_B - omega_body(traj.t, (I1, I1, I3), w0)))) / scale
    # cones: angle of w from the symmetry axis (body) and from L (space); w3 < 0 mirrors them
    sign = 1.0 if w0[2] >= 0 else -1.0
    alpha_b, _, alpha_s = cone_angles(I1, I3, float(np.hypot(w0[0], w0[1])), abs(w0[2]))
    body = np.arctan2(np.hypot(w_B[:, 0], w_B[:, 1]), sign * w_B[:, 2])
    L_W = (R @ model.bodies[0].I_Cm_B @ w_B[..., None])[..., 0]
    space = np.arctan2(np.linalg.norm(np.cross(w_W, L_W), axis=1), np.einsum("ti,ti->t", w_W, L_W))
    cone_err = float(max(np.max(np.abs(body - alpha_b)), np.max(np.abs(space - alpha_s))))
    rate = (I3 - I1) / I1 * w0[2]
    return (max(w_err, cone_err), "",
            f"w_B vs closed form {w_err:.1e} (rel); cones alpha_b = {alpha_b:.6f}, alpha_s = {alpha_s:.6f} rad held to "
            f"{cone_err:.1e} rad; w_perp turns at gamma w3 = {rate:.6f} rad/s")


_HANDLERS = {"torque_free_symmetric": _torque_free_symmetric, "rolling_disk": _rolling_disk, "torque_free": _torque_free, "heavy_top": _heavy_top, "double_pendulum": _double_pendulum,
             "plate_pendulum": _plate_pendulum, "cart_pendulum": _cart_pendulum, "spring_pendulum": _spring_pendulum,
             "rotating_plate": _rotating_plate}
_REACTION_HANDLERS = {"plate_pendulum": _plate_pendulum_reaction, "heavy_top": _heavy_top_reaction,
                      "rotating_plate": _rotating_plate_reaction}
