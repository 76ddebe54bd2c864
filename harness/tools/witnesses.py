"""The dynamics witnesses of ``harness check``: the in-house engine and Exudyn, built from the model
as MuJoCo compiled it.

Neither engine reads a model file: each runs a ``Multibody`` (the harness's one description).
``harness check`` builds that description from MuJoCo's compiled reading of the file
(``harness.model.from_model_file.read_compiled``: one joint per body, fixed children merged into
their body at ``qpos0``, MuJoCo's frames re-expressed in the harness's), then each engine from it.
They therefore test the *dynamics* of MuJoCo's reading, not a parser: they are witnesses of
dynamics only and never vote on how the file is read (``check.vote`` counts MuJoCo, Pinocchio and
Drake alone). What they hold is listed against the description and MuJoCo's reading
(``model_rows``: mass, centre of mass, inertia, axis and joint placement as each engine holds
them); a difference there is a build error of the witness and fails the check.

Coordinates: the check's common coordinates are MuJoCo's (``harness.tools.dynamics_terms``);
the description's are those of ``read_model_file``: hinge/slide ``q = qpos - qpos0``, ball
``q = c qpos c*``, ``v = C qvel`` (``C`` the rotation from MuJoCo's body frame to the harness's),
free unchanged (``to_description``).

In-house M, bias and gravity (``inhouse_terms``) come from the engine's own Newton-Euler
equations in maximal coordinates (``newton_euler.make_dynamics``: the KKT system with the joints'
constraint forces). With u = [v_WCm_W of every body; w_WB_B of every body] and J(q) the map from
common joint velocities to u (``harness.model.kinematics.forward``), a generalized force tau is
applied as the body forces and torques f = J (J^T J)^-1 tau (J^T f = tau: the same virtual power),
the engine's accelerations du/dt are mapped back by least squares dv/dt = J^+ (du/dt - dJ/dt v)
(exact when the engine's accelerations respect the joints, as they must), so that

* M^-1: the responses dv/dt to unit generalized forces (the accelerations' difference with the
  unforced ones), M its inverse;
* M a + bias + gravity = 0 without forces: bias + gravity = -M dv/dt, gravity the same at v = 0.

dJ/dt v is a fourth-order central difference of u along the zero-acceleration flow (step 1e-3 s
scaled by the speed; truncation ~1e-12 relative).

Exudyn integrates in redundant coordinates with implicit (order-2) solvers: it holds no
joint-space terms, and it is compared in free motion only.

Free motion (``free_motion``): from the first of the random states of MuJoCo against Pinocchio
(``FREE_STATES``) over at most ``FREE_T_END``, each
witness's run against MuJoCo's rigid run (RK4, contacts, constraints, passive forces and
actuators off), on every moving body's centre of mass (world position and velocity) and frame
orientation (geodesic angle, MuJoCo's body frame turned into the harness's by ``C``) and angular
velocity (world). In-house: ``rk4_compiled`` (``rk4`` where the compiled form cannot hold the
model) at the check's dt with projection; Exudyn: its ``TrapezoidalIndex2`` (implicit trapezoidal
rule, order 2) at the check's dt, modified Newton. No tolerance: both run again, with MuJoCo, at 2 dt (or dt / 2),
and each difference is judged by how it converges (``harness.judging.error_model``): at the lower
of the two methods' orders (4 against in-house, 2 against Exudyn) or at the resolution, the
witness holds MuJoCo's dynamics; a floor is a dynamics difference, reported apart from the
loaders' verdict (a witness never votes on the file).

A model the description cannot hold (a body with several joints, equality constraints, an unnamed
joint) leaves both witnesses "not run: <one line>"; the parsers still compare.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from harness.judging.error_model import CONVERGES, judge_refinement
from harness.model import kinematics, rotations
from harness.model.errors import InputError
from harness.model.from_model_file import ModelFile, read_compiled, zero_state
from harness.model.joints import JOINTS
from harness.tools import dynamics_terms as dc

WITNESSES = ("in-house", "Exudyn")
#: The in-house engine's method: RK4 compiled (Numba; ``harness.engines.inhouse.compiled``), the
#: per-state ``rk4`` where the compiled form cannot hold the model (``INHOUSE_FALLBACK``).
INHOUSE_METHOD = "rk4_compiled"
INHOUSE_FALLBACK = "rk4"
#: Exudyn's method: the implicit trapezoidal rule on Euler-parameter nodes, order 2.
EXUDYN_METHOD = "TrapezoidalIndex2"
#: The witnesses' free motion: from the first of the check's random states, over at most this
#: horizon (s). Judged by convergence, a run needs only enough steps for its order to show (100 at
#: the check's 1 ms, compared at 11 samples). Exudyn runs its modified Newton iteration
#: (``ExudynEngine(modified_newton=True)``): on g1 (30 bodies) 0.1 s at 1 ms took 6.0 s with full
#: Newton and 0.26 s with modified Newton, to the same Newton tolerances.
FREE_STATES = 1
FREE_T_END = 0.1


@dataclass
class WitnessFree:
    """One witness's free motion against MuJoCo's rigid run from one state: largest differences over
    the saved samples at the check's step (position m, orientation rad, velocity m/s or rad/s), the
    body where the pose differs most, how each difference converges (``models``: quantity ->
    ``ErrorModel``), ``status`` ("ok" or why the run failed) and the method it ran."""

    witness: str
    state: int
    position: float
    orientation: float
    velocity: float
    worst_body: str
    models: dict
    status: str = "ok"
    method: str = ""

    @property
    def passed(self) -> bool:
        """It ran, and every difference converges (falls at the methods' order, or sits at the resolution)."""
        return self.status == "ok" and bool(self.models) and all(e.classification == CONVERGES
                                                                 for e in self.models.values())

    @property
    def summary(self) -> str:
        """One line: how the difference converges (the position's model, the worst of the three otherwise)."""
        if self.status != "ok":
            return f"not run: {self.status}"
        bad = [e for e in self.models.values() if e.classification != CONVERGES]
        e = bad[0] if bad else self.models["position"]
        return f"{e.classification} ({e.reason})"


@dataclass
class ModelRow:
    """A body's quantity as a witness holds it, against the description it was built from
    (and MuJoCo's reading, for the frame-independent mass and principal moments)."""

    witness: str
    body: str
    quantity: str
    held: str
    difference: float     # relative to the quantity's scale
    ok: bool


@dataclass
class Witnesses:
    """The witnesses of one check: why they did not run (``refusal``), the description, rows."""

    refusal: str = ""
    model_file: ModelFile | None = None
    rows: list[ModelRow] = field(default_factory=list)
    free: list[WitnessFree] = field(default_factory=list)
    wall_s: float = 0.0
    source: object = None   # (q, v) -> Terms of the in-house engine (``inhouse_source``)
    dynamics: list = field(default_factory=list)   # TermDiff of each loader against the in-house terms

    @property
    def problems(self) -> list[str]:
        return [f"{r.witness} holds body {r.body!r} {r.quantity} {r.held}, not the description's (relative "
                f"difference {r.difference:.2e})" for r in self.rows if not r.ok]


# --------------------------------------------------------------------------- the description


def describe(m: mujoco.MjModel, source: Path) -> Witnesses:
    """The description of MuJoCo's compiled reading (``read_compiled``, fixed children merged), or
    ``Witnesses.refusal`` saying in one line why there is none."""
    try:
        mf = read_compiled(m, source, merge_fixed=True)
    except InputError as err:
        return Witnesses(refusal=str(err).removeprefix(f"{source}: "))
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]
    if not all(names):
        return Witnesses(refusal="a joint without a name: the witnesses map joints by name")
    return Witnesses(model_file=mf)


