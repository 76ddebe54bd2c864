"""RKMK4 on Pinocchio's configuration group: fourth order, and equal to MuJoCo's RK4."""

import numpy as np
import pytest

from harness.model import rotations
from harness.engines.base import RunSettings
from harness.engines.mujoco.engine import ENGINE as MUJOCO
from harness.engines.pinocchio.engine import ENGINE as PINOCCHIO
from harness.engines import load_scene


def _final_orientation(scene, dt, integrator="rkmk4"):
    tr = PINOCCHIO.simulate(scene, RunSettings(1.0, dt, 1.0, integrator))
    return tr.quat_WB[-1, 0], tr.w_WB_W[-1, 0]


def test_rkmk4_is_fourth_order_in_orientation():
    scene = load_scene("torque_free", {"omega0": "3,1,2"})
    q_ref, w_ref = _final_orientation(scene, 1e-3)
    errs = []
    for dt in (0.04, 0.02):
        q, w = _final_orientation(scene, dt)
        errs.append(rotations.geodesic_angle(q, q_ref))
    order = np.log2(errs[0] / errs[1])
    assert 3.7 < order < 4.3, order


def test_semi_implicit_euler_is_first_order():
    scene = load_scene("heavy_top")
    ref = PINOCCHIO.simulate(scene, RunSettings(0.2, 1e-4, 0.2, "rkmk4"))
    errs = []
    for dt in (2e-3, 1e-3):
        tr = PINOCCHIO.simulate(scene, RunSettings(0.2, dt, 0.2, "euler"))
        errs.append(rotations.geodesic_angle(tr.quat_WB[-1, 0], ref.quat_WB[-1, 0]))
    assert 0.8 < np.log2(errs[0] / errs[1]) < 1.2


@pytest.mark.parametrize("name,overrides", [
    ("torque_free", {}), ("heavy_top", {}), ("double_pendulum", {}),
    ("double_pendulum", {"F0": 2.0, "omega_f": 3.0}),
])
def test_pinocchio_rkmk4_matches_mujoco_rk4(name, overrides):
    """Both are RK4 with the Lie-group stage map: they agree to round-off, not to dt^4."""
    scene = load_scene(name, overrides)
    s = RunSettings(1.0, scene.dt, 0.1, "RK4")
    a = MUJOCO.simulate(scene, s)
    b = PINOCCHIO.simulate(scene, RunSettings(1.0, scene.dt, 0.1, "rkmk4"))
    assert a.ok and b.ok
    assert np.abs(a.p_WCm_W - b.p_WCm_W).max() < 1e-11
    assert rotations.geodesic_angle(a.quat_WB, b.quat_WB).max() < 1e-11
    assert np.abs(a.w_WB_W - b.w_WB_W).max() < 1e-9
