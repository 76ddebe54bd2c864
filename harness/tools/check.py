"""``harness check``: compare any MJCF/URDF model between MuJoCo and Pinocchio, then write a report.

Loads (``load_pair``):

* ``--mjcf`` and ``--urdf``: MuJoCo from the MJCF, Pinocchio from the URDF;
* ``--urdf`` alone: both engines from the URDF (MuJoCo compiles URDF itself);
* ``--mjcf`` alone: both engines from the MJCF (``pinocchio.buildModelFromMJCF``).

The robot is fixed-base (a URDF's root link is welded to the world in both engines) unless
``floating_base`` adds a free joint named ``root_joint`` to the root body in both. Joints are
matched by name (MuJoCo's URDF import keeps the URDF joint names). ``strip`` deletes geoms and
meshes from MuJoCo's copy (mass properties come from the inertials; meshes need not be found);
``keep_static`` turns off MuJoCo's ``fusestatic``, on by default for URDF.

Then, in order: the models (per joint: the rigid body it moves with mass, centre of mass,
inertia, placement in the parent, joint type and axis; gravity; importer differences such as
fused links, limits, damping, armature, mimic joints), the dynamics terms at random states
(``harness.tools.dynamics_terms``), and free motion under gravity from random states (MuJoCo RK4 with
contacts, constraints and passive forces off; Pinocchio ``aba`` with
``lie_group_integrators.rkmk4_step``), comparing joint trajectories and every moving body's world
pose. The report ``check_<model>.md`` is written atomically after everything has loaded.

MuJoCo's warnings while the dynamics terms and the free motions run (e.g. "Nan, Inf or huge value
in QACC ... The simulation is unstable.") are captured into the result (``CheckResult.warnings``,
``harness.engines.mujoco.warning_capture``: count and first message) and shown in the report and
the summary, never printed on stderr.

Bad input (missing or malformed file, missing mesh, a joint type that cannot be mapped,
non-positive mass, an inertia that is not positive definite or violates the triangle inequality)
raises ``InputError`` naming the file, before anything is written.
"""

from __future__ import annotations

import copy
import os
import re
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from harness.io import atomic
from harness.tools import dynamics_terms as dc
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.engines.pinocchio.lie_group_integrators import rkmk4_step
from harness.engines.pinocchio.model import from_pinocchio, root_joint_model
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.joints import FREE, JOINTS
from harness.tools.loaded_models import (
    JointBody,
    check_joint_bodies_physical,
    compare_joint_bodies,
    mujoco_joint_bodies,
    pinocchio_joint_bodies,
)
from harness.model.sanity import check_inertia

FREE_MOTION_TOL = {"joint": 1e-6, "position": 1e-6, "orientation": 1e-6, "velocity": 1e-5}  # rad or m, m, rad, rad/s or m/s
SAME_FILE_RTOL = 1e-9   # model comparison when both engines read the same file
TWO_FILES_RTOL = 1e-6   # when MJCF and URDF were written separately (decimals in the files)


# --------------------------------------------------------------------------- loading any file


@contextmanager
def captured_native_stderr():
    """Capture what C++ libraries (urdfdom) print on file descriptor 2; yields a dict whose
    ``"text"`` holds it afterwards, so that a failed load gives one line and no stray output."""
    holder = {"text": ""}
    try:
        saved = os.dup(2)
    except OSError:  # pragma: no cover - no stderr at all
        yield holder
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield holder
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            holder["text"] = tmp.read().decode(errors="replace")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def file_format(path: Path) -> str:
    """``URDF`` for ``*.urdf``, else ``MJCF``."""
    return "URDF" if Path(path).suffix.lower() == ".urdf" else "MJCF"


