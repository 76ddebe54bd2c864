"""``harness check``: read any MJCF/URDF model with three independent importers (MuJoCo,
Pinocchio and Drake), say which agree on what, then write a report.

Loads (``load_models``):

* ``--mjcf`` and ``--urdf``: MuJoCo from the MJCF, Pinocchio and Drake from the URDF;
* ``--urdf`` alone: all three from the URDF (MuJoCo compiles URDF itself);
* ``--mjcf`` alone: all three from the MJCF (``pinocchio.buildModelFromMJCF``, Drake's
  ``Parser(plant).AddModels`` into a continuous ``MultibodyPlant``).

MuJoCo is required: a file it does not load is bad input. Pinocchio and Drake may refuse a file
(a parser error, or a joint the harness cannot compare, such as Pinocchio's planar joint): the
refusal is one line in the result and the report ("Drake: does not load: <reason>") and the
other loaders still compare; when only MuJoCo loads there is nothing to compare (bad input).

The robot is fixed-base (a URDF's root link is welded to the world in all three) unless
``floating_base`` adds a free joint named ``root_joint`` to the root body in all three. Joints are
matched by name (MuJoCo's URDF import keeps the URDF joint names); a free joint Drake names after
its body is matched to MuJoCo's free joint of that body; Pinocchio's composite joint (its MJCF
parser's one joint for a body with several) is split back into the file's joints, in order.
``strip`` deletes geoms and meshes from MuJoCo's copy (mass properties come from the inertials;
meshes need not be found); ``keep_static`` turns off MuJoCo's ``fusestatic``, on by default for URDF.

Then, in order:

* the models (``vote``): per joint and per quantity (``QUANTITIES``: type, mass, centre of mass,
  inertia about it, position and orientation in the parent, axis, joint point, range, damping,
  armature) and for gravity, which loaders agree within the tolerance. Where two agree against
  the third, the third is *the odd one out* and the report names it with both values ("Pinocchio
  is the odd one out: 8.37758 kg where MuJoCo and Drake read 1 kg"). The odd one out reads the
  file differently from the two others: usually the importer that is wrong, but the file decides
  (only MuJoCo honours ``<compiler settotalmass>``, for instance). Importer differences that are
  not compared (fused links, friction loss, mimic joints, what Drake's parser ignores) are notes;
* the dynamics terms at random states (``harness.tools.dynamics_terms``) of every loader whose
  joints are MuJoCo's (same names and types; Drake's roll-pitch-yaw ball joints excluded),
  pair by pair, with the odd one out per term where one pair agrees and two differ;
* free motion under gravity from random states, MuJoCo against Pinocchio (MuJoCo RK4 with
  contacts, constraints and passive forces off; Pinocchio ``aba`` with
  ``lie_group_integrators.rkmk4_step``), comparing joint trajectories and every moving body's
  world pose; not run when Pinocchio does not load the file or its joints are not MuJoCo's.

The report ``check_<model>.md`` is written atomically after everything has loaded. Its verdict
fails on any disagreement between the loaders that read the file (a refusal is reported, not
judged), on a dynamics term or a free motion beyond tolerance.

MuJoCo's warnings while the dynamics terms and the free motions run (e.g. "Nan, Inf or huge value
in QACC ... The simulation is unstable.") are captured into the result (``CheckResult.warnings``,
``harness.engines.mujoco.warning_capture``: count and first message) and shown in the report and
the summary, never printed on stderr; Drake's parser warnings (Python logging) are captured into
the notes.

Bad input (missing or malformed file, missing mesh, a file MuJoCo cannot load, non-positive
mass, an inertia that is not positive definite or violates the triangle inequality, a model that
only MuJoCo loads) raises ``InputError`` naming the file, before anything is written.
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
from harness.io.provenance import drake_version
from harness.tools import dynamics_terms as dc
from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.engines.pinocchio.lie_group_integrators import rkmk4_step
from harness.engines.pinocchio.model import from_pinocchio, root_joint_model
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.joints import FREE, JOINTS, TRANSLATIONAL, by_pinocchio
from harness.tools.loaded_models import (
    DrakeRefusal,
    JointBody,
    JointDetails,
    check_joint_bodies_physical,
    drake_gravity,
    drake_joint_bodies,
    drake_joint_details,
    has_axis,
    load_drake,
    mujoco_joint_bodies,
    mujoco_joint_details,
    pinocchio_joint_bodies,
    pinocchio_joint_details,
    pinocchio_joint_slots,
    pinocchio_split_joint_bodies,
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
            if root is None:
                model = build(str(path))
            elif fmt == "URDF":
                model = build(str(path), root())
            else:  # Pinocchio 4.1's MJCF binding takes a root joint only with its name
                model = build(str(path), root(), "root_joint")
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

LOADERS = ("MuJoCo", "Pinocchio", "Drake")


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
class Reading:
    """One importer's reading of the model.

    Attributes:
        loader: ``MuJoCo``, ``Pinocchio`` or ``Drake``; ``source``: the file it read; ``version``.
        refusal: why it does not load the file (one line), None when it does.
        bodies, details: per joint, the body it moves and the joint's point, range, damping
            and armature (``harness.tools.loaded_models``: ``JointBody``, ``JointDetails``).
        gravity: m/s^2, world.
        model: what it holds (``MjModel``, ``pin.Model``, ``DrakeLoad``).
        slots: Pinocchio only: joint name -> ``PinocchioSlot`` (composite joints split).
        parser: what its parser said while loading (Drake's warnings, one line each).
        dynamics: why its dynamics terms are not compared with MuJoCo's ("" when they are).
        hints: quantity -> a known cause, shown when this loader is the odd one out in it.
    """

    loader: str
    source: Path
    version: str
    refusal: str | None = None
    bodies: list[JointBody] = field(default_factory=list)
    details: list[JointDetails] = field(default_factory=list)
    gravity: np.ndarray | None = None
    model: object = None
    slots: dict = field(default_factory=dict)
    parser: tuple[str, ...] = ()
    dynamics: str = ""
    hints: dict = field(default_factory=dict)

    @property
    def loaded(self) -> bool:
        return self.refusal is None


@dataclass(frozen=True)
class Vote:
    """One quantity of one joint (or, with ``joint == ""``, gravity) across the loaders that read it.

    Attributes:
        joint, body: names (MuJoCo's body name where MuJoCo has the joint).
        quantity: what is compared (``QUANTITIES``, ``present``, ``gravity``).
        values: loader -> its value as text, with the unit.
        groups: the loaders that agree with each other (within the check's tolerance), largest
            group first; one group: all agree.
        hint: a known cause, when the values show it (e.g. a range read as degrees).
        counted: whether a disagreement fails the check (``SETTINGS`` are not counted when
            the loaders read an MJCF and a URDF: a URDF revolute joint must state limits and
            cannot state an armature).
    """

    joint: str
    body: str
    quantity: str
    values: dict[str, str]
    groups: tuple[tuple[str, ...], ...]
    hint: str = ""
    counted: bool = True

    @property
    def agree(self) -> bool:
        return len(self.groups) <= 1

    @property
    def odd(self) -> str | None:
        """The loader the two others agree against (three loaders read it, two agree), else None."""
        if len(self.groups) == 2 and len(self.groups[0]) == 2 and len(self.groups[1]) == 1:
            return self.groups[1][0]
        return None

    @property
    def message(self) -> str:
        who = f"joint {self.joint!r} (body {self.body!r})" if self.joint else "model"
        hint = f" ({self.hint})" if self.hint else ""
        odd = self.odd
        if self.quantity == "present":
            have = [k for k, v in self.values.items() if v == "present"]
            lack = [k for k, v in self.values.items() if v != "present"]
            if odd is not None:
                others = " and ".join(k for k in self.values if k != odd)
                text = (f"{odd} is the odd one out: it has no such joint; {others} have it" if odd in lack
                        else f"{odd} is the odd one out: only it has this joint, {others} do not")
            else:
                text = f"only in {' and '.join(have)}, not in {' and '.join(lack)}"
            return f"{who}: {text}{hint}"
        if odd is not None:
            a, b = self.groups[0]
            return (f"{who}: {self.quantity}: {odd} is the odd one out: {self.values[odd]} where {a} and {b} read "
                    f"{self.values[a]}{hint}")
        parts = ", ".join(f"{v} in {k}" for k, v in self.values.items())
        lead = "all three differ: " if len(self.groups) == 3 else ""
        return f"{who}: {self.quantity}: {lead}{parts}{hint}"


@dataclass
class CheckResult:
    """Everything ``harness check`` found for one model."""

    name: str
    mode: str
    base: str
    readings: dict[str, Reading] = field(default_factory=dict)
    votes: list[Vote] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    dynamics: list[dc.TermDiff] = field(default_factory=list)
    free: list[FreeMotion] = field(default_factory=list)
    free_skipped: str = ""   # why the free motion was not run ("" when it was)
    settings: dict = field(default_factory=dict)
    warnings: dict = field(default_factory=dict)  # MuJoCo's warnings during the comparison: {"count", "first"}

    @property
    def model_problems(self) -> list[str]:
        """The disagreements between the loaders that fail the check, one message each."""
        return [v.message for v in self.votes if not v.agree and v.counted]

    @property
    def setting_differences(self) -> list[str]:
        """Disagreements in joint settings between an MJCF and a URDF (listed, not counted)."""
        return [v.message for v in self.votes if not v.agree and not v.counted]

    @property
    def refusals(self) -> list[str]:
        """``"<loader>: does not load: <reason>"`` for each loader that refused the file."""
        return [f"{r.loader}: does not load: {r.refusal}" for r in self.readings.values() if not r.loaded]

    @property
    def free_passed(self) -> bool:
        tol = FREE_MOTION_TOL
        return all(r.joint <= tol["joint"] and r.velocity <= tol["velocity"] and r.position <= tol["position"]
                   and r.orientation <= tol["orientation"] for r in self.free)  # NaN (a motion gone to NaN) fails

    @property
    def passed(self) -> bool:
        """No disagreement between the loaders that read the file (a refusal is reported, not
        judged), dynamics terms and free motion within tolerance."""
        return not self.model_problems and all(d.passed for d in self.dynamics) and self.free_passed


def _refusal(err: Exception, path: Path) -> str:
    """An InputError's one line without the leading ``<path>: `` (and the loader's name)."""
    text = str(err).removeprefix(f"{path}: ").replace("Pinocchio cannot load", "cannot load", 1)
    native = re.search(r"^(cannot load the \w+: ).*? message: (.*)$", text)  # a C++ exception's location, then its message
    return native.group(1) + native.group(2) if native else text


def _pin_unmappable(slots: dict) -> str | None:
    for name, s in slots.items():
        if by_pinocchio(s.shortname) is None:
            kind = s.shortname.removeprefix("JointModel").lower()
            return (f"joint {name!r} of type {kind} cannot be compared between engines "
                    "(supported: revolute, continuous, prismatic, fixed, and a free root)")
    return None


def _body_joints(m: mujoco.MjModel) -> dict[str, list[str]]:
    """MuJoCo body name -> its joints' names, in order."""
    out: dict[str, list[str]] = {}
    for j in range(m.njnt):
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.jnt_bodyid[j])) or f"body{int(m.jnt_bodyid[j])}"
        out.setdefault(body, []).append(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}")
    return out