def _body_of(mf: ModelFile) -> dict[str, str]:
    return dict(mf.joints)


def to_description(mf: ModelFile, jmap: dc.JointMap, q: np.ndarray, v: np.ndarray) -> tuple[dict, dict]:
    """Common (MuJoCo) state -> the description's per-body ``q0, v0`` (module docstring); bodies
    whose joints are not mapped stay at zero, at rest."""
    m, mb = mf.model, mf.multibody
    q0, v0 = {}, {}
    for body in mb.bodies:
        q0[body.name], v0[body.name] = zero_state(JOINTS[body.joint])
    for s in jmap.slots:
        body = mf.joints[s.name]
        qs, vs = np.array(s.q(q), float), np.array(s.v(v), float)
        jt = s.joint
        if jt.world_linear_velocity:
            pass
        elif jt.quat_at is not None:
            C = mf.rotations[body]
            c = rotations.from_matrix(C)
            qs = rotations.multiply(rotations.multiply(c, qs / np.linalg.norm(qs)), c * np.array([1.0, -1.0, -1.0, -1.0]))
            vs = C @ vs
        else:
            qs = qs - m.qpos0[s.mj_q:s.mj_q + jt.nq]
        q0[body], v0[body] = qs, vs
    return q0, v0


def _u(mb, q0: dict, v0: dict) -> np.ndarray:
    """u = [v_WCm_W of every body; w_WB_B of every body] (the in-house engine's velocity layout)."""
    states = kinematics.forward(mb, q0, v0)
    lin, ang = [], []
    for b in mb.bodies:
        s = states[b.name]
        lin.append(s.v_WCm_W)
        ang.append(rotations.matrix(s.quat_WB).T @ s.w_WB_W)
    return np.concatenate(lin + ang)