def _require_file(path: Path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: {file_format(path)} file not found")
    return path


def read_mujoco_spec(path: Path) -> mujoco.MjSpec:
    """Parse an MJCF or URDF file with MuJoCo's parser (no compilation)."""
    path = _require_file(path)
    try:
        with captured_native_stderr():
            return mujoco.MjSpec.from_file(str(path))
    except Exception as err:
        raise InputError(f"{path}: cannot load {file_format(path)}: {_one_line(err)}") from None


def check_spec_inertials(spec: mujoco.MjSpec, source: Path) -> None:
    """File-level sanity of the inertials: no body/link may have a negative mass, and every
    body/link that a joint moves and that has mass must have a valid inertia tensor
    (``check_inertia``: positive definite, triangle inequality). Fixed links (frames, sensors)
    are judged through the composite body they are merged into (``load_pair``)."""
    for body in spec.bodies:
        if body.name == "world" or not body.explicitinertial:
            continue
        mass = float(body.mass)
        what = f"body {body.name!r}"
        if not np.isfinite(mass) or mass < 0.0:
            raise InputError(f"{source}: {what}: mass must be positive, got {mass:g} kg")
        if mass == 0.0 or body.first_joint() is None:
            continue
        full = np.asarray(body.fullinertia, dtype=float)
        if np.all(np.isfinite(full)):
            xx, yy, zz, xy, xz, yz = full
            inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:  # principal moments in the frame iquat: validity does not depend on the frame
            inertia = np.diag(np.asarray(body.inertia, dtype=float))
        check_inertia(inertia, what, str(source))


def add_root_joint(spec: mujoco.MjSpec, kind: str, source: Path) -> None:
    """Give the root body (first child of the world) a joint of kind ``kind`` named
    ``root_joint``: one Pinocchio can add as a root joint (``JointType.pinocchio_root``: free or
    ball); ``none`` leaves it welded."""
    if kind == "none":
        return
    jt = JOINTS.get(kind)
    if jt is None or jt.pinocchio_root is None:
        raise InputError(f"{source}: a {kind} joint cannot be a root joint Pinocchio adds")
    roots = [b for b in spec.bodies if b.name != "world" and b.parent is not None and b.parent.name == "world"]
    if not roots:
        raise InputError(f"{source}: no root body to attach a {kind} joint to")
    root = roots[0]
    joint = root.first_joint()
    if joint is not None:
        wanted = getattr(mujoco.mjtJoint, jt.mujoco)
        if joint.type == wanted and root.next_joint(joint) is None:
            joint.name = "root_joint"  # an MJCF that has the root joint already: match Pinocchio's name
            return
        raise InputError(f"{source}: root body {root.name!r} already has a joint that is not a single {kind} joint")
    if jt is FREE:
        root.add_freejoint(name="root_joint")
    else:
        root.add_joint(name="root_joint", type=getattr(mujoco.mjtJoint, jt.mujoco))


def strip_geometry(spec: mujoco.MjSpec) -> tuple[int, int]:
    """Delete every geom and mesh (dynamics do not need them); returns (geoms, meshes) removed."""
    geoms, meshes = list(spec.geoms), list(spec.meshes)
    for g in geoms:
        spec.delete(g)
    for mesh in meshes:
        spec.delete(mesh)
    return len(geoms), len(meshes)


def compile_spec(spec: mujoco.MjSpec, source: Path) -> mujoco.MjModel:
    """Compile, turning MuJoCo's errors into one-line InputErrors naming the file."""
    try:
        with captured_native_stderr():
            return spec.compile()
    except Exception as err:
        text = _one_line(err)
        missing = re.search(r"Error opening file '([^']*)'", text)
        if missing:
            hint = " (MuJoCo cannot resolve package:// URIs)" if "package:" in missing.group(1) else ""
            raise InputError(f"{source}: missing mesh: cannot open mesh file '{missing.group(1)}'{hint}; "
                             "use --strip-geometry to compare the dynamics without geometry") from None
        raise InputError(f"{source}: MuJoCo cannot compile the {file_format(source)}: {text}") from None


def load_mujoco(path: Path, *, root_joint: str = "none", strip: bool = False,
                keep_static: bool = False) -> tuple[mujoco.MjModel, list[str]]:
    """MuJoCo model of an MJCF or URDF file as written (plus an optional root joint), and notes
    on what loading did (stripped geometry; ``keep_static`` turns MuJoCo's ``fusestatic`` off,
    which is on by default for URDF)."""
    spec = read_mujoco_spec(path)
    add_root_joint(spec, root_joint, path)
    check_spec_inertials(spec, path)
    notes = []
    if keep_static:
        spec.compiler.fusestatic = False
        notes.append("MuJoCo's fusestatic turned off: links on fixed joints stay separate bodies")
    if strip:
        n_geom, n_mesh = strip_geometry(spec)
        notes.append(f"geometry stripped for the dynamics comparison: {n_geom} geoms and {n_mesh} meshes removed "
                     "from MuJoCo's copy (mass properties come from the <inertial> elements)")
    return compile_spec(spec, path), notes


# root joint kind (harness name) -> the joint model Pinocchio adds
PIN_ROOTS = {"none": None} | {jt.name: root_joint_model(jt) for jt in JOINTS.values() if jt.pinocchio_root}


def load_pinocchio(path: Path, *, root_joint: str = "none") -> pin.Model:
    """Pinocchio model of a URDF (``buildModelFromUrdf``) or MJCF (``buildModelFromMJCF``)."""
    path = _require_file(path)
    fmt = file_format(path)
    root = PIN_ROOTS[root_joint]
    build = pin.buildModelFromUrdf if fmt == "URDF" else pin.buildModelFromMJCF
    try:
        with captured_native_stderr() as err_text:
            model = build(str(path), root()) if root else build(str(path))
    except Exception as err:
        reasons = [ln.strip().removeprefix("Error:").strip() for ln in err_text["text"].splitlines()
                   if ln.strip().startswith("Error:")]
        detail = f" ({'; '.join(reasons)})" if reasons else ""
        raise InputError(f"{path}: Pinocchio cannot load the {fmt}: {_one_line(err)}{detail}") from None
    if isinstance(model, tuple):  # some overloads return (model, constraints)
        model = model[0]
    return model


def check_mappable_joints(pmodel: pin.Model, source: Path) -> None:
    """InputError for a joint type ``harness check`` cannot put into common coordinates."""
    for jid in range(1, pmodel.njoints):
        if pin_joint_type(pmodel.joints[jid]) is None:
            name = pmodel.joints[jid].shortname().removeprefix("JointModel").lower()
            raise InputError(f"{source}: joint {pmodel.names[jid]!r} of type {name} cannot be compared between engines "
                             "(supported: revolute, continuous, prismatic, fixed, and a free root)")


# --------------------------------------------------------------------------- the check


@dataclass
class FreeMotion:
    """Largest differences over one free-motion run (units: see ``FREE_MOTION_TOL``)."""

    state: int
    joint: float
    velocity: float
    position: float
    orientation: float
    worst_body: str
    constrained_joint: float = float("nan")   # MuJoCo with limits/equality/damping on vs off (rad or m)


@dataclass
class CheckResult:
    """Everything ``harness check`` found for one model."""

    name: str
    mujoco_source: Path
    pinocchio_source: Path
    mode: str
    base: str
    model_problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    mujoco_bodies: list[JointBody] = field(default_factory=list)
    pinocchio_bodies: list[JointBody] = field(default_factory=list)
    gravity: tuple[np.ndarray, np.ndarray] | None = None
    dynamics: list[dc.TermDiff] = field(default_factory=list)
    free: list[FreeMotion] = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    warnings: dict = field(default_factory=dict)  # MuJoCo's warnings during the comparison: {"count", "first"}

    @property
    def free_passed(self) -> bool:
        tol = FREE_MOTION_TOL
        return all(r.joint <= tol["joint"] and r.velocity <= tol["velocity"] and r.position <= tol["position"]
                   and r.orientation <= tol["orientation"] for r in self.free)  # NaN (a motion gone to NaN) fails

    @property
    def passed(self) -> bool:
        return not self.model_problems and all(d.passed for d in self.dynamics) and self.free_passed


def load_pair(mjcf: Path | None, urdf: Path | None, *, floating_base: bool = False, strip: bool = False,
              keep_static: bool = False):
    """MuJoCo and Pinocchio models per the module docstring; returns (m, pmodel, mujoco file,
    pinocchio file, mode, notes). Raises InputError for bad input."""
    if mjcf is None and urdf is None:
        raise InputError("check needs --mjcf MODEL.xml, --urdf MODEL.urdf, or both")
    mj_file = Path(mjcf) if mjcf is not None else Path(urdf)
    pin_file = Path(urdf) if urdf is not None else Path(mjcf)
    for path in {mj_file, pin_file}:
        _require_file(path)
    mode = {(True, True): "MJCF -> MuJoCo, URDF -> Pinocchio", (False, True): "URDF -> MuJoCo and Pinocchio",
            (True, False): "MJCF -> MuJoCo and Pinocchio"}[(mjcf is not None, urdf is not None)]
    root = FREE.name if floating_base else "none"
    # Parse and check the file-level inertials first, so that every bad value gets the same message.
    for path in {mj_file, pin_file}:
        spec = read_mujoco_spec(path)
        add_root_joint(spec, root, path)
        check_spec_inertials(spec, path)
    pmodel = load_pinocchio(pin_file, root_joint=root)
    check_mappable_joints(pmodel, pin_file)
    check_joint_bodies_physical(pinocchio_joint_bodies(pmodel), str(pin_file))
    m, notes = load_mujoco(mj_file, root_joint=root, strip=strip, keep_static=keep_static)
    last = {}  # a MuJoCo body with several joints carries its mass at the last one
    for x in mujoco_joint_bodies(m):
        last[x.body] = x
    check_joint_bodies_physical(list(last.values()), str(mj_file))
    if m.nv == 0 or pmodel.nv == 0:
        raise InputError(f"{pin_file}: the model has no moving joint, nothing to compare "
                         "(a free-flying robot needs --floating-base)")
    return m, pmodel, mj_file, pin_file, mode, notes


def run_check(mjcf: Path | None, urdf: Path | None, *, seed: int = 0, n_states: int = dc.DEFAULT_STATES,
              n_free: int = 3, t_end: float = 0.5, dt: float = 1e-3, save_every: float = 0.01,
              floating_base: bool = False, strip: bool = False, keep_static: bool = False) -> CheckResult:
    """Load, compare models, dynamics terms and free motion (see module docstring)."""
    for label, value in (("--t-end", t_end), ("--dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{label} must be positive and finite, got {value!r}")
    if n_states < 1 or n_free < 0:
        raise InputError("--states must be >= 1 and --free-runs >= 0")
    m, pmodel, mj_file, pin_file, mode, notes = load_pair(mjcf, urdf, floating_base=floating_base, strip=strip,
                                                                keep_static=keep_static)
    try:
        jmap = dc.named_joint_map(m, pmodel)
    except dc.MappingError as err:
        raise InputError(f"{pin_file}: joints cannot be matched by name between MuJoCo and Pinocchio: {err}") from None
    name = Path(urdf if urdf is not None else mjcf).stem
    res = CheckResult(name, mj_file, pin_file, mode, "floating (free root joint 'root_joint')" if floating_base else "fixed")
    res.notes += notes
    rtol = SAME_FILE_RTOL if mj_file == pin_file else TWO_FILES_RTOL
    res.mujoco_bodies, res.pinocchio_bodies = mujoco_joint_bodies(m), pinocchio_joint_bodies(pmodel)
    res.model_problems += compare_joint_bodies(res.mujoco_bodies, res.pinocchio_bodies, ("MuJoCo", "Pinocchio"), rtol=rtol)
    g_mj, g_pin = np.array(m.opt.gravity), np.array(pmodel.gravity.linear)
    res.gravity = (g_mj, g_pin)
    if np.linalg.norm(g_mj - g_pin) > rtol * max(np.linalg.norm(g_mj), 1.0):
        why = (" (Pinocchio's MJCF parser ignores <option gravity>)" if file_format(pin_file) == "MJCF"
               else " (a URDF cannot state gravity: Pinocchio's default)")
        res.model_problems.append(f"gravity {g_mj.tolist()} m/s^2 in MuJoCo, {g_pin.tolist()} m/s^2 in Pinocchio{why}")
    res.notes += importer_notes(m, pmodel, jmap, mj_file, pin_file)
    states = dc.random_states(jmap, n_states, seed)
    d, data = mujoco.MjData(m), pmodel.createData()
    res.settings = {"seed": seed, "states": n_states, "free_runs": n_free, "t_end": t_end, "dt": dt,
                    "save_every": save_every, "rtol_model": rtol, "rtol_dynamics": max(dc.DEFAULT_RTOL, rtol)}
    with captured_warnings() as caught:  # MuJoCo's warnings go into the result, not onto stderr
        try:
            terms = dc.evaluate({"MuJoCo": lambda q, v: dc.mujoco_terms(m, jmap, q, v, d),
                                 "Pinocchio": lambda q, v: dc.pinocchio_terms(pmodel, jmap, q, v, data)}, states)
            res.dynamics = dc.compare_terms(terms, rtol=max(dc.DEFAULT_RTOL, rtol))
            for k, (q, v) in enumerate(dc.random_states(jmap, n_free, seed + 1)):
                res.free.append(free_motion(m, pmodel, jmap, q, v, k, t_end=t_end, dt=dt, save_every=save_every))
        finally:
            res.warnings = caught.stats()
    return res


def importer_notes(m: mujoco.MjModel, pmodel: pin.Model, jmap: dc.JointMap, mj_file: Path, pin_file: Path) -> list[str]:
    """What the two importers do differently beyond mass properties (not counted as failures)."""
    notes = []
    mj_bodies = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)}
    pin_links = [f.name for f in pmodel.frames if f.type == pin.FrameType.BODY]
    fused = [n for n in pin_links if n not in mj_bodies]
    if fused:
        notes.append(f"MuJoCo fused {len(fused)} link(s) without a moving joint into their parent body (fusestatic; "
                     f"their mass is merged, as Pinocchio merges it into the parent joint's inertia): {', '.join(fused)}")
        massless = [b.name for b in read_mujoco_spec(mj_file).bodies if b.name in fused and b.explicitinertial
                    and b.mass == 0.0 and (np.any(np.asarray(b.inertia) != 0)
                                           or np.any(np.nan_to_num(np.asarray(b.fullinertia, dtype=float)) != 0))]
        if massless:
            notes.append(f"link(s) with mass 0 but a non-zero rotational inertia: {', '.join(massless)}. MuJoCo's fusestatic "
                         "drops that inertia when it merges the link into its parent; Pinocchio adds it to the parent "
                         "joint's inertia (with --keep-static-links MuJoCo keeps it)")
    if file_format(mj_file) == "URDF":
        notes.append(f"MuJoCo's URDF import: options not in URDF take MuJoCo's defaults (timestep {m.opt.timestep:g} s, "
                     f"integrator {mujoco.mjtIntegrator(m.opt.integrator).name[6:]}, gravity {np.round(m.opt.gravity, 6).tolist()} "
                     "m/s^2); visual geometry is discarded (discardvisual), collision geometry kept")
    rows = {"limits": [], "damping": [], "armature": [], "friction": []}
    for s in jmap.slots:
        if s.joint.axis is None:
            continue
        j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, s.name)
        dof = m.jnt_dofadr[j]
        mj_lim = (round(float(m.jnt_range[j][0]), 6), round(float(m.jnt_range[j][1]), 6)) if m.jnt_limited[j] else None
        lo, hi = pmodel.lowerPositionLimit[s.pin_q], pmodel.upperPositionLimit[s.pin_q]
        pin_lim = (round(float(lo), 6), round(float(hi), 6)) if s.pin_nq == 1 and np.isfinite(lo) and np.isfinite(hi) else None
        if mj_lim is not None or pin_lim is not None:
            rows["limits"].append(f"{s.name} MuJoCo {mj_lim} / Pinocchio {pin_lim}")
        for key, mj_val, pin_val in (("damping", m.dof_damping[dof], pmodel.damping[s.pin_v]),
                                     ("armature", m.dof_armature[dof], pmodel.armature[s.pin_v]),
                                     ("friction", m.dof_frictionloss[dof], pmodel.friction[s.pin_v])):
            if mj_val != 0.0 or pin_val != 0.0:
                rows[key].append(f"{s.name} {mj_val:g} / {pin_val:g}")
    if rows["limits"]:
        notes.append("joint limits (MuJoCo enforces them as constraints; Pinocchio stores them, aba ignores them): "
                     + "; ".join(rows["limits"]))
    if rows["damping"]:
        notes.append("joint damping, MuJoCo / Pinocchio (MuJoCo applies it as a passive force; Pinocchio's aba ignores it): "
                     + "; ".join(rows["damping"]))
    if rows["armature"]:
        notes.append("armature (rotor inertia added to M's diagonal by both), MuJoCo / Pinocchio: " + "; ".join(rows["armature"]))
    if rows["friction"]:
        notes.append("dry friction, MuJoCo frictionloss / Pinocchio friction (only MuJoCo applies it): " + "; ".join(rows["friction"]))
    if m.neq:
        eqs = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i) or mujoco.mjtEq(m.eq_type[i]).name[5:].lower()
               for i in range(m.neq)]
        notes.append(f"MuJoCo has {m.neq} equality constraint(s) ({', '.join(eqs)}; a URDF <mimic> becomes one); "
                     "Pinocchio's default URDF import treats a mimic joint as an independent joint")
    return notes


