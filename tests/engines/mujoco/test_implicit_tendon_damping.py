"""MuJoCo's implicit integrators and a tendon damper between two branches of the tree: the measured
behaviour behind the flyball governor's choice of RK4 for MuJoCo (models/flyball_governor/README.md).

Each of the governor's spring-dampers is a spatial tendon from the slider to a rod, two sibling
branches of the shaft. One ``implicit`` step of MuJoCo equals the implicit-Euler velocity update
``v + h (M - h D')^-1 f`` where D' is the tendons' damping derivative ``-c J^T J`` without its
entries between the slider's and the rods' degrees of freedom (MuJoCo adds it into ``qDeriv``,
which has the mass matrix's sparsity), not the update with the full derivative; over 1 s its
error grows with the damping, which Euler's does not."""

import mujoco
import numpy as np

from harness.engines import get_engine, load_scene
from harness.engines.base import RunSettings
from harness.engines.mujoco.model import load_mjcf

H = 1e-4


def _smooth(m, qpos, qvel):
    """``(f, M, ten_length)``: the smooth force qfrc_passive - qfrc_bias (no actuators), the dense mass
    matrix and the tendon lengths at (qpos, qvel)."""
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return d.qfrc_passive - d.qfrc_bias, M, d.ten_length.copy()


def test_one_implicit_step_drops_the_dampers_cross_branch_derivative():
    scene = load_scene("flyball_governor")
    m = load_mjcf(scene.mjcf, scene.multibody(), dt=H, integrator="implicit")
    qpos, qvel = np.array([0.1, 0.5, 0.55, 0.52]), np.array([6.283185307179586, -0.2, 0.1, 0.3])  # shaft, rods, slider
    f, M, _ = _smooth(m, qpos, qvel)
    J = np.zeros((m.ntendon, m.nv))  # tendon Jacobian by central differences of the lengths (hinges, a slide)
    for j in range(m.nv):
        e = np.eye(m.nv)[j] * 1e-7
        J[:, j] = (_smooth(m, qpos + e, qvel)[2] - _smooth(m, qpos - e, qvel)[2]) / 2e-7
    assert np.all(np.abs(J[:, 0]) < 1e-8) and np.all(np.abs(J[:, 3]) > 0.1)  # the shaft stretches neither, the slider both
    D = np.zeros((m.nv, m.nv))  # the whole derivative df/dqvel (dampers, Coriolis and centrifugal terms), numerically
    for j in range(m.nv):
        e = np.eye(m.nv)[j] * 1e-6
        D[:, j] = (_smooth(m, qpos, qvel + e)[0] - _smooth(m, qpos, qvel - e)[0]) / 2e-6
    dampers = -sum(m.tendon_damping[t] * np.outer(J[t], J[t]) for t in range(m.ntendon))
    cross = dampers - np.diag(np.diag(dampers))  # slider and rods are siblings: their pairs are cross-branch
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_step(m, d)
    pruned = qvel + H * np.linalg.solve(M - H * (D - cross), f)
    full = qvel + H * np.linalg.solve(M - H * D, f)
    assert np.max(np.abs(d.qvel - pruned)) < 1e-7  # measured 1.2e-10
    assert np.max(np.abs(d.qvel - full)) > 1e-2  # measured 3e-2 rad/s


def test_its_error_grows_with_the_damping():
    """Slider height after 1 s at h = 1e-4 s against RK4 at 2.5e-5 s: implicit 5.9e-5, 1.1e-3, 1.7e-2 m
    for c = 0, 4e3, 4e4 N s/m (Euler 7.5e-5, 7.4e-5, 7.4e-5 m)."""
    errors = {}
    for c in (0.0, 4e4):
        scene = load_scene("flyball_governor", {"c": c})
        ref = get_engine("mujoco").simulate(scene, RunSettings(1.0, 2.5e-5, 0.5, "RK4"))
        i = ref.body_names.index("slider")
        for method in ("implicit", "Euler"):
            tr = get_engine("mujoco").simulate(scene, RunSettings(1.0, H, 0.5, method))
            errors[c, method] = abs(tr.p_WCm_W[-1, i, 2] - ref.p_WCm_W[-1, i, 2])
    assert errors[0.0, "implicit"] < 1e-4 and errors[4e4, "implicit"] > 1e-2
    assert errors[0.0, "Euler"] < 1e-4 and errors[4e4, "Euler"] < 1e-4