# --------------------------------------------------------------------------- in-house terms


def inhouse_source(w: Witnesses, jmap: dc.JointMap):
    """``(q, v) -> Terms`` of the in-house engine in common coordinates (module docstring)."""
    from harness.engines.inhouse import build
    from harness.engines.inhouse.model import TorqueElement, initial_state
    from harness.engines.inhouse.newton_euler import make_dynamics

    mf = w.model_file
    mb = mf.multibody
    nem = build(mb)
    nb, nv = nem.nb, jmap.nv
    index = {n: i for i, n in enumerate(nem.body_names)}
    # rows of the bodies the mapped joints move (an unmapped tree stays out of the least squares)
    moved, mapped = set(), {mf.joints[s.name] for s in jmap.slots}
    for b in mb.bodies:
        if b.name in mapped or (b.parent in moved):
            moved.add(b.name)
    rows = np.array([3 * index[n] + k for n in moved for k in range(3)]
                    + [3 * nb + 3 * index[n] + k for n in moved for k in range(3)], dtype=int)
    base = make_dynamics(nem)

    def udot(y, f=None):
        if f is None:
            return base(0.0, y)[0][7 * nb:]
        F, tau = f[:3 * nb].reshape(nb, 3), f[3 * nb:].reshape(nb, 3)
        torques = tuple(TorqueElement(i, nb, np.eye(3)[k], float(tau[i, k])) for i in range(nb) for k in range(3)
                        if tau[i, k])
        dyn = make_dynamics(replace(nem, weight_W=nem.weight_W + F, torques=nem.torques + torques))
        return dyn(0.0, y)[0][7 * nb:]

    def state(q, v):
        q0, v0 = to_description(mf, jmap, q, v)
        return q0, v0, initial_state(replace(mb, q0=q0, v0=v0), nem)

    def J_of(q):
        q0, _ = to_description(mf, jmap, q, np.zeros(nv))
        cols = []
        for e in np.eye(nv):
            _, ve = to_description(mf, jmap, q, e)
            cols.append(_u(mb, q0, ve))
        return np.stack(cols, axis=1)

    def accel(J, du):
        return np.linalg.lstsq(J[rows], du[rows], rcond=None)[0]

    def terms(q, v):
        J = J_of(q)
        _, _, y = state(q, v)
        _, _, y_rest = state(q, np.zeros(nv))
        free0 = udot(y_rest)
        Minv = np.zeros((nv, nv))
        pinvT = J @ np.linalg.inv(J.T @ J)
        for k in range(nv):
            Minv[:, k] = accel(J, udot(y_rest, pinvT[:, k]) - free0)
        M = np.linalg.inv(Minv)
        speed = max(1.0, float(np.max(np.abs(v), initial=0.0)))
        h = dc.FD_STEP / speed

        def u_along(t):
            q0, v0 = to_description(mf, jmap, dc.retract(jmap, q, t * v), v)
            return _u(mb, q0, v0)

        Jdot_v = dc._d4(u_along, h)
        total = -M @ accel(J, udot(y) - Jdot_v)
        gravity = -M @ accel(J, free0)
        return dc.Terms(M, total - gravity, gravity)

    return terms


# --------------------------------------------------------------------------- model terms as each holds them


def _rel(a, b, scale: float) -> float:
    return float(np.max(np.abs(np.asarray(a, float) - np.asarray(b, float)), initial=0.0)) / max(scale, 1e-300)


def _fmt(x) -> str:
    x = np.ravel(np.asarray(x, float))
    return f"{x[0]:.6g}" if len(x) == 1 else "[" + ", ".join(f"{c:.6g}" for c in x) + "]"