def load_models(mjcf: Path | None, urdf: Path | None, *, floating_base: bool = False, strip: bool = False,
                keep_static: bool = False) -> tuple[dict[str, Reading], str, list[str]]:
    """Every loader's reading of the file(s) per the module docstring; returns (readings by
    loader name, mode, notes on loading). Raises InputError for bad input: no file, a missing
    or malformed file, a file MuJoCo does not load, a non-physical body (non-positive mass,
    invalid inertia), a model without a moving joint, or a model only MuJoCo loads."""
    if mjcf is None and urdf is None:
        raise InputError("check needs --mjcf MODEL.xml, --urdf MODEL.urdf, or both")
    mj_file = Path(mjcf) if mjcf is not None else Path(urdf)
    other_file = Path(urdf) if urdf is not None else Path(mjcf)
    for path in {mj_file, other_file}:
        _require_file(path)
    mode = {(True, True): "MJCF -> MuJoCo, URDF -> Pinocchio and Drake",
            (False, True): "URDF -> MuJoCo, Pinocchio and Drake",
            (True, False): "MJCF -> MuJoCo, Pinocchio and Drake"}[(mjcf is not None, urdf is not None)]
    root = FREE.name if floating_base else "none"
    # Parse and check the file-level inertials first, so that every bad value gets the same message.
    for path in {mj_file, other_file}:
        spec = read_mujoco_spec(path)
        add_root_joint(spec, root, path)
        check_spec_inertials(spec, path)
    pinr = Reading("Pinocchio", other_file, pin.__version__)
    pin_bad = None
    try:
        pmodel = load_pinocchio(other_file, root_joint=root)
    except InputError as err:
        pinr.refusal = _refusal(err, other_file)
    else:
        pinr.model = pmodel
        try:  # judged again once MuJoCo has loaded: a body Pinocchio alone reads as massless is its misreading
            check_joint_bodies_physical(pinocchio_joint_bodies(pmodel), str(other_file))
        except InputError as err:
            pin_bad = err
    try:
        m, notes = load_mujoco(mj_file, root_joint=root, strip=strip, keep_static=keep_static)
    except InputError:
        if pin_bad is not None:
            raise pin_bad from None
        raise
    bodies = mujoco_joint_bodies(m, _zero_qpos(m))  # masses and inertias do not depend on the configuration
    last = {}  # a MuJoCo body with several joints carries its mass at the last one
    for x in bodies:
        last[x.body] = x
    check_joint_bodies_physical(list(last.values()), str(mj_file))
    if m.nv == 0:
        raise InputError(f"{mj_file}: the model has no moving joint, nothing to compare "
                         f"(a URDF's root link is fixed unless --floating-base)")
    mjr = Reading("MuJoCo", mj_file, mujoco.__version__, bodies=bodies,
                  details=mujoco_joint_details(m), gravity=mujoco_gravity(m), model=m, hints=_mujoco_hints(m, mj_file))
    if pin_bad is not None:  # MuJoCo reads the bodies as physical: Pinocchio's reading is what differs
        pinr.dynamics = f"its reading of a body is not physical ({_refusal(pin_bad, other_file)})"
    if pinr.loaded:
        pinr.slots = pinocchio_joint_slots(pinr.model, _body_joints(m))
        why = _pin_unmappable(pinr.slots)
        if why is not None:
            pinr.refusal, pinr.model, pinr.slots = why, None, {}
        else:
            pinr.bodies = pinocchio_split_joint_bodies(pinr.model, pinr.slots)
            pinr.details = pinocchio_joint_details(pinr.model, pinr.slots)
            pinr.gravity = np.array(pinr.model.gravity.linear, dtype=float)
    drr = Reading("Drake", other_file, drake_version())
    try:
        with captured_native_stderr():
            load = load_drake(other_file, root_joint=root)
    except DrakeRefusal as err:
        drr.refusal = str(err)
    else:
        drr.model, drr.parser = load, load.warnings
        drr.bodies, drr.details, drr.gravity = drake_joint_bodies(load), drake_joint_details(load), drake_gravity(load)
        notes += [f"Drake: {n}" for n in load.notes]
    readings = {r.loader: r for r in (mjr, pinr, drr)}
    if not pinr.loaded and not drr.loaded:
        raise InputError(f"{other_file}: only MuJoCo loads the model, nothing to compare it with: "
                         + "; ".join(f"{r.loader}: {r.refusal}" for r in (pinr, drr)))
    notes += _match_free_joints(readings)
    return readings, mode, notes


