"""MuJoCo through ``mujoco.rollout``: many steps (and many initial states) in one C call.

``harness.engines.mujoco.engine`` steps MuJoCo from Python (``mj_step`` per step, read-back at
each saved sample); here the stepping happens inside ``mujoco.rollout.rollout`` and the states it
returns (``nbatch x nstep x nstate``, ``mjSTATE_FULLPHYSICS`` layout) are converted to maximal
coordinates afterwards with the same reading as the engine (``read_bodies``: ``mj_forward`` on
the state, then ``xipos``, ``xquat`` and ``mj_objectVelocity``, COM velocity in world). The time
spent inside ``rollout`` is MuJoCo's own; the difference to the stepping loop is the harness's
Python overhead.

Prescribed forces are not supported here: ``rollout`` applies open-loop controls held over each
step, while the harness sets the force at every RK4 stage (``mjcb_control``);
``prepare`` raises ``NotImplementedError`` for a forced scene.

MuJoCo's warnings during ``run`` are not printed but kept (``RolloutModel.warnings``, the
messages of the last ``run``) and stored by ``trajectory`` as ``stats["warnings"]`` (count and
first message), as the stepping engine does.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np
from mujoco import rollout as _rollout

from harness.engines.base import first_blowup, warning_stats
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.engines.mujoco.model import load_mjcf, set_initial_state
from harness.model.multibody import Multibody
from harness.model.scene import Scene
from harness.measure.trajectory import Trajectory

STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


class RolloutModel:
    """A compiled model with the scene's initial state, ready for ``rollout``.

    Attributes:
        m, d: the MjModel and a scratch MjData.
        model: the scene's ``Multibody``.
        body_ids: MuJoCo body id per ``model.bodies`` entry.
        state0: (nstate,) initial ``mjSTATE_FULLPHYSICS`` state.
    """

    def __init__(self, m: mujoco.MjModel, model: Multibody, source) -> None:
        self.m = m
        self.d = mujoco.MjData(m)
        self.model = model
        set_initial_state(m, self.d, model, source)
        mujoco.mj_forward(m, self.d)
        self.body_ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in model.bodies]
        self.nstate = mujoco.mj_stateSize(m, STATE_SPEC)
        self.state0 = np.empty(self.nstate)
        mujoco.mj_getState(m, self.d, self.state0, STATE_SPEC)
        self._datas: dict[int, list[mujoco.MjData]] = {}
        self.warnings: list[str] = []  # MuJoCo's warning messages during the last ``run``

    def datas(self, nthread: int) -> list[mujoco.MjData]:
        """``nthread`` MjData for ``rollout`` (one per thread), made once."""
        if nthread not in self._datas:
            self._datas[nthread] = [mujoco.MjData(self.m) for _ in range(nthread)]
        return self._datas[nthread]

    def run(self, initial_states: np.ndarray, nstep: int, nthread: int = 1) -> np.ndarray:
        """``rollout`` from ``initial_states`` (nbatch x nstate) for ``nstep`` steps with
        ``nthread`` threads; returns the states after each step, nbatch x nstep x nstate.
        MuJoCo's warnings go to ``self.warnings``, not to stdout."""
        with captured_warnings() as caught:
            state, _ = _rollout.rollout(self.m, self.datas(nthread), np.atleast_2d(initial_states), nstep=int(nstep))
        self.warnings = caught.messages
        return state

    def state_from_joints(self, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """The full-physics state (nstate,) with joint coordinates ``qpos``, ``qvel`` at t = 0."""
        d = self.d
        mujoco.mj_setState(self.m, d, self.state0, STATE_SPEC)
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        out = np.empty(self.nstate)
        mujoco.mj_getState(self.m, d, out, STATE_SPEC)
        return out

    def integrate_pos(self, qpos: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """``qpos`` moved by the joint velocities ``dq`` (nv,) over unit time (``mj_integratePos``:
        on the joints' manifold, quaternions kept unit); a new array."""
        out = np.array(qpos, dtype=float)
        mujoco.mj_integratePos(self.m, out, np.asarray(dq, dtype=float), 1.0)
        return out

    def read_bodies(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Maximal coordinates of one state: centre-of-mass positions (nb, 3) m, quaternions
        ``wxyz`` (nb, 4), centre-of-mass velocities (nb, 3) m/s and angular velocities (nb, 3)
        rad/s, all world frame (as ``mujoco_engine``)."""
        m, d = self.m, self.d
        mujoco.mj_setState(m, d, state, STATE_SPEC)
        mujoco.mj_forward(m, d)
        nb = len(self.body_ids)
        p, q, v, w = np.empty((nb, 3)), np.empty((nb, 4)), np.empty((nb, 3)), np.empty((nb, 3))
        res6 = np.zeros(6)
        for i, bid in enumerate(self.body_ids):
            p[i] = d.xipos[bid]
            q[i] = d.xquat[bid]
            mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, bid, res6, 0)
            w[i] = res6[:3]
            v[i] = res6[3:]
        return p, q, v, w

    def trajectory(self, states: np.ndarray, t: np.ndarray, integrator: str) -> Trajectory:
        """A ``Trajectory`` from states (n x nstate) saved at times ``t`` (n,) s; a blow-up
        (``harness.engines.base.first_blowup``: a non-finite state, a speed beyond
        ``BLOWUP_SPEED``) ends it with its reason."""
        n = len(t)
        nb = len(self.body_ids)
        P, Q, V, W = (np.full((n, nb, k), np.nan) for k in (3, 4, 3, 3))
        for k in range(n):
            if not np.all(np.isfinite(states[k])):
                break  # this sample and the rest stay NaN: first_blowup ends the run there
            P[k], Q[k], V[k], W[k] = self.read_bodies(states[k])
        bad, reason, message = first_blowup(P, V, W, t)
        saved = n if bad < 0 else bad
        return Trajectory(engine="mujoco", integrator=integrator, body_names=tuple(b.name for b in self.model.bodies),
                          t=np.asarray(t, dtype=float)[:saved], p_WCm_W=P[:saved], quat_WB=Q[:saved],
                          v_WCm_W=V[:saved], w_WB_W=W[:saved], reason=reason, message=message,
                          stats={"warnings": warning_stats(self.warnings)})


def prepare(scene: Scene, dt: float, integrator: str) -> RolloutModel:
    """Compile the scene's MJCF with step ``dt`` (s) and ``integrator`` for ``rollout``."""
    model = scene.multibody()
    if model.forces:
        raise NotImplementedError("mujoco.rollout holds controls over a step; prescribed forces need per-stage control")
    m = load_mjcf(scene.mjcf, model, dt=dt, integrator=integrator)
    return RolloutModel(m, model, scene.mjcf)


def default_threads() -> int:
    """Threads for batched rollouts: the cores this process may use (as the compiled in-house
    batch, ``harness.engines.inhouse.compiled.solver.default_threads``)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def saved_states(initial: np.ndarray, states: np.ndarray, steps_per_save: int) -> np.ndarray:
    """The initial state (nstate,) and every ``steps_per_save``-th state of one rollout
    (nstep x nstate): the states at the save times, (nstep / steps_per_save + 1) x nstate."""
    return np.concatenate([np.asarray(initial)[None], states[steps_per_save - 1 :: steps_per_save]])