def model_rows(w: Witnesses, mujoco_bodies, rtol: float) -> list[ModelRow]:
    """Per body: mass, centre of mass, inertia, axis and joint placement as the in-house engine's
    ``NEModel`` and Exudyn's system hold them, against the description; mass and principal moments
    also against MuJoCo's reading (``JointBody``, frame-independent)."""
    from harness.engines.inhouse import build

    mb = w.model_file.multibody
    nem = build(mb)
    index = {n: i for i, n in enumerate(nem.body_names)}
    tree = {name: j for j, name in enumerate(nem.joint_names)}
    slides = {sl.name: sl for sl in nem.slides}
    nj = len(nem.joint_names)
    mj = {x.body: x for x in mujoco_bodies if x.mass > 0}
    out = []

    def add(witness, body, quantity, held, want, scale):
        d = _rel(held, want, scale)
        out.append(ModelRow(witness, body.name, quantity, _fmt(held), d, bool(d <= rtol)))

    size = max([1.0] + [float(np.linalg.norm(b.p_PB_P)) for b in mb.bodies])
    for b in mb.bodies:
        i = index[b.name]
        com = np.asarray(b.p_BCm_B, float)
        held_com, held_axis, held_place = None, None, None
        if b.name in tree:
            j = tree[b.name]
            held_com = -nem.D_end[j, :, 0]
            parent_com = np.zeros(3) if b.parent is None else np.asarray(mb.body(b.parent).p_BCm_B, float)
            held_place = nem.D_end[nj + j, :, 0] + parent_com
            if JOINTS[b.joint].axis:
                held_axis = nem.D_end[j, :, 1]
        elif b.name in slides:
            sl = slides[b.name]
            held_com, held_axis = -sl.r_c, sl.axis
            held_place = sl.r_p + (np.zeros(3) if b.parent is None else np.asarray(mb.body(b.parent).p_BCm_B, float))
        add("in-house", b, "mass", nem.mass[i], b.mass, b.mass)
        add("in-house", b, "inertia", nem.I_B[i], b.I_Cm_B, np.max(np.abs(b.I_Cm_B)))
        if held_com is not None:
            add("in-house", b, "centre of mass", held_com, com, size)
            add("in-house", b, "position in parent", held_place, b.p_PB_P, size)
        if held_axis is not None:
            add("in-house", b, "axis", held_axis, b.axis_B, 1.0)
        x = mj.get(b.name)
        if x is not None:
            add("MuJoCo's reading vs description", b, "mass", x.mass, b.mass, b.mass)
            add("MuJoCo's reading vs description", b, "principal moments", np.linalg.eigvalsh(x.I_Cm_B),
                np.linalg.eigvalsh(b.I_Cm_B), np.max(np.abs(b.I_Cm_B)))
    out += _exudyn_rows(mb, rtol, size)
    return out


def _exudyn_rows(mb, rtol: float, size: float) -> list[ModelRow]:
    try:
        from harness.engines.exudyn.model import build as exu_build
        system = exu_build(mb, "RotationEulerParameters")
    except Exception as err:  # noqa: BLE001 - Exudyn missing or refusing: one line
        return [ModelRow("Exudyn", "-", "build", " ".join(str(err).split()), float("inf"), False)]
    out = []
    for b in mb.bodies:
        obj = system.mbs.GetObject(system.bodies[b.name])
        mass = float(obj["mass"])
        c = np.asarray(obj["centerOfMass"], float)
        i6 = np.asarray(obj["inertia"], float)   # xx yy zz yz xz xy about the body reference point
        I_ref = np.array([[i6[0], i6[5], i6[4]], [i6[5], i6[1], i6[3]], [i6[4], i6[3], i6[2]]])
        I_c = I_ref - mass * (c @ c * np.eye(3) - np.outer(c, c))
        for quantity, held, want, scale in (("mass", mass, b.mass, b.mass),
                                            ("centre of mass", c, b.p_BCm_B, size),
                                            ("inertia", I_c, b.I_Cm_B, np.max(np.abs(b.I_Cm_B)))):
            d = _rel(held, want, scale)
            out.append(ModelRow("Exudyn", b.name, quantity, _fmt(held), d, bool(d <= rtol)))
    return out


# --------------------------------------------------------------------------- free motion