def mujoco_gravity(m: mujoco.MjModel) -> np.ndarray:
    """The gravity MuJoCo applies (m/s^2, world): ``opt.gravity``, or zero when the file turns it
    off (``<option><flag gravity="disable"/>``)."""
    if int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        return np.zeros(3)
    return np.array(m.opt.gravity, dtype=float)


def _mujoco_hints(m: mujoco.MjModel, path: Path) -> dict[str, str]:
    """What MuJoCo alone honours in the file, by the quantity it changes: the compiler's mass
    adjustments (``settotalmass``, ``boundmass``, ``boundinertia``, ``balanceinertia``) and a
    disabled gravity."""
    hints = {}
    compiler = read_mujoco_spec(path).compiler
    adjust = [f'{key}="{value:g}"' for key, value in (("settotalmass", compiler.settotalmass),
                                                       ("boundmass", compiler.boundmass),
                                                       ("boundinertia", compiler.boundinertia)) if value > 0]
    adjust += ['balanceinertia="true"'] if compiler.balanceinertia else []
    if adjust:
        text = f"only MuJoCo applies <compiler {' '.join(adjust)}>"
        hints.update({"mass": text, "inertia about the centre of mass": text, "centre of mass": text})
    if int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        hints["gravity"] = 'only MuJoCo honours <option><flag gravity="disable"/>'
    return hints


def _zero_qpos(m: mujoco.MjModel) -> np.ndarray:
    """MuJoCo's ``qpos0`` with every hinge and slide at 0 (``qpos0`` holds a joint's ``ref``): the
    loaders are compared at equal joint coordinates, where Pinocchio stands at ``neutral`` and
    Drake is put by ``drake_joint_bodies``."""
    q = np.array(m.qpos0, dtype=float)
    for j in range(m.njnt):
        if has_axis(mujoco_joint_kind(m, j)):
            q[m.jnt_qposadr[j]] = 0.0
    return q


def _match_free_joints(readings: dict[str, Reading]) -> list[str]:
    """Give a loader's free joint MuJoCo's name for the same body's free joint (Drake names a
    free joint after its body: its MJCF parser drops ``<freejoint name=...>``, and ``Finalize``
    floats the body under the body's name); returns a note per renamed joint."""
    from dataclasses import replace

    mj = readings["MuJoCo"]
    mj_free = {x.body: x.joint for x in mj.bodies if x.kind == FREE.name}
    mj_names = {x.joint for x in mj.bodies}
    notes = []
    for r in readings.values():
        if r.loader == "MuJoCo" or not r.loaded:
            continue
        renames = {x.joint: mj_free[x.body] for x in r.bodies
                   if x.kind == FREE.name and x.joint not in mj_names and x.body in mj_free}
        if not renames:
            continue
        r.bodies = [replace(x, joint=renames.get(x.joint, x.joint)) for x in r.bodies]
        r.details = [replace(x, joint=renames.get(x.joint, x.joint)) for x in r.details]
        if r.slots:
            r.slots = {renames.get(k, k): s for k, s in r.slots.items()}
        notes.append(f"{r.loader} names the free joint of " + ", ".join(
            f"body {mj.bodies[[x.joint for x in mj.bodies].index(new)].body!r} {old!r} (MuJoCo: {new!r})"
            for old, new in renames.items()) + "; matched to MuJoCo's by body")
    return notes