def free_motion(m: mujoco.MjModel, pmodel: pin.Model, jmap: dc.JointMap, q0: np.ndarray, v0: np.ndarray, k: int, *,
                t_end: float, dt: float, save_every: float) -> FreeMotion:
    """Unforced motion under gravity from (q0, v0) (common coordinates) in both engines.

    MuJoCo: RK4 at ``dt``, contacts, constraints (limits, equalities, friction loss) and passive
    forces (damping, springs) disabled, so that both integrate M a + C v + g = 0. Pinocchio:
    ``aba`` with zero torque and ``rkmk4_step`` at ``dt``. A second MuJoCo run with only contacts
    off measures how far limits, equality constraints and damping move the joints
    (``constrained_joint``; informational).
    """
    steps_per_save = max(1, int(round(save_every / dt)))
    n_saves = max(1, int(round(t_end / (steps_per_save * dt))))
    rigid = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
                         | mujoco.mjtDisableBit.mjDSBL_DAMPER | mujoco.mjtDisableBit.mjDSBL_SPRING)
    as_file = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT)
    bodies = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in _moving_bodies(m)]
    frames = [pmodel.getFrameId(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b), pin.FrameType.BODY) for b in bodies]
    d_rigid, d_file = mujoco.MjData(rigid), mujoco.MjData(as_file)
    for dd in (d_rigid, d_file):
        dd.qpos[:], dd.qvel[:] = dc.mujoco_state(m, jmap, q0, v0)
    data = pmodel.createData()
    qp, vp = dc.pinocchio_state(pmodel, jmap, q0, v0)
    tau = np.zeros(pmodel.nv)

    def accel(t, q, v):
        return pin.aba(pmodel, data, q, v, tau).copy()

    worst = {"joint": 0.0, "velocity": 0.0, "position": 0.0, "orientation": 0.0, "constrained": 0.0}
    worst_body = ""
    for i in range(n_saves + 1):
        if i > 0:
            for _ in range(steps_per_save):
                mujoco.mj_step(rigid, d_rigid)
                mujoco.mj_step(as_file, d_file)
                qp, vp = rkmk4_step(pmodel, accel, 0.0, qp, vp, dt)
        mujoco.mj_kinematics(rigid, d_rigid)
        pin.framesForwardKinematics(pmodel, data, qp)
        qc_mj, vc_mj = _common_from_mujoco(jmap, d_rigid.qpos, d_rigid.qvel)
        qc_pin, vc_pin = _common_from_pinocchio(pmodel, jmap, qp, vp)
        worst["joint"] = _worse(worst["joint"], _joint_distance(jmap, qc_mj, qc_pin))
        worst["velocity"] = _worse(worst["velocity"], float(np.max(np.abs(vc_mj - vc_pin), initial=0.0)))
        qc_file, _ = _common_from_mujoco(jmap, d_file.qpos, d_file.qvel)
        worst["constrained"] = _worse(worst["constrained"], _joint_distance(jmap, qc_mj, qc_file))
        for b, fid in zip(bodies, frames):
            oMf = data.oMf[fid]
            dp = float(np.linalg.norm(d_rigid.xpos[b] - oMf.translation))
            finite = np.all(np.isfinite(oMf.rotation)) and np.all(np.isfinite(d_rigid.xquat[b]))
            dq = float(rotations.geodesic_angle(d_rigid.xquat[b], rotations.from_matrix(oMf.rotation))) if finite else float("nan")
            if (dp > worst["position"] or dq > worst["orientation"]
                    or (not np.isfinite(dp + dq) and np.isfinite(worst["position"] + worst["orientation"]))):
                worst_body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b)
            worst["position"], worst["orientation"] = _worse(worst["position"], dp), _worse(worst["orientation"], dq)
    return FreeMotion(k, worst["joint"], worst["velocity"], worst["position"], worst["orientation"], worst_body,
                      worst["constrained"])