#: Wall-clock budget (s) of one witness run (``free_motion``), made in its own worker process.
WITNESS_TIMEOUT = 120.0
#: The witness free motions' compared quantities and their units.
WITNESS_UNITS = {"position": "m", "orientation": "rad", "velocity": "m/s or rad/s"}


def _mujoco_samples(m: mujoco.MjModel, rigid: mujoco.MjModel, mf: ModelFile, jmap: dc.JointMap, q0: np.ndarray,
                    v0: np.ndarray, moving: list[str], steps: int, n_saves: int) -> list[dict]:
    """MuJoCo's rigid run ``rigid`` (at its own timestep), sampled every ``steps`` steps: per moving
    body of the description, (centre of mass m, R_WB of the description's frame, centre-of-mass
    velocity m/s, angular velocity rad/s), world frame, the body's merged fixed children included."""
    d = mujoco.MjData(rigid)
    d.qpos[:], d.qvel[:] = dc.mujoco_state(m, jmap, q0, v0)
    ids = {b.name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in mf.multibody.bodies}
    owner = np.arange(m.nbody)
    for b in range(1, m.nbody):
        owner[b] = b if m.body_jntnum[b] > 0 else owner[m.body_parentid[b]]
    parts = {b: [c for c in range(1, m.nbody) if owner[c] == b] for b in ids.values()}
    out = []
    vel = np.zeros(6)
    for i in range(n_saves + 1):
        if i > 0:
            for _ in range(steps):
                mujoco.mj_step(rigid, d)
        mujoco.mj_forward(rigid, d)
        sample = {}
        for name in moving:
            b = ids[name]
            R = d.xmat[b].reshape(3, 3)
            p_com, v_com, total = np.zeros(3), np.zeros(3), 0.0
            for part in parts[b]:   # the body and its merged fixed children (``read_compiled``)
                mujoco.mj_objectVelocity(rigid, d, mujoco.mjtObj.mjOBJ_BODY, part, vel, 0)   # [w, v at xipos], world
                mk = float(m.body_mass[part]) or (1.0 if part == b and len(parts[b]) == 1 else 0.0)
                p_com, v_com, total = p_com + mk * d.xipos[part], v_com + mk * vel[3:], total + mk
                if part == b:
                    w_W = vel[:3].copy()
            sample[name] = (p_com / total, R @ mf.rotations[name].T, v_com / total, w_W)
        out.append(sample)
    return out


def _differences(traj, ref: list[dict]) -> tuple[dict[str, float], str, dict[str, float]]:
    """Largest differences of a witness's trajectory from MuJoCo's samples (``WITNESS_UNITS``), the
    body where the pose differs most, and the motion's scales (largest body distance from the world
    origin, at least 1 mm; 1 rad; largest speed, at least 1)."""
    worst = {"position": 0.0, "orientation": 0.0, "velocity": 0.0}
    scales = {"position": 1e-3, "orientation": 1.0, "velocity": 1.0}
    worst_body, top = "", -1.0
    for i, sample in enumerate(ref):
        for name, (p, R, v, w_W) in sample.items():
            bi = traj.body_index(name)
            dp = float(np.linalg.norm(traj.p_WCm_W[i, bi] - p))
            dq = float(rotations.geodesic_angle(traj.quat_WB[i, bi], rotations.from_matrix(R)))
            dv = float(max(np.max(np.abs(traj.v_WCm_W[i, bi] - v)), np.max(np.abs(traj.w_WB_W[i, bi] - w_W))))
            if not np.isfinite(dp + dq + dv):
                dp = dq = dv = float("nan")
            if np.isnan(dp) or dp + dq > top:
                top, worst_body = (float("inf") if np.isnan(dp) else dp + dq), name
            worst = {key: float(np.maximum(worst[key], val)) for key, val in
                     (("position", dp), ("orientation", dq), ("velocity", dv))}
            scales["position"] = max(scales["position"], float(np.linalg.norm(p)))
            scales["velocity"] = max(scales["velocity"], float(np.max(np.abs(np.concatenate([v, w_W])))))
    return worst, worst_body, scales