# --------------------------------------------------------------------------- which loaders agree


def _length(x: JointBody, y: JointBody) -> float:
    """Length scale of a joint's body (m): its centre of mass and placement, at least 1 mm."""
    return max(np.linalg.norm(x.p_BCm_B), np.linalg.norm(x.p_PB_P), np.linalg.norm(y.p_BCm_B),
               np.linalg.norm(y.p_PB_P), 1e-3)


def _fmt(x, unit: str = "", digits: int = 6) -> str:
    if x is None:
        return "none"
    a = np.asarray(x, dtype=float)
    if a.ndim and np.all(np.isfinite(a)):  # round-off beside the largest entry shown as 0
        a = np.where(np.abs(a) < 1e-12 * max(float(np.abs(a).max()), 1e-300), 0.0, a)
    if a.ndim == 0:
        text = f"{float(a):.{digits}g}"
    elif a.ndim == 1:
        text = "[" + ", ".join(f"{float(c):.{digits}g}" for c in a) + "]"
    else:
        text = "[" + ", ".join("[" + ", ".join(f"{float(c):.{digits}g}" for c in row) + "]" for row in a) + "]"
    return f"{text} {unit}".strip()


def _rotvec(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def _point_gap(x: JointBody, y: JointBody, dx: JointDetails, dy: JointDetails) -> float:
    """Distance between two joint points (m): for a hinge, across the axis only (a point moved
    along the axis is the same hinge); for a ball, the full distance."""
    d = dx.point_B - dy.point_B
    if JOINTS[x.kind].axis is not None:
        d = d - (d @ x.axis_B) * x.axis_B
    return float(np.linalg.norm(d))


def _has_point(kind: str) -> bool:
    """A hinge or a ball: a joint whose point matters (not a slide, not free; an engine's own kind neither)."""
    jt = JOINTS.get(kind)
    return jt is not None and jt.constrained and jt.axis != TRANSLATIONAL


def _limits_close(a, b, rtol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return all(abs(p - q) <= rtol * max(1.0, abs(p), abs(q)) for p, q in zip(a, b))


def _range_text(lim, kind: str) -> str:
    if lim is None:
        return "unlimited"
    unit = "m" if JOINTS.get(kind) is not None and JOINTS[kind].axis == TRANSLATIONAL else "rad"
    return f"[{lim[0]:.6g}, {lim[1]:.6g}] {unit}"


def _degrees_hint(odd, majority) -> str:
    """A hint when the odd range is the majority's times pi/180 (read as degrees) or 180/pi."""
    if odd is None or majority is None or not any(majority):
        return ""
    for factor, text in ((np.pi / 180.0, "its range is the others' x pi/180: the file's numbers read as degrees"),
                         (180.0 / np.pi, "its range is the others' x 180/pi: the file's numbers read as radians")):
        if np.allclose(np.array(odd), factor * np.array(majority), rtol=1e-9, atol=0.0):
            return text
    return ""


# quantity -> (applies to the joint (body record), same (x, y, details x, details y, rtol), text)
QUANTITIES = {
    "type": (lambda x: True, lambda x, y, dx, dy, r: x.kind == y.kind, lambda x, d: x.kind),
    "mass": (lambda x: True, lambda x, y, dx, dy, r: bool(np.isclose(x.mass, y.mass, rtol=r, atol=1e-12)),
             lambda x, d: _fmt(x.mass, "kg")),
    "centre of mass": (lambda x: True,
                       lambda x, y, dx, dy, r: np.linalg.norm(x.p_BCm_B - y.p_BCm_B) <= r * _length(x, y),
                       lambda x, d: _fmt(x.p_BCm_B, "m")),
    "inertia about the centre of mass": (
        lambda x: True,
        lambda x, y, dx, dy, r: np.abs(x.I_Cm_B - y.I_Cm_B).max() <= r * max(np.abs(x.I_Cm_B).max(), np.abs(y.I_Cm_B).max(), 1e-300),
        lambda x, d: _fmt(x.I_Cm_B, "kg m^2")),
    "position in parent": (lambda x: JOINTS.get(x.kind) is None or JOINTS[x.kind].constrained,
                           lambda x, y, dx, dy, r: np.linalg.norm(x.p_PB_P - y.p_PB_P) <= r * _length(x, y),
                           lambda x, d: _fmt(x.p_PB_P, "m")),
    "orientation in parent": (lambda x: JOINTS.get(x.kind) is None or JOINTS[x.kind].constrained,
                              lambda x, y, dx, dy, r: np.abs(x.R_PB - y.R_PB).max() <= max(r, 1e-12),
                              lambda x, d: "rotation vector " + _fmt(_rotvec(x.R_PB), "rad")),
    "axis": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
             lambda x, y, dx, dy, r: np.linalg.norm(x.axis_B - y.axis_B) <= max(r, 1e-12),
             lambda x, d: _fmt(x.axis_B)),
    "joint point": (lambda x: _has_point(x.kind),
                    lambda x, y, dx, dy, r: _point_gap(x, y, dx, dy) <= r * _length(x, y),
                    lambda x, d: _fmt(d.point_B, "m")),
    "range": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
              lambda x, y, dx, dy, r: _limits_close(dx.limits, dy.limits, r),
              lambda x, d: _range_text(d.limits, x.kind)),
    "damping": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                lambda x, y, dx, dy, r: bool(np.isclose(dx.damping, dy.damping, rtol=r, atol=1e-12)),
                lambda x, d: _fmt(d.damping)),
    "armature": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                 lambda x, y, dx, dy, r: bool(np.isclose(dx.armature, dy.armature, rtol=r, atol=1e-12)),
                 lambda x, d: _fmt(d.armature)),
}
# a quantity a loader does not hold for a joint (None in its JointDetails) is not voted on
_DETAIL_FIELD = {"joint point": "point_B", "range": None, "damping": "damping", "armature": "armature"}
# joint settings: counted when every loader reads one file, listed only between an MJCF and a URDF
SETTINGS = ("range", "damping", "armature")