def _worse(old: float, new: float) -> float:
    """The larger of two differences, NaN when either is NaN: a motion that went to NaN stays
    NaN and fails its tolerance (``max(old, nan)`` would keep ``old``)."""
    return float(np.maximum(old, new))


def _mujoco_copy(m: mujoco.MjModel, dt: float, disable: int) -> mujoco.MjModel:
    out = copy.deepcopy(m)
    out.opt.timestep = dt
    out.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    out.opt.disableflags = int(out.opt.disableflags) | int(disable)
    return out


def _moving_bodies(m: mujoco.MjModel) -> list[str]:
    return [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody) if m.body_jntnum[b] > 0]


def _common_from_mujoco(jmap: dc.JointMap, qpos: np.ndarray, qvel: np.ndarray):
    q, v = np.zeros(jmap.nq), np.zeros(jmap.nv)
    for s in jmap.slots:
        s.q(q)[:] = qpos[s.mj_q:s.mj_q + s.joint.nq]
        s.v(v)[:] = qvel[s.mj_v:s.mj_v + s.joint.nv]
    return q, v


def _common_from_pinocchio(pmodel: pin.Model, jmap: dc.JointMap, qp: np.ndarray, vp: np.ndarray):
    """Inverse of ``dynamics_terms.pinocchio_state`` (``harness.engines.pinocchio.model.from_pinocchio``)."""
    q, v = np.zeros(jmap.nq), np.zeros(jmap.nv)
    for s in jmap.slots:
        s.q(q)[:], s.v(v)[:] = from_pinocchio(s.joint, qp[s.pin_q:s.pin_q + s.pin_nq],
                                              vp[s.pin_v:s.pin_v + s.joint.nv], pmodel.jointPlacements[s.pin_joint])
    return q, v


