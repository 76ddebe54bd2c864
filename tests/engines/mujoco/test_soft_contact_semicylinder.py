"""MuJoCo's own soft contact on the rocking semicylinder (Problem 5.12), against the exact motion:
the scene states the smooth plane as an ideal slide (``models/rocking_semicylinder``); here the
plane is a MuJoCo contact instead, the way a MuJoCo user would model it: one free body, a
cylinder geom of radius R (its lower half is the curved face while |phi| < pi/2) on a plane,
frictionless (``condim="1"``), RK4 at the scene's step. The README's figures come from
``test_mujoco_soft_contact_damps_the_rocking``."""

import mujoco
import numpy as np

from harness.engines import load_scene
from harness.references import rocking_semicylinder as ref


def soft_contact_run(p: ref.SemicylinderParams, dt: float, t_end: float, solref: str = "", solimp: str = ""):
    """(t, phi, z_O) of the semicylinder as one free MuJoCo body on a plane with a frictionless
    contact; phi (rad) about -y, z_O (m) the axis's height (R on the ideal plane)."""
    c = ref.centroid_depth(p.R)
    t_ax = p.m * (p.R**2 / 4.0 + p.w**2 / 12.0) - p.m * c * c
    i_y = 0.5 * p.m * p.R**2 - p.m * c * c
    t_z = p.m * (p.R**2 / 4.0 + p.w**2 / 12.0)
    settings = (f' solref="{solref}"' if solref else "") + (f' solimp="{solimp}"' if solimp else "")
    xml = f"""<mujoco><option timestep="{dt}" integrator="RK4" gravity="0 0 {-p.g}"/>
      <worldbody><geom name="plane" type="plane" size="5 5 0.1" condim="1"/>
        <body name="semicylinder" pos="{p.x0} 0 {p.R}"><freejoint/>
          <inertial pos="0 0 {-c}" mass="{p.m}" diaginertia="{t_ax} {i_y} {t_z}"/>
          <geom type="cylinder" size="{p.R} {p.w / 2}" euler="1.5707963267948966 0 0" condim="1"{settings}/>
        </body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qpos[3:7] = [np.cos(p.phi0 / 2), 0.0, -np.sin(p.phi0 / 2), 0.0]  # rotation about -y by phi0
    n, every = int(round(t_end / dt)), int(round(0.01 / dt))
    t, phi, z = [], [], []
    R = np.zeros(9)
    for k in range(n + 1):
        if k % every == 0:
            mujoco.mju_quat2Mat(R, d.qpos[3:7])
            t.append(d.time)
            phi.append(np.arctan2(R[6], R[0]))
            z.append(d.qpos[2])
        mujoco.mj_step(m, d)
    return np.array(t), np.array(phi), np.array(z)


def test_mujoco_soft_contact_damps_the_rocking():
    """With MuJoCo's default contact settings the rocking (exact amplitude 0.5 rad, undamped) is
    gone within 0.3 s: the body rests at phi = 0, sunk 0.14 mm, while the exact motion still swings
    by 0.5 rad; the largest error over 3 s is the amplitude itself."""
    scene = load_scene("rocking_semicylinder")
    p = ref.SemicylinderParams.from_mapping(scene.params)
    t, phi, z = soft_contact_run(p, scene.dt, 3.0)
    exact = ref.reference_solution(p, t)
    late = t >= 0.3
    assert np.max(np.abs(phi[late])) < 1e-2 < 0.4 < np.max(np.abs(exact.phi[late]))
    assert np.max(np.abs(phi - exact.phi)) > 0.9 * p.phi0
    assert 0.0 < p.R - z[-1] < 1e-3