def _groups(labels: list[str], same) -> tuple[tuple[str, ...], ...]:
    """Loaders that agree, as connected groups of ``same``, largest first (ties in loader order)."""
    groups: list[list[str]] = []
    for a in labels:
        joined = [g for g in groups if any(same(a, b) for b in g)]
        merged = [a] + [b for g in joined for b in g]
        groups = [g for g in groups if g not in joined] + [sorted(merged, key=labels.index)]
    groups.sort(key=lambda g: (-len(g), labels.index(g[0])))
    return tuple(tuple(g) for g in groups)


def vote(readings: dict[str, Reading], rtol: float) -> list[Vote]:
    """Per joint (MuJoCo's order, then joints only other loaders have) and per quantity
    (``QUANTITIES``, in order), which of the loaders that read the file agree; then gravity.
    ``SETTINGS`` votes are not counted when the loaders read different files."""
    loaded = [r for r in readings.values() if r.loaded]
    one_file = len({r.source for r in loaded}) == 1
    labels = [r.loader for r in loaded]
    bodies = {r.loader: {x.joint: x for x in r.bodies} for r in loaded}
    details = {r.loader: {x.joint: x for x in r.details} for r in loaded}
    names: list[str] = []
    for r in loaded:
        names += [x.joint for x in r.bodies if x.joint not in names]
    out = []
    for name in names:
        have = [k for k in labels if name in bodies[k]]
        body = bodies[have[0]][name].body
        if len(have) < len(labels):
            values = {k: "present" if k in have else "absent" for k in labels}
            out.append(Vote(name, body, "present", values, _groups(labels, lambda a, b, vals=values: vals[a] == vals[b])))
        for quantity, (applies, same, text) in QUANTITIES.items():
            who = [k for k in have if applies(bodies[k][name])]
            if quantity in _DETAIL_FIELD:  # a loader without the detail (None) does not vote on it
                field_name = _DETAIL_FIELD[quantity]
                who = [k for k in who if name in details[k]
                       and (field_name is None or getattr(details[k][name], field_name) is not None)]
            if len(who) < 2:
                continue
            x = {k: bodies[k][name] for k in who}
            d = {k: details[k].get(name) for k in who}
            groups = _groups(who, lambda a, b, x=x, d=d, same=same: bool(same(x[a], x[b], d[a], d[b], rtol)))
            values = {k: text(x[k], d[k]) for k in who}
            counted = one_file or quantity not in SETTINGS
            v = Vote(name, body, quantity, values, groups, counted=counted)
            hint = readings[v.odd].hints.get(quantity, "") if v.odd is not None else ""
            if quantity == "range" and v.odd is not None:
                hint = _degrees_hint(d[v.odd].limits, d[groups[0][0]].limits) or hint
            out.append(Vote(name, body, quantity, values, groups, hint, counted) if hint else v)
    g = {r.loader: r.gravity for r in loaded if r.gravity is not None}
    if len(g) >= 2:
        groups = _groups(list(g), lambda a, b: np.linalg.norm(g[a] - g[b]) <= rtol * max(np.linalg.norm(g[a]), 1.0))
        v = Vote("", "", "gravity", {k: _fmt(val, "m/s^2") for k, val in g.items()}, groups)
        hint = readings[v.odd].hints.get("gravity", "") if v.odd is not None else ""
        if v.odd == "Pinocchio" and file_format(readings["Pinocchio"].source) == "MJCF":
            hint = "Pinocchio's MJCF parser ignores <option gravity>"
        elif not hint and not v.agree and file_format(readings["Pinocchio"].source) == "URDF":
            hint = "a URDF cannot state gravity: each loader's default"
        out.append(Vote("", "", "gravity", v.values, groups, hint))
    return out


def dynamics_odd(diffs: list[dc.TermDiff]) -> dict[str, str]:
    """Term -> the source the two others agree against (three sources: exactly one pair agrees)."""
    out = {}
    for term in dc.TERMS:
        rows = [d for d in diffs if d.term == term]
        sources = {s for d in rows for s in (d.a, d.b)}
        ok = [d for d in rows if d.passed]
        if len(sources) == 3 and len(rows) == 3 and len(ok) == 1:
            (odd,) = sources - {ok[0].a, ok[0].b}
            out[term] = odd
    return out


# --------------------------------------------------------------------------- dynamics: joints of each loader


def _pinocchio_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Pinocchio coordinates for ``dynamics_terms.joint_map``; None (with
    ``r.dynamics`` saying why) when Pinocchio's joints are not MuJoCo's or its bodies are not
    physical."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = r.dynamics or _joint_set_problem(mjr, kinds)
    if why:
        r.dynamics = why
        return None
    return {name: {"pin_q": s.idx_q, "pin_v": s.idx_v, "pin_joint": s.jid, "pin_nq": s.nq} for name, s in r.slots.items()}