def _joint_distance(jmap: dc.JointMap, a: np.ndarray, b: np.ndarray) -> float:
    """Largest per-joint distance (``JointType.distance``): |dq| for hinge (wrapped) and slide,
    geodesic angle for ball, position and geodesic angle for free."""
    return max((s.joint.distance(s.q(a), s.q(b)) for s in jmap.slots), default=0.0)


# --------------------------------------------------------------------------- report


def _v(x, digits=6) -> str:
    return "[" + ", ".join(f"{float(c):.{digits}g}" for c in np.ravel(x)) + "]"


def render_report(res: CheckResult, command: str) -> str:
    """The Markdown report of one check."""
    L = [f"# harness check: {res.name}", "", f"Verdict: **{'PASS' if res.passed else 'FAIL'}**", "",
         f"Command: `{command}`", "",
         f"- Loads: {res.mode}; MuJoCo {mujoco.__version__} from `{res.mujoco_source}`, "
         f"Pinocchio {pin.__version__} from `{res.pinocchio_source}`",
         f"- Base: {res.base}; joints matched by name; common coordinates of `harness.tools.dynamics_terms` "
         "(MuJoCo's: free joint linear velocity in world, angular in the body frame)",
         f"- Settings: {', '.join(f'{k} {v}' for k, v in res.settings.items())}", ""]
    L += ["## Models", "", "Per joint, the rigid body it moves (fixed children merged), in the frame of its child "
          "body/link, at the reference configuration (MuJoCo `qpos0`, Pinocchio `neutral`). Units: kg, m, kg m^2.", "",
          "| joint | body | type | mass (kg) | centre of mass (m) | principal moments (kg m^2) | axis | position in parent (m) |",
          "|---|---|---|---|---|---|---|---|"]
    for x in res.mujoco_bodies:
        L.append(f"| {x.joint} | {x.body} | {x.kind} | {x.mass:.6g} | {_v(x.p_BCm_B)} | {_v(np.linalg.eigvalsh(x.I_Cm_B))} "
                 f"| {_v(x.axis_B, 3)} | {_v(x.p_PB_P)} |")
    if res.gravity is not None:
        L += ["", f"Gravity (m/s^2): MuJoCo {_v(res.gravity[0])}, Pinocchio {_v(res.gravity[1])}."]
    L += ["", "Disagreements between the engines (mass, centre of mass, inertia, placement, axis, gravity):", ""]
    L += [f"- {p}" for p in res.model_problems] or ["- none"]
    L += ["", "Importer differences (informational, not counted):", ""]
    L += [f"- {n}" for n in res.notes] or ["- none"]
    L += ["", "## Engine warnings", ""]
    L += warning_lines(res) or ["- none"]
    L += ["", "## Dynamics terms at random states", "",
          f"{res.settings.get('states')} seeded random states (hinge angles within MuJoCo's limits where limited, rates "
          "~N(0, 1)); M(q), C(q,v)v and g(q) from `mj_fullM`/`qfrc_bias` and `crba`/`nonLinearEffects`/"
          "`computeGeneralizedGravity`, in common coordinates. Relative = max abs difference / largest entry.", "",
          "| sources | term | max abs | max rel | tolerance | verdict |", "|---|---|---|---|---|---|"]
    for d in res.dynamics:
        L.append(f"| {d.a} vs {d.b} | {d.term} | {d.max_abs:.3e} | {d.max_rel:.3e} | {d.rtol:.0e} | {'ok' if d.passed else 'DIFFERS'} |")
    tol = FREE_MOTION_TOL
    L += ["", "## Free motion under gravity", "",
          f"{len(res.free)} random initial states, {res.settings.get('t_end')} s at dt {res.settings.get('dt')} s; MuJoCo RK4 with "
          "contacts, constraints (limits, equalities, friction loss) and passive forces (damping, springs) disabled; "
          "Pinocchio `aba` + `rkmk4_step`. Max over saved samples (every "
          f"{res.settings.get('save_every')} s) of the joint-coordinate difference, joint-velocity difference and every "
          "moving body's world position and orientation (geodesic) difference. Last column: how far MuJoCo's joints move "
          "when limits, equalities and damping are left on (contacts off), against the run without them.", "",
          f"| state | joints (tol {tol['joint']:.0e}) | joint velocities (tol {tol['velocity']:.0e}) | body position m (tol {tol['position']:.0e}) "
          f"| body orientation rad (tol {tol['orientation']:.0e}) | worst body | MuJoCo as the file says vs rigid |",
          "|---|---|---|---|---|---|---|"]
    for r in res.free:
        L.append(f"| {r.state} | {r.joint:.3e} | {r.velocity:.3e} | {r.position:.3e} | {r.orientation:.3e} | {r.worst_body} "
                 f"| {r.constrained_joint:.3e} |")
    return "\n".join(L) + "\n"