def free_motion(w: Witnesses, m: mujoco.MjModel, jmap: dc.JointMap, q0: np.ndarray, v0: np.ndarray, k: int, *,
                t_end: float, dt: float, save_every: float, rigid_at) -> list[WitnessFree]:
    """Both witnesses from common state (q0, v0) against MuJoCo's rigid model (``rigid_at(step)``:
    MuJoCo's rigid model at that step), each judged by how its difference converges (module
    docstring): the witness and MuJoCo run at ``dt`` and at 2 ``dt`` (``dt`` / 2 when the save interval
    is an odd number of steps; half the finest step where the levels leave it open), and the
    largest differences are fitted at the lower of the two methods' orders."""
    from harness.engines.base import RunSettings
    from harness.engines.exudyn.engine import ExudynEngine
    from harness.engines.inhouse import InhouseEngine
    from harness.validate.workers import run_cases

    mf = w.model_file
    mb = mf.multibody
    qd, vd = to_description(mf, jmap, q0, v0)
    model = replace(mb, q0=qd, v0=vd)
    steps = max(1, int(round(save_every / dt)))
    n_saves = max(1, int(round(t_end / (steps * dt))))
    moving = _descendants(mb, [mf.joints[s.name] for s in jmap.slots])
    second = 2.0 * dt if steps % 2 == 0 else dt / 2.0
    refs: dict[float, list[dict]] = {}

    def reference(h: float) -> list[dict]:
        if h not in refs:
            refs[h] = _mujoco_samples(m, rigid_at(h), mf, jmap, q0, v0, moving, int(round(steps * dt / h)), n_saves)
        return refs[h]

    mujoco_order = 4.0   # MuJoCo's RK4
    out = []
    for label, engine, method in (("in-house", InhouseEngine(), INHOUSE_METHOD), ("Exudyn", ExudynEngine(modified_newton=True), EXUDYN_METHOD)):
        order = min(float(engine.integrators[method].order), mujoco_order)
        failure: list[str] = []
        worst_at: dict[float, tuple] = {}

        chosen = [method]

        def measure(h: float, engine=engine, label=label, chosen=chosen) -> dict[str, float]:
            nan = {q: float("nan") for q in WITNESS_UNITS}
            if failure:
                return nan
            rs = RunSettings(n_saves * steps * dt, h, steps * dt, chosen[0])
            # in its own worker under a wall-clock budget: a hang or a crash is that witness's result
            outcome = run_cases([(label, engine.simulate_model, (model, rs))], 1, WITNESS_TIMEOUT)[label]
            if outcome.status != "ok":
                failure.append(f"timed out after {WITNESS_TIMEOUT:g} s" if outcome.status == "timeout"
                               else f"{outcome.status}: {' '.join(outcome.message.split())}")
                return nan
            traj = outcome.value
            if traj.status == "unsupported" and chosen[0] == INHOUSE_METHOD:   # the compiled form cannot hold it
                chosen[0] = INHOUSE_FALLBACK
                return measure(h)
            if traj.status != "ok" or len(traj.t) != n_saves + 1:
                failure.append(f"{traj.status}: {traj.message}")
                return nan
            worst_at[h] = _differences(traj, reference(h))
            return worst_at[h][0]

        first = measure(dt)
        if failure:
            out.append(WitnessFree(label, k, float("nan"), float("nan"), float("nan"), "", {}, failure[0], chosen[0]))
            continue
        scales = {q: (unit, worst_at[dt][2][q]) for q, unit in WITNESS_UNITS.items()}
        models = judge_refinement(lambda h: first if h == dt else measure(h), (dt, second), order, scales,
                                  n_saves * steps)
        out.append(WitnessFree(label, k, first["position"], first["orientation"], first["velocity"], worst_at[dt][1],
                               models, failure[0] if failure else "ok", chosen[0]))
    return out


def _descendants(mb, names) -> list[str]:
    moved = set(names)
    for b in mb.bodies:
        if b.parent in moved:
            moved.add(b.name)
    return [b.name for b in mb.bodies if b.name in moved]


def run(w: Witnesses, m: mujoco.MjModel, jmap: dc.JointMap, free_states, *, t_end: float, dt: float,
        save_every: float, rigid_at) -> None:
    """The witnesses' free motions from ``free_states`` into ``w.free``; wall time into ``w.wall_s``."""
    start = time.perf_counter()
    for k, (q, v) in enumerate(free_states):
        w.free += free_motion(w, m, jmap, q, v, k, t_end=t_end, dt=dt, save_every=save_every, rigid_at=rigid_at)
    w.wall_s += time.perf_counter() - start