def _drake_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Drake coordinates (``position_start``, ``velocity_start``); None (with
    ``r.dynamics`` saying why) when Drake's moving joints are not MuJoCo's, or are of a kind
    whose Drake coordinates are not mapped (Drake's ball joint has roll-pitch-yaw angles)."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = _joint_set_problem(mjr, kinds)
    balls = [n for n, k in kinds.items() if JOINTS.get(k) is not None and JOINTS[k].quat_at is not None
             and not JOINTS[k].world_linear_velocity]
    if not why and balls:
        why = f"Drake's ball joints ({', '.join(balls)}) have roll-pitch-yaw coordinates, not mapped to quaternions"
    if why:
        r.dynamics = why
        return None
    plant = r.model.plant
    moving = [plant.get_joint(j) for j in plant.GetJointIndices() if plant.get_joint(j).type_name() != "weld"]
    # drake_joint_bodies keeps Drake's joint order; a free joint may carry MuJoCo's name (_match_free_joints)
    return {x.joint: {"drake_q": int(j.position_start()), "drake_v": int(j.velocity_start())}
            for x, j in zip(r.bodies, moving)}


def _joint_set_problem(mjr: Reading, kinds: dict[str, str]) -> str:
    """Why a loader's joints (name -> kind) cannot be put into MuJoCo's coordinates ("" when they can)."""
    mj = {x.joint: x.kind for x in mjr.bodies}
    missing, extra = [n for n in mj if n not in kinds], [n for n in kinds if n not in mj]
    if missing or extra:
        return "its joints are not MuJoCo's (" + "; ".join(
            ([f"no {', '.join(missing)}"] if missing else []) + ([f"{', '.join(extra)} not in MuJoCo"] if extra else [])) + ")"
    other = [f"{n} is {kinds[n]}, MuJoCo's {k}" for n, k in mj.items() if kinds[n] != k]
    return f"its joint types differ from MuJoCo's ({'; '.join(other)})" if other else ""


def run_check(mjcf: Path | None, urdf: Path | None, *, seed: int = 0, n_states: int = dc.DEFAULT_STATES,
              n_free: int = 3, t_end: float = 0.5, dt: float = 1e-3, save_every: float = 0.01,
              floating_base: bool = False, strip: bool = False, keep_static: bool = False) -> CheckResult:
    """Load, compare models, dynamics terms and free motion (see module docstring)."""
    for label, value in (("--t-end", t_end), ("--dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{label} must be positive and finite, got {value!r}")
    if n_states < 1 or n_free < 0:
        raise InputError("--states must be >= 1 and --free-runs >= 0")
    readings, mode, notes = load_models(mjcf, urdf, floating_base=floating_base, strip=strip, keep_static=keep_static)
    name = Path(urdf if urdf is not None else mjcf).stem
    res = CheckResult(name, mode, "floating (free root joint 'root_joint')" if floating_base else "fixed", readings)
    res.notes += notes
    mjr, pinr, drr = (readings[k] for k in LOADERS)
    m = mjr.model
    rtol = SAME_FILE_RTOL if len({r.source for r in readings.values() if r.loaded}) == 1 else TWO_FILES_RTOL
    res.votes = vote(readings, rtol)
    res.notes += importer_notes(readings)
    pin_table = _pinocchio_table(mjr, pinr) if pinr.loaded else None
    drake_table = _drake_table(mjr, drr) if drr.loaded else None
    jmap = dc.joint_map(m, pin_table, drake_table)
    states = dc.random_states(jmap, n_states, seed)
    res.settings = {"seed": seed, "states": n_states, "free_runs": n_free, "t_end": t_end, "dt": dt,
                    "save_every": save_every, "rtol_model": rtol, "rtol_dynamics": max(dc.DEFAULT_RTOL, rtol)}
    d = mujoco.MjData(m)
    sources = {"MuJoCo": lambda q, v: dc.mujoco_terms(m, jmap, q, v, d)}
    if pin_table is not None:
        pmodel, data = pinr.model, pinr.model.createData()
        sources["Pinocchio"] = lambda q, v: dc.pinocchio_terms(pmodel, jmap, q, v, data)
    if drake_table is not None:
        plant = drr.model.plant
        context = plant.CreateDefaultContext()
        sources["Drake"] = lambda q, v: dc.drake_terms(plant, jmap, q, v, context)
    with captured_warnings() as caught:  # MuJoCo's warnings go into the result, not onto stderr
        try:
            if len(sources) >= 2:
                terms = dc.evaluate(sources, states)
                res.dynamics = dc.compare_terms(terms, rtol=max(dc.DEFAULT_RTOL, rtol))
            if pin_table is None:
                res.free_skipped = ("Pinocchio does not load the file" if not pinr.loaded
                                    else f"Pinocchio's dynamics are not compared ({pinr.dynamics})")
                res.free_skipped += "; the free motion compares MuJoCo with Pinocchio only"
            else:
                for k, (q, v) in enumerate(dc.random_states(jmap, n_free, seed + 1)):
                    res.free.append(free_motion(m, pinr.model, jmap, q, v, k, t_end=t_end, dt=dt, save_every=save_every))
        finally:
            res.warnings = caught.stats()
    return res


def importer_notes(readings: dict[str, Reading]) -> list[str]:
    """What the importers do differently beyond the compared quantities (not counted as failures)."""
    mjr, pinr, drr = (readings[k] for k in LOADERS)
    m, mj_file = mjr.model, mjr.source
    notes = []
    if pinr.loaded:
        pmodel = pinr.model
        mj_bodies = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)}
        pin_links = [f.name for f in pmodel.frames if f.type == pin.FrameType.BODY]
        fused = [n for n in pin_links if n not in mj_bodies]
        if fused and file_format(mj_file) == "URDF":
            notes.append(f"MuJoCo fused {len(fused)} link(s) without a moving joint into their parent body (fusestatic; "
                         f"their mass is merged, as Pinocchio and Drake merge it into the parent joint's body): "
                         f"{', '.join(fused)}")
            massless = [b.name for b in read_mujoco_spec(mj_file).bodies if b.name in fused and b.explicitinertial
                        and b.mass == 0.0 and (np.any(np.asarray(b.inertia) != 0)
                                               or np.any(np.nan_to_num(np.asarray(b.fullinertia, dtype=float)) != 0))]
            if massless:
                notes.append(f"link(s) with mass 0 but a non-zero rotational inertia: {', '.join(massless)}. MuJoCo's "
                             "fusestatic drops that inertia when it merges the link into its parent; Pinocchio adds it "
                             "to the parent joint's inertia (with --keep-static-links MuJoCo keeps it)")
        composites = sorted({pmodel.names[s.jid] for s in pinr.slots.values() if s.sub >= 0})
        if composites:
            notes.append(f"Pinocchio's MJCF parser made the joints of {len(composites)} body(ies) with several joints one "
                         f"composite joint each ({', '.join(composites)}); compared here split back into the file's "
                         "joints, in order")
        friction = []
        for x in mjr.bodies:
            s = pinr.slots.get(x.joint)
            if s is None or JOINTS[x.kind].axis is None:
                continue
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, x.joint)
            mj_val, pin_val = m.dof_frictionloss[m.jnt_dofadr[j]], pmodel.friction[s.idx_v]
            if mj_val != 0.0 or pin_val != 0.0:
                friction.append(f"{x.joint} {mj_val:g} / {pin_val:g}")
        if friction:
            notes.append("dry friction, MuJoCo frictionloss / Pinocchio friction (only MuJoCo applies it; Drake's "
                         "parsers do not read it): " + "; ".join(friction))
    if file_format(mj_file) == "URDF":
        notes.append(f"MuJoCo's URDF import: options not in URDF take MuJoCo's defaults (timestep {m.opt.timestep:g} s, "
                     f"integrator {mujoco.mjtIntegrator(m.opt.integrator).name[6:]}, gravity {np.round(m.opt.gravity, 6).tolist()} "
                     "m/s^2); visual geometry is discarded (discardvisual), collision geometry kept")
    limited = [(x, d) for x, d in zip(mjr.bodies, mjr.details) if d.limits is not None]
    if limited:
        notes.append("joint limits (MuJoCo enforces them as constraints; Pinocchio stores them, aba ignores them; "
                     "Drake stores them): " + "; ".join(f"{x.joint} {_range_text(d.limits, x.kind)}" for x, d in limited)
                     + " (compared as `range`)")
    damped = [(x, d) for x, d in zip(mjr.bodies, mjr.details) if d.damping]
    if damped:
        notes.append("joint damping (MuJoCo and Drake apply it as a passive force; Pinocchio's aba ignores it; "
                     "not in the dynamics terms below): " + "; ".join(f"{x.joint} {d.damping:g}" for x, d in damped)
                     + " (compared as `damping`)")
    if m.neq:
        eqs = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i) or mujoco.mjtEq(m.eq_type[i]).name[5:].lower()
               for i in range(m.neq)]
        notes.append(f"MuJoCo has {m.neq} equality constraint(s) ({', '.join(eqs)}; a URDF <mimic> becomes one); "
                     "Pinocchio's default URDF import treats a mimic joint as an independent joint")
    if drr.loaded and drr.parser:
        counts: dict[str, list[str]] = {}
        for line in drr.parser:
            match = re.match(r"line (\d+): (?:warning: )?(.*)", line)
            where, text = (match.group(1), match.group(2)) if match else ("?", line)
            text = re.sub(r"\b(geom|body|joint|motor|mesh|site|material) \S+ (specified|has|uses|does)", r"\1 <name> \2", text)
            counts.setdefault(text, []).append(where)
        notes.append(f"Drake's parser warned {len(drr.parser)} time(s) (what it ignores): " + "; ".join(
            f"{text} (x{len(lines)})" for text, lines in counts.items()))
    for r in readings.values():
        if r.loaded and r.dynamics:
            notes.append(f"{r.loader}'s dynamics terms are not compared: {r.dynamics}")
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