def warning_lines(res: CheckResult) -> list[str]:
    """MuJoCo's captured warnings as report lines (none when it gave none)."""
    count = int(res.warnings.get("count", 0) or 0)
    if not count:
        return []
    return [(f"- MuJoCo: {count} warning{'s' if count != 1 else ''} during the dynamics terms and free motions; "
             f"first: {res.warnings.get('first', '')}")]


def summary_lines(res: CheckResult) -> list[str]:
    """What ``harness check`` prints."""
    lines = [f"{res.name}: {'PASS' if res.passed else 'FAIL'} ({res.mode}, {res.base} base)"]
    lines += [f"  MODEL {p}" for p in res.model_problems]
    lines += [f"  warnings {line[2:]}" for line in warning_lines(res)]
    for d in res.dynamics:
        lines.append(f"  dynamics {d.term:<8} {d.a} vs {d.b}: max abs {d.max_abs:.3e}, max rel {d.max_rel:.3e}"
                     + ("" if d.passed else f"  DIFFERS (> {d.rtol:.0e})"))
    for r in res.free:
        lines.append(f"  free motion {r.state}: joints {r.joint:.3e}, velocities {r.velocity:.3e}, "
                     f"body position {r.position:.3e} m, orientation {r.orientation:.3e} rad")
    return lines


def write_report(res: CheckResult, out_dir: Path, command: str) -> Path:
    path = Path(out_dir) / f"check_{res.name}.md"
    atomic.write_text(path, render_report(res, command))
    return path