def verdict(res: CheckResult) -> str:
    """Why the check passes or fails, in one line: the odd one out per loader (the model quantities and
    dynamics terms where the two others agree against it), disagreements without a majority,
    failed dynamics or free motion, and the loaders that do not load the file."""
    parts = []
    odd: dict[str, list[str]] = {}
    for v in res.votes:
        if v.odd is not None and v.counted:
            what = v.quantity
            if what == "present":
                what = "joint missing" if v.values[v.odd] != "present" else "extra joint"
            odd.setdefault(v.odd, []).append(what)
    dyn_odd = dynamics_odd(res.dynamics)
    for term, loader in dyn_odd.items():
        odd.setdefault(loader, []).append(f"dynamics {term}")
    for loader in LOADERS:
        if loader in odd:
            counts: dict[str, int] = {}
            for q in odd[loader]:
                counts[q] = counts.get(q, 0) + 1
            parts.append(f"{loader} is the odd one out: " + ", ".join(f"{q}" + (f" x{n}" if n > 1 else "")
                                                                       for q, n in counts.items()))
    split = [v for v in res.votes if not v.agree and v.odd is None and v.counted]
    if split:
        parts.append(f"{len(split)} disagreement(s) without a majority")
    bad_terms = sorted({d.term for d in res.dynamics if not d.passed and d.term not in dyn_odd})
    if bad_terms:
        parts.append(f"dynamics {', '.join(bad_terms)} differ")
    if not res.free_passed:
        parts.append("free motion differs (MuJoCo vs Pinocchio)")
    if not parts and res.passed:
        loaded = [r.loader for r in res.readings.values() if r.loaded]
        parts.append(f"{', '.join(loaded[:-1])} and {loaded[-1]} agree")
    if res.setting_differences:
        parts.append(f"{len(res.setting_differences)} joint setting(s) differ between the MJCF and the URDF (listed, "
                     "not counted)")
    parts += res.refusals
    return "; ".join(parts)


_CELL_QUANTITIES = tuple(QUANTITIES)


def _vote_cell(v: Vote | None, n_loaded: int = 3) -> str:
    if v is None:
        return ""
    if v.agree:
        return "=" if len(v.values) == n_loaded else "= (" + ", ".join(v.values) + ")"
    if v.odd is not None:
        return f"**{v.odd}**"
    return "**differ**"


def render_report(res: CheckResult, command: str) -> str:
    """The Markdown report of one check."""
    mjr = res.readings["MuJoCo"]
    loads = []
    for source in dict.fromkeys(r.source for r in res.readings.values()):
        readers = [r for r in res.readings.values() if r.source == source]
        ok = [f"{r.loader} {r.version}" for r in readers if r.loaded]
        if ok:
            loads.append(f"{', '.join(ok)} from `{source}`")
        loads += [f"{r.loader} {r.version} **does not load** `{source}`: {r.refusal}" for r in readers if not r.loaded]
    L = [f"# harness check: {res.name}", "", f"Verdict: **{'PASS' if res.passed else 'FAIL'}**: {verdict(res)}", "",
         f"Command: `{command}`", "",
         f"- Loads: {res.mode}; " + "; ".join(loads),
         f"- Base: {res.base}; joints matched by name; common coordinates of `harness.tools.dynamics_terms` "
         "(MuJoCo's: free joint linear velocity in world, angular in the body frame)",
         f"- Settings: {', '.join(f'{k} {v}' for k, v in res.settings.items())}", ""]
    L += ["## Models", "", "MuJoCo's reading, per joint: the rigid body it moves (fixed children merged), in the frame "
          "of its child body/link, at zero joint coordinates (every hinge and slide at 0, whatever its `ref`; free and "
          "ball joints as the file places them; Pinocchio at `neutral`). Units: kg, m, kg m^2. A body with several "
          "joints carries its mass at its last joint.", "",
          "| joint | body | type | mass (kg) | centre of mass (m) | principal moments (kg m^2) | axis | position in parent (m) |",
          "|---|---|---|---|---|---|---|---|"]
    for x in mjr.bodies:
        L.append(f"| {x.joint} | {x.body} | {x.kind} | {x.mass:.6g} | {_v(x.p_BCm_B)} | {_v(np.linalg.eigvalsh(x.I_Cm_B))} "
                 f"| {_v(x.axis_B, 3)} | {_v(x.p_PB_P)} |")
    loaded = [r.loader for r in res.readings.values() if r.loaded]
    L += ["", "### Which loaders agree", "",
          f"Per joint and quantity, among the loaders that read the file ({', '.join(loaded)}): `=` all agree (with the "
          "loaders in brackets when not all of them read it); a loader's name in bold: **the odd one out**, the one the two "
          "others agree against; **differ**: no majority; empty: the quantity does not apply (e.g. no axis on a free "
          f"joint). Tolerance: relative {res.settings.get('rtol_model')} (lengths against the body's size, at least "
          "1 mm). The odd one out reads the file differently from the two others: usually the importer that is wrong, "
          "but the file decides (e.g. only MuJoCo honours `<compiler settotalmass>`).", "",
          "| joint | body | present | " + " | ".join(_CELL_QUANTITIES) + " |",
          "|---|---|---|" + "---|" * len(_CELL_QUANTITIES)]
    by_joint: dict[str, dict[str, Vote]] = {}
    for v in res.votes:
        by_joint.setdefault(v.joint, {})[v.quantity] = v
    for joint, votes in by_joint.items():
        if not joint:
            continue
        body = next(iter(votes.values())).body
        L.append(f"| {joint} | {body} | {_vote_cell(votes.get('present'), len(loaded)) or '='} | "
                 + " | ".join(_vote_cell(votes.get(q), len(loaded)) for q in _CELL_QUANTITIES) + " |")
    g = by_joint.get("", {}).get("gravity")
    if g is not None:
        L += ["", "Gravity: " + ", ".join(f"{k} {val}" for k, val in g.values.items()) + f": {_vote_cell(g, len(loaded))}."]
    L += ["", "Disagreements between the loaders (the odd one out named where two agree against one):", ""]
    L += [f"- {p}" for p in res.model_problems] or ["- none"]
    if res.setting_differences:
        L += ["", "Joint settings that differ between the MJCF and the URDF (listed, not counted: a URDF revolute joint "
              "must state limits and cannot state an armature):", ""]
        L += [f"- {p}" for p in res.setting_differences]
    L += ["", "Importer differences (informational, not counted):", ""]
    L += [f"- {n}" for n in res.notes] or ["- none"]
    L += ["", "## Engine warnings", ""]
    L += warning_lines(res) or ["- none"]
    sources = sorted({s for d in res.dynamics for s in (d.a, d.b)}, key=LOADERS.index)
    L += ["", "## Dynamics terms at random states", "",
          f"{res.settings.get('states')} seeded random states (hinge angles within MuJoCo's limits where limited, rates "
          "~N(0, 1)); M(q), C(q,v)v and g(q) from MuJoCo `mj_fullM`/`qfrc_bias`, Pinocchio `crba`/`nonLinearEffects`/"
          "`computeGeneralizedGravity`, Drake `CalcMassMatrix`/`CalcBiasTerm`/`CalcGravityGeneralizedForces`, in "
          f"common coordinates; sources compared: {', '.join(sources) or 'none'}. Relative = max abs difference / "
          "largest entry.", ""]
    L += [f"- {r.loader} not compared: {r.dynamics}" for r in res.readings.values() if r.loaded and r.dynamics]
    L += [f"- {r.loader} not compared: it does not load the file" for r in res.readings.values() if not r.loaded]
    if any(not r.loaded or r.dynamics for r in res.readings.values()):
        L.append("")
    L += ["| sources | term | max abs | max rel | tolerance | verdict |", "|---|---|---|---|---|---|"]
    for d in res.dynamics:
        L.append(f"| {d.a} vs {d.b} | {d.term} | {d.max_abs:.3e} | {d.max_rel:.3e} | {d.rtol:.0e} | {'ok' if d.passed else 'DIFFERS'} |")
    odd_terms = dynamics_odd(res.dynamics)
    for loader in LOADERS:
        terms = [t for t, k in odd_terms.items() if k == loader]
        if terms:
            L += ["", f"{loader} is the odd one out in {', '.join(terms)} (the two others agree)."]
    tol = FREE_MOTION_TOL
    L += ["", "## Free motion under gravity", ""]
    if res.free_skipped:
        L += [f"Not run: {res.free_skipped}."]
        return "\n".join(L) + "\n"
    L += [f"{len(res.free)} random initial states, {res.settings.get('t_end')} s at dt {res.settings.get('dt')} s; MuJoCo RK4 with "
          "contacts, constraints (limits, equalities, friction loss) and passive forces (damping, springs) disabled; "
          "Pinocchio `aba` + `rkmk4_step` (Drake is compared by its dynamics terms above, not in free motion). Max over "
          f"saved samples (every {res.settings.get('save_every')} s) of the joint-coordinate difference, joint-velocity "
          "difference and every moving body's world position and orientation (geodesic) difference. Last column: how far "
          "MuJoCo's joints move when limits, equalities and damping are left on (contacts off), against the run without "
          "them.", "",
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
    lines = [f"{res.name}: {'PASS' if res.passed else 'FAIL'} ({res.mode}, {res.base} base)",
             f"  verdict: {verdict(res)}"]
    lines += [f"  MODEL {p}" for p in res.model_problems]
    lines += [f"  setting (not counted) {p}" for p in res.setting_differences]
    lines += [f"  warnings {line[2:]}" for line in warning_lines(res)]
    for d in res.dynamics:
        lines.append(f"  dynamics {d.term:<8} {d.a} vs {d.b}: max abs {d.max_abs:.3e}, max rel {d.max_rel:.3e}"
                     + ("" if d.passed else f"  DIFFERS (> {d.rtol:.0e})"))
    lines += [f"  dynamics {r.loader} not compared: {r.dynamics}" for r in res.readings.values() if r.loaded and r.dynamics]
    for r in res.free:
        lines.append(f"  free motion {r.state}: joints {r.joint:.3e}, velocities {r.velocity:.3e}, "
                     f"body position {r.position:.3e} m, orientation {r.orientation:.3e} rad")
    if res.free_skipped:
        lines.append(f"  free motion not run: {res.free_skipped}")
    return lines


def write_report(res: CheckResult, out_dir: Path, command: str) -> Path:
    path = Path(out_dir) / f"check_{res.name}.md"
    atomic.write_text(path, render_report(res, command))
    return path
