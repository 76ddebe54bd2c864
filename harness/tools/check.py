"""``harness check``: read any MJCF/URDF model with three independent importers (MuJoCo,
Pinocchio and Drake), say which agree on what, check the dynamics with two more engines built
from MuJoCo's reading (the in-house engine and Exudyn), then write a report.

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
matched by name (MuJoCo's URDF import keeps the URDF joint names), or through a joint map
(``joint_map``, ``--joint-map FILE`` / ``--map mjcf=urdf``: the URDF's joints compared under the
MJCF's names, ``apply_joint_map``; a name neither file has is bad input); a free joint Drake names
after its body is matched to MuJoCo's free joint of that body. A body with several joints: MuJoCo
moves it by its joints in order; Pinocchio's composite joint (its MJCF parser's one joint for such
a body) is split back into the file's joints, in order; Drake's chain of massless bodies (one
joint each) is read as the one body. ``keep_static`` turns off MuJoCo's ``fusestatic``, on by
default for URDF.

Each loader reads the file as written unless the comparison needs a copy (section "the copies
the loaders read"; the report lists each change under "What the loaders read differs"):
``strip`` (``--strip-geometry``) removes geoms, meshes, height fields, textures, materials and
skins, and what refers to them, from every loader's copy (an MJCF's copy read by all its loaders,
a URDF's without ``<visual>``/``<collision>`` for Pinocchio and Drake, MuJoCo's reading of a URDF
stripped in its spec); mass properties then come from the ``<inertial>`` elements, and a body
whose mass MuJoCo derives from its geoms keeps it: MuJoCo compiles the file with its geometry
first and MuJoCo's reading (and an MJCF's copy for Pinocchio and Drake) carries those values as
explicit ``<inertial>`` elements, so that stripping does not change MuJoCo's dynamics (an MJCF's
loaders then all read MuJoCo's geom-derived masses; a URDF's Pinocchio and Drake read its
``<inertial>`` elements, as without stripping); where the geometry does not compile (a missing
mesh file) those masses are lost and the note names the bodies. An MJCF read by every loader
gets names for its unnamed bodies and joints (MuJoCo's ``body<k>``/``joint<j>``) and, in a copy,
a model name (Drake's parser needs one); keyframes that no longer fit (a root joint added, or
Pinocchio's reading of another size) are dropped; the check does not use keyframes. Equality
constraints, tendons and actuators are listed as "not compared" (``not_compared``: counts and
names).

Then, in order:

* the models (``vote``): per joint and per quantity (``QUANTITIES``: type, mass, centre of mass,
  inertia about it, position and orientation in the parent, axis, joint point, range, damping,
  friction loss, armature) and for gravity, which loaders agree within the tolerance. Where two
  agree against the third, the third is *the odd one out* and the report names it with both
  values and by how much they differ ("Pinocchio is the odd one out: 8.37758 kg where MuJoCo and
  Drake read 1 kg; they differ by 7.37758 kg (88.1% of 8.37758 kg)"). The odd one out reads the
  file differently from the two others: usually the importer that is wrong, but the file decides
  (only MuJoCo honours ``<compiler settotalmass>``, for instance). The joint settings (range rad
  or m, damping, friction loss, armature) of an MJCF and a URDF are listed, not counted (a URDF
  cannot state an armature); friction loss never counts (only MuJoCo applies it, Drake's parsers
  do not read it). The report's joint-settings table says per joint "same", "differs (by how
  much)" or "only <loader> reads it", and lists each actuator's gear (MuJoCo's ``gear``, Drake's
  gear ratio from a URDF transmission) as not compared. Importer differences that are not
  compared (fused links, masses MuJoCo derives from geoms where the file gives no
  ``<inertial>``, mimic joints, what Drake's parser ignores, Pinocchio's MJCF parser reading only
  the first body under ``<worldbody>``) are notes;
* what the differences come from (``diagnose``, ``Finding``), each named only when putting it
  back reconciles the two readings within the tolerance: a URDF ``<inertial><origin rpy>`` that
  one reading applies and the other does not (mujoco #3559: the difference of the inertias is
  R I0 R^T - I0 of the link's written tensor I0); a fixed child (URDF fixed joint, MJCF body
  without a joint) whose mass properties are missing or different in one reading of the body
  it is merged into (the bodies' ``parts``: with that child's part swapped the readings agree;
  e.g. MuJoCo's ``fusestatic`` dropping a massless link's inertia, an MJCF body without
  ``<inertial>``); an armature only some loaders read, with what it adds to M's diagonal entry
  at zero joint coordinates, and M differing by exactly that diagonal at every state
  (``diagnose_dynamics``); the first of a body's several joints that one reading puts at the
  parent body's origin (Drake's MJCF parser);
* the dynamics terms at random states (``harness.tools.dynamics_terms``) of every loader whose
  joints are MuJoCo's (same names and types; Drake's roll-pitch-yaw ball joints excluded; a
  loader that lacks whole kinematic trees of MuJoCo's is compared on the others, and so is every
  loader then: ``Reading.partial``), pair by pair, with the odd one out per term where one pair
  agrees and two differ;
* free motion under gravity from random states, MuJoCo against Pinocchio (MuJoCo RK4 with
  contacts, constraints, passive forces (gravity compensation and fluid forces included) and
  actuators off; Pinocchio ``aba`` with ``lie_group_integrators.rkmk4_step``), comparing joint
  trajectories and the world pose of every moving body both hold (matched through their joints);
  not run when Pinocchio does not load the file or its joints are not MuJoCo's.

* the in-house engine and Exudyn, two *witnesses of dynamics* (``harness.tools.witnesses``),
  built from MuJoCo's reading (its compiled model read into the harness's ``Multibody`` by
  ``harness.model.from_model_file.read_compiled``, fixed children merged), not from the file:
  they test the dynamics, not a parser, and never vote on the model quantities above (a
  witness would only repeat MuJoCo's reading). What each holds (mass, centre of mass, inertia,
  axis, position in parent per body) is listed against that description in a separate table;
  a difference is a build error and fails the check. The in-house M, bias and gravity (from its
  Newton-Euler accelerations for unit generalized forces) are compared with each loader's at
  the same random states (``Witnesses.dynamics``, the rows ``<loader> vs in-house`` of the
  report's dynamics table, kept out of ``CheckResult.dynamics``); it is named the odd one out in a term when it differs from
  MuJoCo while another loader agrees with MuJoCo (``witness_odd``); the loaders' own odd one out
  is decided among the loaders alone (``dynamics_odd``). Both run free motion from the same
  random states as Pinocchio, compared with MuJoCo's rigid run on every moving body's world
  pose and velocity (in-house at the check's tolerances; Exudyn, order 2, with its own). A
  model the description cannot hold (a body with several joints, equality constraints) leaves
  them "not run: <one line>" in the verdict and the report; the loaders still compare.

The report ``check_<model>.md`` is written atomically after everything has loaded. Its verdict
fails on any disagreement between the loaders that read the file (a refusal is reported, not
judged), on a dynamics term or a free motion beyond tolerance (the witnesses' included), on a
witness holding another model than its description, and ends with the causes found.

MuJoCo's warnings while the dynamics terms and the free motions run (e.g. "Nan, Inf or huge value
in QACC ... The simulation is unstable.") are captured into the result (``CheckResult.warnings``,
``harness.engines.mujoco.warning_capture``: count and first message) and shown in the report and
the summary, never printed on stderr; Drake's parser warnings (Python logging) are captured into
the notes.

Before any loader opens a file, it must be a regular file (symlinks resolved) of at most
``harness.model.input_files.MAX_INPUT_BYTES``, UTF-8 text, whose ``<include>``s, meshes, textures and
height fields lie inside its folder or a folder given with ``--allow-dir`` (``allowed_dirs``;
``harness.model.input_files.check_model_file``); a FIFO, a device, an include outside is bad input.
The copies live in a temporary folder ``harness-check-*``, removed on SIGTERM too
(``atomic.sigterm_exits``). When MuJoCo refuses the file, its own reason is the message (Pinocchio
is asked for a second opinion only on a body's mass or inertia).

Bad input (missing or malformed file, missing mesh, a file MuJoCo cannot load, non-positive
mass, an inertia that is not positive definite or violates the triangle inequality, a model that
only MuJoCo loads, a joint map naming joints the files do not have) raises ``InputError`` naming
the file or the option, before anything is written.
"""

from __future__ import annotations

import copy
import os
import re
import tempfile
import time
import tomllib
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from harness.io import atomic
from harness.model.input_files import check_input_file, check_model_file, parse_xml, read_input_text
from harness.io.provenance import drake_version
from harness.tools import dynamics_terms as dc
from harness.tools import witnesses as wit
from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.mujoco.warning_capture import captured_warnings
from harness.engines.pinocchio.lie_group_integrators import rkmk4_step
from harness.engines.pinocchio.model import from_pinocchio, root_joint_model
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.from_model_file import add_root_joint  # noqa: F401 - also harness zoo's
from harness.model.joints import FREE, JOINTS, TRANSLATIONAL, by_pinocchio
from harness.model.scene import check_steps
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
    """``path`` if it is a regular file of bounded size (``harness.model.input_files``: a FIFO or a
    device would block or flood the loader), else InputError naming it (``... file not found``)."""
    path = Path(path)
    check_input_file(path, file_format(path))
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


@dataclass
class MujocoLoad:
    """MuJoCo's reading of a model file (``mujoco_load``).

    Attributes:
        model: the compiled ``MjModel``.
        notes: what loading did (fusestatic off).
        copies: how MuJoCo's reading differs from the file (geometry stripped, keyframes dropped).
        dropped_keys: (index in the file, why) of the keyframes dropped because they no longer fit.
        frozen: the geom-derived mass properties kept when the geometry was stripped from the
            spec (a URDF), None otherwise.
    """

    model: mujoco.MjModel
    notes: list[str]
    copies: list[str] = field(default_factory=list)
    dropped_keys: list[tuple[int, str]] = field(default_factory=list)
    frozen: GeomInertials | None = None


def _read_as(read: Path, source: Path) -> mujoco.MjSpec:
    """``read_mujoco_spec(read)`` with errors naming ``source`` (``read`` is its copy)."""
    try:
        return read_mujoco_spec(read)
    except InputError as err:
        raise InputError(str(err).replace(str(read), str(source))) from None


def mujoco_load(read: Path, source: Path | None = None, *, root_joint: str = "none", strip_spec: bool = False,
                keep_static: bool = False, frozen: GeomInertials | None = None) -> MujocoLoad:
    """MuJoCo model of ``read`` (``source`` itself or the loaders' copy of it, named ``source``
    in errors), plus an optional root joint; keyframes that no longer fit are dropped
    (``drop_unfitting_keys``). ``strip_spec`` strips the geometry in the spec (how a URDF is
    stripped for MuJoCo), keeping the geom-derived mass properties where MuJoCo can compile the
    geometry (``geom_inertials``, or ``frozen`` when given); ``keep_static`` turns MuJoCo's
    ``fusestatic`` off, on by default for URDF."""
    source = Path(source if source is not None else read)
    spec = _read_as(read, source)
    add_root_joint(spec, root_joint, source)
    check_spec_inertials(spec, source)
    notes = []
    if keep_static:
        spec.compiler.fusestatic = False
        notes.append("MuJoCo's fusestatic turned off: links on fixed joints stay separate bodies")
    copies = []
    if strip_spec:
        frozen = frozen if frozen is not None else geom_inertials(read)
        freeze_spec_inertials(spec, frozen)
        counts = strip_geometry(spec)
        names = [b.name for b in spec.bodies]
        what = "link" if file_format(source) == "URDF" else "body"
        copies.append(f"geometry stripped (--strip-geometry) from MuJoCo's reading of the {file_format(source)}: "
                     f"{_counts_text(counts)} removed; " + _mass_note(frozen, names, what))
    dropped = drop_unfitting_keys(spec, source)
    if dropped:
        copies.append(_keys_note(dropped, "MuJoCo's reading"))
    return MujocoLoad(compile_spec(spec, source), notes, copies, dropped, frozen if strip_spec else None)


def _keys_note(dropped: list[tuple[int, str]], where: str) -> str:
    return (f"{len(dropped)} keyframe(s) dropped from {where}, no longer fitting the model (the check does not use "
            "keyframes): " + "; ".join(why for _, why in dropped))


def _mass_note(frozen: GeomInertials, names: list[str], what: str = "body") -> str:
    """What stripping the geometry did to the mass properties (``geom_inertials``)."""
    def label(k):
        return names[k] or f"{what}{k}"

    text = "mass properties come from the <inertial> elements"
    if frozen.failed:
        lost = [label(k) for k in frozen.lost]
        if lost:
            text += (f"; MuJoCo could not compile the geometry ({frozen.failed}), so the {len(lost)} "
                     f"{what}{'(ies)' if what == 'body' else '(s)'} whose mass "
                     f"it derives from their geoms have none once it is stripped: {', '.join(lost)}")
        return text
    if frozen.values:
        text += (f"; the {len(frozen.values)} {what}{'(ies)' if what == 'body' else '(s)'} whose mass MuJoCo derives "
                 "from their geoms keep it, computed by MuJoCo with the geometry before stripping and written as "
                 "explicit inertials ("
                 + ", ".join(f"{label(k)} {v[0]:.6g} kg" for k, v in frozen.values.items()) + ")")
        if frozen.from_geoms:
            text += ' (the compiler\'s inertiafromgeom="true" ignores the <inertial> elements: every body\'s inertial ' \
                    "is MuJoCo's, and the copy says inertiafromgeom=\"auto\")"
    return text


def load_mujoco(path: Path, *, root_joint: str = "none", strip: bool = False,
                keep_static: bool = False) -> tuple[mujoco.MjModel, list[str]]:
    """MuJoCo model of an MJCF or URDF file as written (plus an optional root joint), and notes
    on what loading did (``mujoco_load``; ``strip`` strips the geometry in the spec)."""
    load = mujoco_load(Path(path), root_joint=root_joint, strip_spec=strip, keep_static=keep_static)
    return load.model, load.notes + load.copies


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


def supported_joints() -> str:
    """The joints ``harness check`` compares, from the joint table (``harness.model.joints``): every
    kind has MuJoCo's coordinates and Pinocchio's joint model; URDF types where a URDF can state
    the kind, and the root joint ``--floating-base`` adds."""
    mjcf = [jt.mujoco.split("_", 1)[1].lower() for jt in JOINTS.values() if jt.mujoco]
    urdf = [t for jt in JOINTS.values() for t in jt.urdf]
    return (f"supported: MJCF {', '.join(mjcf[:-1])} and {mjcf[-1]} joints, several on one body too; URDF "
            f"{', '.join(urdf)} and fixed joints; a {FREE.name} root joint added by --floating-base")


def check_mappable_joints(pmodel: pin.Model, source: Path) -> None:
    """InputError for a joint type ``harness check`` cannot put into common coordinates."""
    for jid in range(1, pmodel.njoints):
        if pin_joint_type(pmodel.joints[jid]) is None:
            name = pmodel.joints[jid].shortname().removeprefix("JointModel").lower()
            raise InputError(f"{source}: joint {pmodel.names[jid]!r} of type {name} cannot be compared between engines "
                             f"({supported_joints()})")


# --------------------------------------------------------------------------- the copies the loaders read
#
# A loader reads the file as written unless something must change for the comparison; then it
# reads a copy in a temporary folder (same file name), and the report says what changed:
#
# * ``--strip-geometry``: an MJCF's copy (read by every loader that reads the MJCF) without geoms,
#   meshes, height fields, textures, materials and skins, nor what refers to them (tendon wraps
#   around geoms, sensors on geoms, contact pairs, custom tuple elements); a URDF's copy for
#   Pinocchio and Drake without ``<visual>``/``<collision>``; MuJoCo's reading of a URDF stripped
#   in its spec. Mass properties: ``geom_inertials``, written into the copies as explicit
#   inertials (``MjcfCopy.freeze``, ``freeze_spec_inertials``);
# * an MJCF read by every loader with unnamed bodies or joints: named ``body<k>``/``joint<k>``
#   after MuJoCo's numbering (joints are matched by name);
# * keyframes that no longer fit (a root joint added): dropped (``drop_unfitting_keys``); the
#   check does not use keyframes;
# * a copy of an MJCF without ``<mujoco model>`` is named after the file (Drake's parser needs it).

GEOMETRY_ASSETS = ("mesh", "hfield", "texture", "material", "skin")
_COUNT_WORDS = {"geom": ("geom", "geoms"), "mesh": ("mesh", "meshes"), "hfield": ("height field", "height fields"),
                "texture": ("texture", "textures"), "material": ("material", "materials"), "skin": ("skin", "skins"),
                "wrap": ("tendon wrap around a geom", "tendon wraps around geoms"),
                "sensor": ("sensor on a geom", "sensors on geoms"), "pair": ("contact pair", "contact pairs"),
                "tuple": ("custom tuple element on a geom", "custom tuple elements on geoms"),
                "visual": ("<visual> element", "<visual> elements"),
                "collision": ("<collision> element", "<collision> elements")}


def _counts_text(counts: dict[str, int]) -> str:
    """``{"geom": 3, "mesh": 1}`` as "3 geoms, 1 mesh" (kinds with none left out)."""
    return ", ".join(f"{n} {_COUNT_WORDS.get(k, (k, k))[n != 1]}" for k, n in counts.items() if n) or "nothing"


def strip_geometry(spec: mujoco.MjSpec) -> dict[str, int]:
    """Delete every geom, mesh, height field, skin, texture and material from a spec (dynamics do
    not need them); returns what was removed, by kind. Mass properties are not kept: see
    ``geom_inertials`` and ``freeze_spec_inertials``."""
    counts = {}
    for kind, items in (("geom", spec.geoms), ("mesh", spec.meshes), ("hfield", spec.hfields), ("skin", spec.skins),
                        ("material", spec.materials), ("texture", spec.textures)):
        items = list(items)
        for item in items:
            spec.delete(item)
        counts[kind] = len(items)
    for item in list(spec.sites) + list(spec.tendons):   # what else may name a material
        item.material = ""
    return counts


@dataclass
class GeomInertials:
    """The mass properties MuJoCo derives from geoms, per body of a file (``geom_inertials``).

    Attributes:
        values: spec body index (``spec.bodies`` order, world 0) -> (mass kg, ipos m, iquat wxyz,
            principal moments kg m^2) of the bodies whose mass MuJoCo derives from their geoms
            (no ``<inertial>``, or all under ``<compiler inertiafromgeom="true">``) and is positive.
        geoms: spec body index -> number of geoms, for the same bodies.
        failed: why MuJoCo could not compile the geometry ("" when it could): the masses are lost.
        lost: spec body indices whose mass came from geoms and is lost (when ``failed``).
        from_geoms: whether the compiler derives every body's inertia from its geoms.
        model: the file compiled so (None when nothing needed it or it did not compile).
    """

    values: dict = field(default_factory=dict)
    geoms: dict = field(default_factory=dict)
    failed: str = ""
    lost: list = field(default_factory=list)
    from_geoms: bool = False
    model: mujoco.MjModel | None = None


def geom_inertials(path: Path) -> GeomInertials:
    """Compile the file as written with MuJoCo (``fusestatic`` off so that every body keeps its
    own, the compiler's mass adjustments off, keyframes dropped) and read the mass properties of
    the bodies whose mass comes from their geoms."""
    spec = read_mujoco_spec(path)
    out = GeomInertials(from_geoms=spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE)
    wanted = [k for k, b in enumerate(spec.bodies) if k > 0 and (out.from_geoms or not b.explicitinertial)]
    if not wanted:
        return out
    for key in list(spec.keys):
        spec.delete(key)
    spec.compiler.fusestatic = False
    spec.compiler.settotalmass, spec.compiler.boundmass, spec.compiler.boundinertia = -1.0, 0.0, 0.0
    spec.compiler.balanceinertia = False
    with_geoms = [k for k in wanted if list(spec.bodies[k].geoms)]  # before compiling: a failed compile
    try:                                                              # leaves the spec unreadable
        with captured_native_stderr():
            m = spec.compile()
    except Exception as err:
        out.failed = _one_line(err).removeprefix("Error: ")
        out.lost = with_geoms
        return out
    out.model = m
    for k in wanted:
        if m.body_mass[k] > 0.0:
            out.values[k] = (float(m.body_mass[k]), np.array(m.body_ipos[k]), np.array(m.body_iquat[k]),
                             np.array(m.body_inertia[k]))
            out.geoms[k] = int(m.body_geomnum[k])
    return out


def freeze_spec_inertials(spec: mujoco.MjSpec, frozen: GeomInertials) -> None:
    """Write the geom-derived mass properties into a spec as explicit inertials (bodies matched
    by index: the spec must be the file's, as ``geom_inertials`` read it); nothing when the
    geometry did not compile."""
    if frozen.failed:
        return
    bodies = list(spec.bodies)
    for k, (mass, ipos, iquat, inertia) in frozen.values.items():
        b = bodies[k]
        b.explicitinertial = True
        b.mass, b.ipos, b.iquat, b.inertia = mass, ipos, iquat, inertia
        b.fullinertia = [np.nan] * 6
    if frozen.from_geoms:
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO
        for k, b in enumerate(bodies):
            if k > 0 and k not in frozen.values:
                b.explicitinertial = False


def _num(x) -> str:
    return " ".join(repr(float(c)) for c in np.ravel(x))


class MjcfCopy:
    """An MJCF as an element tree (``<include>`` inlined, asset folders made absolute), edited for
    the loaders and written to a temporary folder under the original file name.

    ``changes`` says, one sentence each, how the copy differs from the file."""

    def __init__(self, path: Path):
        self.path = Path(path)
        try:
            self.root = parse_xml(self.path, "MJCF")
            self._inline(self.root, 0)
        except (ET.ParseError, OSError) as err:
            raise InputError(f"{path}: cannot read the MJCF for the loaders' copy: {_one_line(err)}") from None
        self._absolute_dirs()
        self.changes: list[str] = []
        self.key_elements = [k for kf in self.root.iter("keyframe") for k in kf.findall("key")]

    def _inline(self, element, depth: int) -> None:
        if depth > 20:
            raise InputError(f"{self.path}: <include> nested more than 20 deep")
        children = []
        for child in list(element):
            if child.tag == "include":
                name = child.get("file", "")
                path = self.path.parent / name   # MuJoCo: relative to the main file's folder
                included = parse_xml(path, "included MJCF")
                self._inline(included, depth + 1)
                children += list(included)
            else:
                self._inline(child, depth)
                children.append(child)
        element[:] = children

    def _absolute_dirs(self) -> None:
        """Make the compiler's asset folders absolute (the copy lives elsewhere)."""
        base = self.path.parent.resolve()
        compilers = self.root.findall("compiler")
        given: dict[str, str] = {}
        for c in compilers:
            for key in ("assetdir", "meshdir", "texturedir"):
                if c.get(key) is not None:
                    given[key] = c.attrib.pop(key)
        if not any(e.get("file") for e in self.root.iter() if e.tag != "include"):
            for key, value in given.items():   # nothing to find: put back what the file says
                (compilers[-1] if compilers else self._compiler()).set(key, value)
            return
        last = compilers[-1] if compilers else self._compiler()
        asset = given.get("assetdir", "")
        for key in ("meshdir", "texturedir"):
            value = given.get(key, asset)
            last.set(key, value if Path(value).is_absolute() else str(base / value))
        if "assetdir" in given:
            last.set("assetdir", asset if Path(asset).is_absolute() else str(base / asset))

    def _compiler(self):
        c = ET.Element("compiler")
        self.root.insert(0, c)
        return c

    def bodies(self) -> list:
        """The ``<body>`` elements in document order (MuJoCo's body order, world excluded)."""
        return list(self.root.iter("body"))

    def strip(self) -> dict[str, int]:
        """Remove the geometry (see the section comment); returns what was removed, by kind."""
        counts = dict.fromkeys(("geom", "mesh", "hfield", "texture", "material", "skin", "wrap", "sensor", "pair",
                                "tuple"), 0)
        for parent in list(self.root.iter()):
            for child in list(parent):
                tag = child.tag
                if tag == "geom" and parent.tag == "default":
                    for attr in ("material", "mesh", "hfield"):
                        child.attrib.pop(attr, None)
                    continue
                if tag == "geom":
                    kind = "wrap" if parent.tag == "spatial" else "geom"
                elif parent.tag in ("asset", "deformable") and tag in GEOMETRY_ASSETS:
                    kind = tag
                elif parent.tag == "sensor" and (child.get("objtype") == "geom" or child.get("reftype") == "geom"
                                                 or any(child.get(a) for a in ("geom", "geom1", "geom2"))):
                    kind = "sensor"
                elif parent.tag == "contact" and tag == "pair":
                    kind = "pair"
                elif parent.tag == "tuple" and child.get("objtype") == "geom":
                    kind = "tuple"
                else:
                    child.attrib.pop("material", None)
                    continue
                parent.remove(child)
                counts[kind] += 1
        return counts

    def freeze(self, frozen: GeomInertials) -> None:
        """Write ``<inertial>`` elements with MuJoCo's geom-derived values (``geom_inertials``);
        nothing when the geometry did not compile."""
        if frozen.failed:
            return
        bodies = self.bodies()
        for k, (mass, ipos, iquat, inertia) in frozen.values.items():
            body = bodies[k - 1]
            for old in body.findall("inertial"):
                body.remove(old)
            body.insert(0, ET.Element("inertial", {"pos": _num(ipos), "quat": _num(iquat), "mass": _num(mass),
                                                   "diaginertia": _num(inertia)}))
        if frozen.from_geoms:
            for c in self.root.findall("compiler"):
                c.attrib.pop("inertiafromgeom", None)
            for k, body in enumerate(bodies, start=1):
                if k not in frozen.values:
                    for old in body.findall("inertial"):
                        body.remove(old)

    def name_unnamed(self, spec: mujoco.MjSpec) -> tuple[list[str], list[str]]:
        """Give every unnamed body ``body<k>`` and every unnamed joint ``joint<j>`` (MuJoCo's ids,
        as the check names them); returns the new names (bodies, joints)."""
        bodies = self.bodies()
        joints = [j for b in bodies for j in b if j.tag in ("joint", "freejoint")]
        taken = {b.name for b in spec.bodies} | {j.name for j in spec.joints}
        new_bodies, new_joints = [], []
        for elements, prefix, out in ((bodies, "body", new_bodies), (joints, "joint", new_joints)):
            for k, e in enumerate(elements, start=1 if prefix == "body" else 0):
                if e.get("name"):
                    continue
                name = f"{prefix}{k}"
                while name in taken:
                    name += "_"
                taken.add(name)
                e.set("name", name)
                out.append(name)
        return new_bodies, new_joints

    def drop_keys(self, indices) -> None:
        for i in indices:
            key = self.key_elements[i]
            for kf in self.root.iter("keyframe"):
                if key in list(kf):
                    kf.remove(key)

    def write(self, folder: Path) -> Path:
        """Write the copy as ``<folder>/<file name>`` (named after the file when ``<mujoco>`` has no
        model name) and return its path."""
        folder.mkdir(parents=True, exist_ok=True)
        if not self.root.get("model"):
            self.root.set("model", self.path.stem)
            self.changes.append(f"the copy names the model {self.path.stem!r} (the file's <mujoco> has no model "
                                "name, which Drake's parser requires)")
        out = folder / self.path.name
        ET.ElementTree(self.root).write(out, encoding="utf-8", xml_declaration=True)
        return out


def strip_urdf_copy(path: Path, folder: Path) -> tuple[Path, dict[str, int]]:
    """A copy of a URDF without ``<visual>`` and ``<collision>`` elements, as ``<folder>/<name>``."""
    try:
        tree = ET.ElementTree(parse_xml(path, "URDF"))
    except (ET.ParseError, OSError) as err:
        raise InputError(f"{path}: cannot load URDF: {_one_line(err)}") from None
    counts = {"visual": 0, "collision": 0}
    for link in tree.getroot().iter("link"):
        for child in list(link):
            if child.tag in counts:
                link.remove(child)
                counts[child.tag] += 1
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / Path(path).name
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out, counts


def drop_unfitting_keys(spec: mujoco.MjSpec, source: Path) -> list[tuple[int, str]]:
    """Delete the keyframes whose sizes (qpos, qvel, act, ctrl, mocap) do not fit the model the
    spec compiles to (e.g. after a root joint was added); returns (index, why) of each."""
    keys = list(spec.keys)
    if not keys:
        return []
    probe = spec.copy()
    for key in list(probe.keys):
        probe.delete(key)
    m = compile_spec(probe, source)
    sizes = {"qpos": m.nq, "qvel": m.nv, "act": m.na, "ctrl": m.nu, "mpos": 3 * m.nmocap, "mquat": 4 * m.nmocap}
    dims = {"qpos": "nq", "qvel": "nv", "act": "na", "ctrl": "nu", "mpos": "3 nmocap", "mquat": "4 nmocap"}
    dropped = []
    for i, key in enumerate(keys):
        bad = [f"{f} has {len(getattr(key, f))} numbers, the model's {dims[f]} is {n}"
               for f, n in sizes.items() if len(getattr(key, f)) not in (0, n)]
        if bad:
            label = repr(key.name) if key.name else f"#{i}"
            dropped.append((i, f"{label} ({'; '.join(bad)})"))
            spec.delete(key)
    return dropped


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
        bodies, details: per joint, the body it moves (with its merged parts) and the joint's
            point, range, damping, armature and friction loss (``harness.tools.loaded_models``:
            ``JointBody``, ``JointDetails``).
        gravity: m/s^2, world.
        model: what it holds (``MjModel``, ``pin.Model``, ``DrakeLoad``).
        slots: Pinocchio only: joint name -> ``PinocchioSlot`` (composite joints split).
        parser: what its parser said while loading (Drake's warnings, one line each).
        dynamics: why its dynamics terms are not compared with MuJoCo's ("" when they are).
        hints: quantity -> a known cause, shown when this loader is the odd one out in it.
        geom_masses: MuJoCo only: body name -> how MuJoCo got the mass of a body whose file gives
            no ``<inertial>`` (from its geoms: geom density or mass), shown where that body's
            joint differs in mass (``_geom_masses``).
        names: the joints this loader's file names otherwise, compared under the other file's names
            (``apply_joint_map``): name in its file -> name in the comparison.
        partial: MuJoCo's joints this loader lacks, whole kinematic trees of their own: its
            dynamics terms and free motion are compared on the other trees (``_joint_set_problem``).
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
    geom_masses: dict = field(default_factory=dict)
    names: dict = field(default_factory=dict)
    partial: list = field(default_factory=list)

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
            cannot state an armature; ``NOT_COUNTED`` never are).
        detail: by how much the values differ, with the unit (``_difference``: the odd one out
            against the majority, or the two values when two loaders read it); "" when they agree.
    """

    joint: str
    body: str
    quantity: str
    values: dict[str, str]
    groups: tuple[tuple[str, ...], ...]
    hint: str = ""
    counted: bool = True
    detail: str = ""

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
        detail = f"; {self.detail}" if self.detail else ""
        if odd is not None:
            a, b = self.groups[0]
            return (f"{who}: {self.quantity}: {odd} is the odd one out: {self.values[odd]} where {a} and {b} read "
                    f"{self.values[a]}{detail}{hint}")
        parts = ", ".join(f"{v} in {k}" for k, v in self.values.items())
        lead = "all three differ: " if len(self.groups) == 3 else ""
        return f"{who}: {self.quantity}: {lead}{parts}{detail}{hint}"


@dataclass(frozen=True)
class Finding:
    """A cause that accounts for a disagreement, checked against the readings (``diagnose``).

    Attributes:
        kind: ``inertial rotation`` (a URDF ``<inertial><origin rpy>`` that one reading lacks),
            ``fixed child`` (a fixed child's mass properties missing or different in one reading
            of the body they are merged into), ``armature`` (a joint's armature that only some
            loaders read), ``dynamics armature`` (M differing by exactly the armature on its
            diagonal), ``several joints`` (the first of a body's joints at its parent's origin in
            one reading).
        joint, body: where ("" for the dynamics).
        short: a few words for the verdict; ``text``: the whole finding, with figures and units.
        group: findings with the same group are one item of the verdict when there are several
            (``causes_line``: e.g. an armature only one loader reads, on many joints).
    """

    kind: str
    joint: str
    body: str
    short: str
    text: str
    group: str = ""


def causes_line(findings: list[Finding]) -> str:
    """The findings' ``short`` texts for the verdict, one item per group of several (with the
    number of joints and the first three), in order."""
    groups: dict[str, list[Finding]] = {}
    for f in findings:
        if f.group:
            groups.setdefault(f.group, []).append(f)
    items, done = [], set()
    for f in findings:
        if not f.group or len(groups[f.group]) == 1:
            items.append(f.short)
        elif f.group not in done:
            done.add(f.group)
            joints = [g.joint for g in groups[f.group]]
            items.append(f"{f.group} on {len(joints)} joints ({', '.join(joints[:3])}{', ...' if len(joints) > 3 else ''})")
    return "; ".join(items)


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
    findings: list[Finding] = field(default_factory=list)  # what the differences come from (``diagnose``)
    not_compared: list[str] = field(default_factory=list)  # what MuJoCo holds beyond the tree (``not_compared``)
    copies: list[str] = field(default_factory=list)  # how what the loaders read differs from the files
    mapped: int = 0   # joints compared under another name (``apply_joint_map``)
    witnesses: wit.Witnesses | None = None   # the in-house engine and Exudyn (``harness.tools.witnesses``)

    @property
    def model_problems(self) -> list[str]:
        """The disagreements between the loaders that fail the check, one message each."""
        return [v.message for v in self.votes if not v.agree and v.counted]

    @property
    def setting_differences(self) -> list[str]:
        """Disagreements in joint settings that do not fail the check (listed, not counted): between an
        MJCF and a URDF (``SETTINGS``), and friction loss always (``NOT_COUNTED``)."""
        return [v.message for v in self.votes if not v.agree and not v.counted]

    @property
    def two_files(self) -> bool:
        """Whether the loaders read two files (an MJCF and a URDF)."""
        return len({r.source for r in self.readings.values() if r.loaded}) > 1

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
        return (not self.model_problems and all(d.passed for d in self.dynamics) and self.free_passed
                and self.witnesses_passed)

    @property
    def witnesses_passed(self) -> bool:
        """The witnesses hold the description they were built from and move as MuJoCo does (not run: not judged)."""
        w = self.witnesses
        return w is None or bool(w.refusal) or (not w.problems and all(f.passed for f in w.free)
                                                and all(d.passed for d in w.dynamics))


def _refusal(err: Exception, path: Path) -> str:
    """An InputError's one line without the leading ``<path>: `` (and the loader's name)."""
    text = str(err).removeprefix(f"{path}: ").replace("Pinocchio cannot load", "cannot load", 1)
    native = re.search(r"^(cannot load the \w+: ).*? message: (.*)$", text)  # a C++ exception's location, then its message
    return native.group(1) + native.group(2) if native else text


def _pin_unmappable(slots: dict) -> str | None:
    for name, s in slots.items():
        if by_pinocchio(s.shortname) is None:
            kind = s.shortname.removeprefix("JointModel").lower()
            return f"joint {name!r} of type {kind} cannot be compared between engines ({supported_joints()})"
    return None


def _body_joints(m: mujoco.MjModel) -> dict[str, list[str]]:
    """MuJoCo body name -> its joints' names, in order."""
    out: dict[str, list[str]] = {}
    for j in range(m.njnt):
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(m.jnt_bodyid[j])) or f"body{int(m.jnt_bodyid[j])}"
        out.setdefault(body, []).append(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}")
    return out


def load_models(mjcf: Path | None, urdf: Path | None, *, floating_base: bool = False, strip: bool = False,
                keep_static: bool = False, joint_map: dict[str, str] | None = None,
                allowed_dirs: tuple[Path, ...] = ()) -> tuple[dict[str, Reading], str, list[str], list[str]]:
    """Every loader's reading of the file(s) per the module docstring; returns (readings by
    loader name, mode, notes on loading, how what the loaders read differs from the files: the
    copies and the joint map). ``joint_map``: MJCF joint name -> URDF joint name, for
    an MJCF and a URDF whose joints are named differently (``apply_joint_map``). Raises
    InputError for bad input: no file, a missing or malformed file, a file MuJoCo does not load,
    a non-physical body (non-positive mass, invalid inertia), a model without a moving joint, a
    model only MuJoCo loads, or a joint map naming joints the files do not have. Before any
    loader opens them, each file must be a regular file of bounded size and UTF-8 text whose
    includes and assets lie in its folder or one of ``allowed_dirs``
    (``harness.model.input_files.check_model_file``)."""
    if mjcf is None and urdf is None:
        raise InputError("check needs --mjcf MODEL.xml, --urdf MODEL.urdf, or both")
    mj_file = Path(mjcf) if mjcf is not None else Path(urdf)
    other_file = Path(urdf) if urdf is not None else Path(mjcf)
    for path in dict.fromkeys((mj_file, other_file)):
        check_model_file(path, allowed_dirs)
    if joint_map and (mjcf is None or urdf is None):
        raise InputError("--joint-map and --map rename the URDF's joints to the MJCF's: they need both --mjcf and --urdf")
    mode = {(True, True): "MJCF -> MuJoCo, URDF -> Pinocchio and Drake",
            (False, True): "URDF -> MuJoCo, Pinocchio and Drake",
            (True, False): "MJCF -> MuJoCo, Pinocchio and Drake"}[(mjcf is not None, urdf is not None)]
    root = FREE.name if floating_base else "none"
    # Parse and check the file-level inertials first, so that every bad value gets the same message.
    for path in {mj_file, other_file}:
        spec = read_mujoco_spec(path)
        add_root_joint(spec, root, path)
        check_spec_inertials(spec, path)
    with atomic.sigterm_exits(), tempfile.TemporaryDirectory(prefix="harness-check-") as tmp:  # removed on SIGTERM too
        readings, notes, copies = _load_readings(mj_file, other_file, Path(tmp), root=root, strip=strip,
                                                 keep_static=keep_static, mjcf_alone=mjcf is not None and urdf is None)
    if joint_map:
        copies += apply_joint_map(readings, joint_map)
    notes += _match_free_joints(readings)
    return readings, mode, notes, copies


# --------------------------------------------------------------------------- joint maps: MJCF and URDF names


def read_joint_map(path: Path) -> dict[str, str]:
    """MJCF joint name -> URDF joint name from a file: TOML (``mjcf_name = "urdf_name"`` pairs at
    the top level or in one table) or two-column text (``mjcf_name = urdf_name`` or ``mjcf_name
    urdf_name`` per line; ``#`` starts a comment). InputError (naming the file and line) for
    anything else."""
    path = Path(path)
    text = read_input_text(path, "joint map")  # a regular file of bounded size, UTF-8: InputError otherwise
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        data = None
    if data is not None:
        if len(data) == 1 and isinstance(next(iter(data.values())), dict):
            data = next(iter(data.values()))
        bad = [k for k, v in data.items() if not isinstance(v, str) or not v]
        if bad:
            raise InputError(f"{path}: a joint map gives each MJCF joint one URDF joint name (a string); "
                             f"not so for {', '.join(map(repr, bad))}")
        return dict(data)
    out: dict[str, str] = {}
    for n, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split("=", 1) if "=" in line else line.split()
        parts = [p.strip().strip("\"'") for p in parts]
        if len(parts) != 2 or not all(parts):
            raise InputError(f"{path}: line {n}: expected 'mjcf_name = urdf_name', got {line!r}")
        if parts[0] in out:
            raise InputError(f"{path}: line {n}: MJCF joint {parts[0]!r} is mapped twice")
        out[parts[0]] = parts[1]
    return out


def parse_map_options(items: list[str] | None) -> dict[str, str]:
    """``--map mjcf_name=urdf_name`` options (repeatable) as a dict; InputError for a malformed one."""
    out: dict[str, str] = {}
    for item in items or []:
        a, sep, b = item.partition("=")
        a, b = a.strip(), b.strip()
        if not sep or not a or not b:
            raise InputError(f"--map {item!r}: expected mjcf_name=urdf_name")
        if a in out and out[a] != b:
            raise InputError(f"--map: MJCF joint {a!r} is mapped twice ({out[a]!r} and {b!r})")
        out[a] = b
    return out


def _urdf_joint_names(path: Path) -> list[str]:
    """The names of a URDF's joints that move (not ``fixed``), in file order."""
    try:
        root = parse_xml(path, "URDF")
    except (ET.ParseError, OSError, InputError):
        return []
    return [j.get("name") for j in root.findall("joint") if j.get("name") and j.get("type") != "fixed"]


def _few(names, n: int = 12) -> str:
    names = list(names)
    return ", ".join(names[:n]) + (f", ... ({len(names)} in all)" if len(names) > n else "")


def apply_joint_map(readings: dict[str, Reading], joint_map: dict[str, str],
                    label: str = "joint map (--joint-map, --map)") -> list[str]:
    """Compare the URDF's joints (Pinocchio's and Drake's readings) under the MJCF's names:
    ``joint_map`` maps an MJCF joint name (MuJoCo's) to a URDF joint name. InputError, one line,
    for a name that neither file has (listing the joints it does have), a URDF joint mapped twice,
    or a URDF joint that keeps a name the map gives to another one. Returns a note."""
    mjr = readings["MuJoCo"]
    others = [r for r in readings.values() if r.loader != "MuJoCo"]
    mj_names = [x.joint for x in mjr.bodies]
    urdf_file = others[0].source
    urdf_names = list(dict.fromkeys(_urdf_joint_names(urdf_file) + [x.joint for r in others if r.loaded for x in r.bodies]))
    bad_mj = [a for a in joint_map if a not in mj_names]
    bad_urdf = [b for b in joint_map.values() if b not in urdf_names]
    problems = []
    if bad_mj:
        problems.append(f"MJCF {', '.join(map(repr, bad_mj))} (the MJCF's joints: {_few(mj_names)})")
    if bad_urdf:
        problems.append(f"URDF {', '.join(map(repr, bad_urdf))} (the URDF's joints: {_few(urdf_names)})")
    if problems:
        raise InputError(f"{label}: unknown joint name(s): " + "; ".join(problems))
    twice = sorted({b for b in joint_map.values() if list(joint_map.values()).count(b) > 1})
    if twice:
        raise InputError(f"{label}: URDF joint(s) {', '.join(map(repr, twice))} mapped to several MJCF joints")
    rename = {b: a for a, b in joint_map.items()}
    clash = [a for a in rename.values() if a in urdf_names and a not in rename]
    if clash:
        raise InputError(f"{label}: URDF joint(s) {', '.join(map(repr, clash))} keep their names, which the map gives "
                         "to other URDF joints: map them too")
    from dataclasses import replace

    for r in others:
        r.names = {b: a for b, a in rename.items()}
        if not r.loaded:
            continue
        r.bodies = [replace(x, joint=rename.get(x.joint, x.joint)) for x in r.bodies]
        r.details = [replace(x, joint=rename.get(x.joint, x.joint)) for x in r.details]
        if r.slots:
            r.slots = {rename.get(k, k): v for k, v in r.slots.items()}
    changed = [(a, b) for a, b in joint_map.items() if a != b]
    return [f"{label}: {len(changed)} URDF joint(s) compared under the MJCF's names (MJCF = URDF): "
            + _few(f"{a} = {b}" for a, b in changed)] if changed else []


def _unnamed(spec: mujoco.MjSpec) -> tuple[int, int]:
    """How many bodies (world excluded) and joints of a spec have no name."""
    return (sum(1 for b in list(spec.bodies)[1:] if not b.name), sum(1 for j in spec.joints if not j.name))


def _probe(read: Path, source: Path) -> mujoco.MjModel:
    """``read`` compiled as ``geom_inertials`` compiles the file (keyframes dropped, fusestatic and
    the compiler's mass adjustments off); errors name ``source``."""
    spec = _read_as(read, source)
    for key in list(spec.keys):
        spec.delete(key)
    spec.compiler.fusestatic = False
    spec.compiler.settotalmass, spec.compiler.boundmass, spec.compiler.boundinertia = -1.0, 0.0, 0.0
    spec.compiler.balanceinertia = False
    return compile_spec(spec, source)


def _check_copy(source: Path, read: Path, orig: mujoco.MjModel | None = None) -> None:
    """InputError unless the loaders' copy of an MJCF has MuJoCo's tree and masses: the same
    bodies, parents and joints, and each body's mass, centre of mass and principal moments (the
    geom-derived ones as written into the copy), within 1e-9 relative."""
    copy_m = _probe(read, source)
    try:
        orig = orig if orig is not None else _probe(source, source)
    except InputError:   # the geometry does not compile (missing mesh): the tree at least
        spec = read_mujoco_spec(source)
        if (len(spec.bodies), len(spec.joints)) != (copy_m.nbody, copy_m.njnt):
            raise InputError(f"{source}: the loaders' copy does not reproduce the file's bodies and joints "
                             f"({copy_m.nbody - 1} bodies and {copy_m.njnt} joints, the file "
                             f"{len(spec.bodies) - 1} and {len(spec.joints)})") from None
        return
    same = (orig.nbody == copy_m.nbody and orig.njnt == copy_m.njnt
            and np.array_equal(orig.body_parentid, copy_m.body_parentid)
            and np.array_equal(orig.jnt_type, copy_m.jnt_type) and np.array_equal(orig.jnt_bodyid, copy_m.jnt_bodyid))
    if not same:
        raise InputError(f"{source}: the loaders' copy does not reproduce MuJoCo's tree ({copy_m.nbody - 1} bodies and "
                         f"{copy_m.njnt} joints, the file {orig.nbody - 1} and {orig.njnt}): <replicate>, <attach> or "
                         "<composite> may make bodies the file does not write one by one")
    for b in range(1, orig.nbody):
        for a, c, floor in ((orig.body_mass[b], copy_m.body_mass[b], 1e-12),
                            (orig.body_inertia[b], copy_m.body_inertia[b], 1e-12),
                            (orig.body_ipos[b], copy_m.body_ipos[b], 1e-3)):
            if np.abs(np.asarray(a) - np.asarray(c)).max() > 1e-9 * max(float(np.abs(a).max()), floor):
                name = mujoco.mj_id2name(copy_m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
                raise InputError(f"{source}: the loaders' copy changes the mass properties of body {name!r} "
                                 f"({float(np.sum(a)):.9g} -> {float(np.sum(c)):.9g})")


def _refusal_in(err: Exception, tmp: Path, source: Path) -> str:
    """A loader's refusal of ``source`` or of its copy in ``tmp`` (``<tmp>/<loader>/<file name>``), in
    one line without the file's path."""
    text = re.sub(re.escape(str(tmp)) + r"/[^/\s]+/", "", str(err))
    for prefix in (f"{source}: ", f"{source.name}: "):
        text = text.removeprefix(prefix)
    return _refusal(InputError(text), Path(os.devnull))


def _pinocchio_or(err: InputError, other_file: Path, root: str) -> InputError:
    """When MuJoCo refuses the file over a body's mass or inertia and Pinocchio reads a body of it
    as non-physical, Pinocchio's message, which names the body and its joint; else MuJoCo's error,
    which carries MuJoCo's own reason (its depth limit for a chain too deep, a missing file...).
    Pinocchio is not asked about any other refusal: its data for a model MuJoCo refuses for its
    size (a 2000-link chain) would not fit in memory, and its failure would hide MuJoCo's reason."""
    if not re.search(r"mass|inertia", str(err), re.IGNORECASE):
        return err
    try:
        pmodel = load_pinocchio(other_file, root_joint=root)
        check_joint_bodies_physical(pinocchio_joint_bodies(pmodel), str(other_file))
    except InputError as pin_err:
        if "Pinocchio cannot load" not in str(pin_err):
            return pin_err
    except (MemoryError, Exception):  # noqa: BLE001 - only a second opinion: MuJoCo's reason stands
        pass
    return err


def _load_readings(mj_file: Path, other_file: Path, tmp: Path, *, root: str, strip: bool, keep_static: bool,
                   mjcf_alone: bool) -> tuple[dict[str, Reading], list[str], list[str]]:
    """Load MuJoCo, then Pinocchio and Drake, each from the file or its copy in ``tmp`` (see the
    section "the copies the loaders read"); returns (readings, notes, what the copies change)."""
    notes: list[str] = []
    copies: list[str] = []
    copy = None
    frozen = None
    mj_read = mj_file
    strip_note = ""
    if strip:
        frozen = geom_inertials(mj_file)
    if file_format(mj_file) == "MJCF":
        spec0 = read_mujoco_spec(mj_file)
        bodies_unnamed, joints_unnamed = _unnamed(spec0) if mjcf_alone else (0, 0)
        if strip or bodies_unnamed or joints_unnamed:
            copy = MjcfCopy(mj_file)
            readers = "every loader" if mjcf_alone else "MuJoCo"
            if strip:
                counts = copy.strip()
                copy.freeze(frozen)
                names = [b.name for b in spec0.bodies]
                strip_note = (f"geometry stripped (--strip-geometry) from the copy of {mj_file.name} that {readers} "
                              f"reads: {_counts_text(counts)} removed; " + _mass_note(frozen, names)
                              + ("; how each importer derives masses from geoms is therefore not compared"
                                 if mjcf_alone and frozen.values else ""))
            if bodies_unnamed or joints_unnamed:
                new_bodies, new_joints = copy.name_unnamed(spec0)
                copy.changes.append(f"the MJCF has {len(new_bodies)} unnamed body(ies) and {len(new_joints)} unnamed "
                                    "joint(s): named in every loader's copy after MuJoCo's numbering, as the check names "
                                    "them, so that the loaders' joints can be matched by name ("
                                    + ", ".join((new_bodies + new_joints)[:12])
                                    + (", ..." if len(new_bodies) + len(new_joints) > 12 else "") + ")")
            mj_read = copy.write(tmp / "mujoco")
            try:
                _check_copy(mj_file, mj_read, frozen.model if frozen is not None else None)
            except InputError as err:
                raise _with_lost(err, frozen, copy=True) from None
    try:
        mjl = mujoco_load(mj_read, mj_file, root_joint=root, strip_spec=strip and file_format(mj_file) == "URDF",
                          keep_static=keep_static, frozen=frozen)
    except InputError as err:
        raise _with_lost(_pinocchio_or(err, other_file, root), frozen, copy=mj_read != mj_file) from None
    m = mjl.model
    copies += ([strip_note] if strip_note else []) + mjl.copies
    notes += mjl.notes
    bodies = mujoco_joint_bodies(m, _zero_qpos(m))  # masses and inertias do not depend on the configuration
    last = {}  # a MuJoCo body with several joints carries its mass at the last one
    for x in bodies:
        last[x.body] = x
    try:
        check_joint_bodies_physical(list(last.values()), str(mj_file))
    except InputError as err:
        raise _with_lost(err, frozen) from None
    if m.nv == 0:
        raise InputError(f"{mj_file}: the model has no moving joint, nothing to compare "
                         f"(a URDF's root link is fixed unless --floating-base)")
    mjr = Reading("MuJoCo", mj_file, mujoco.__version__, bodies=bodies,
                  details=mujoco_joint_details(m), gravity=mujoco_gravity(m), model=m, hints=_mujoco_hints(m, mj_file),
                  geom_masses=_geom_masses(m, mj_file, frozen))
    # what Pinocchio and Drake read
    other_read = other_file
    if file_format(other_file) == "MJCF":   # the MJCF alone: the loaders read the same copy, if any
        if copy is None and mjl.dropped_keys:
            copy = MjcfCopy(other_file)
        if copy is not None:
            if mjl.dropped_keys:
                copy.drop_keys([i for i, _ in mjl.dropped_keys])
                copy.changes.append(_keys_note(mjl.dropped_keys, "Pinocchio's and Drake's copy"))
            other_read = copy.write(tmp / "others")
    elif strip:
        other_read, counts = strip_urdf_copy(other_file, tmp / "others")
        copies.append(f"geometry stripped (--strip-geometry) from the copy of {other_file.name} that Pinocchio and Drake "
                     f"read: {_counts_text(counts)} removed (they read masses from the <inertial> elements only)")
    pinr = Reading("Pinocchio", other_file, pin.__version__)
    pin_bad = None
    try:
        try:
            pmodel = load_pinocchio(other_read, root_joint=root)
        except InputError as err:
            if "Keyframe size does not match" not in str(err) or file_format(other_file) != "MJCF":
                raise
            keys_copy = copy if copy is not None else MjcfCopy(other_file)
            keys_copy.drop_keys(range(len(keys_copy.key_elements)))
            pmodel = load_pinocchio(keys_copy.write(tmp / "pinocchio"), root_joint=root)
            copies.append(f"Pinocchio refuses the file's keyframes (they do not fit its reading: nq {pmodel.nq}, MuJoCo's "
                         f"{m.nq}): it reads a copy without them (the check does not use keyframes)")
            copy = keys_copy if copy is None else copy
    except InputError as err:
        pinr.refusal = _refusal_in(err, tmp, other_file)
        if not strip and re.search(r"hfield|height ?field|mesh", pinr.refusal, re.IGNORECASE):
            pinr.refusal += " (--strip-geometry removes the geometry)"
    else:
        pinr.model = pmodel
        try:  # a body Pinocchio alone reads as massless is its misreading (MuJoCo reads it as physical)
            check_joint_bodies_physical(pinocchio_joint_bodies(pmodel), str(other_file))
        except InputError as err:
            pin_bad = err
    if pin_bad is not None:
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
            load = load_drake(other_read, root_joint=root)
    except DrakeRefusal as err:
        drr.refusal = str(err).replace(str(tmp), "")
    else:
        drr.model, drr.parser = load, load.warnings
        drr.bodies, drr.details, drr.gravity = drake_joint_bodies(load), drake_joint_details(load), drake_gravity(load)
        notes += [f"Drake: {n}" for n in load.notes]
    if copy is not None:
        copies += copy.changes
    readings = {r.loader: r for r in (mjr, pinr, drr)}
    if not pinr.loaded and not drr.loaded:
        raise InputError(f"{other_file}: only MuJoCo loads the model, nothing to compare it with: "
                         + "; ".join(f"{r.loader}: {r.refusal}" for r in (pinr, drr)))
    return readings, notes, copies


def _with_lost(err: InputError, frozen: GeomInertials | None, copy: bool = False) -> InputError:
    """``err`` with, where stripping the geometry lost geom-derived masses, which and why; the
    copy's line numbers (``copy``) left out (they are not the file's)."""
    if copy:
        err = InputError(re.sub(r",? line \d+", "", str(err)))
    if frozen is None or not frozen.lost:
        return err
    return InputError(f"{err} (--strip-geometry: MuJoCo could not compile the geometry ({frozen.failed}), so the "
                      f"{len(frozen.lost)} body(ies) whose mass it derives from their geoms have none once it is stripped)")


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
                lambda x, d: _fmt(d.damping, _unit("damping", x.kind))),
    "friction loss": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                      lambda x, y, dx, dy, r: bool(np.isclose(dx.friction, dy.friction, rtol=r, atol=1e-12)),
                      lambda x, d: _fmt(d.friction, _unit("friction loss", x.kind))),
    "armature": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                 lambda x, y, dx, dy, r: bool(np.isclose(dx.armature, dy.armature, rtol=r, atol=1e-12)),
                 lambda x, d: _fmt(d.armature, _unit("armature", x.kind))),
}
# a quantity a loader does not hold for a joint (None in its JointDetails) is not voted on
_DETAIL_FIELD = {"joint point": "point_B", "range": None, "damping": "damping", "friction loss": "friction",
                 "armature": "armature"}
# joint settings: counted when every loader reads one file, listed only between an MJCF and a URDF
SETTINGS = ("range", "damping", "friction loss", "armature")
# never counted: only MuJoCo applies a friction loss (Pinocchio stores it, Drake's parsers do not read it)
NOT_COUNTED = ("friction loss",)
# per joint setting, hinge unit and slide unit
_SETTING_UNITS = {"damping": ("N m s/rad", "N s/m"), "friction loss": ("N m", "N"), "armature": ("kg m^2", "kg"),
                  "range": ("rad", "m")}


def _unit(quantity: str, kind: str) -> str:
    """The unit of a joint setting (``_SETTING_UNITS``) for a joint of kind ``kind``: the slide's
    for a translational joint, else the hinge's."""
    hinge, slide = _SETTING_UNITS[quantity]
    jt = JOINTS.get(kind)
    return slide if jt is not None and jt.axis == TRANSLATIONAL else hinge


def _principal_rotation(Ia: np.ndarray, Ib: np.ndarray) -> float:
    """The smallest rotation angle (rad) taking the principal axes of inertia ``Ia`` onto those of
    ``Ib`` (each axis up to its sign); NaN when two principal moments coincide (axes not unique)."""
    ea, Va = np.linalg.eigh(Ia)
    eb, Vb = np.linalg.eigh(Ib)
    top = max(float(np.abs(ea).max()), 1e-300)
    if min(np.diff(ea).min(), np.diff(eb).min()) <= 1e-6 * top:
        return float("nan")
    best = np.pi
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
        R = Vb @ np.diag(signs) @ Va.T
        if np.linalg.det(R) < 0:
            R = Vb @ np.diag([-s for s in signs]) @ Va.T
        best = min(best, float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))
    return best


def _difference(quantity: str, x: JointBody, y: JointBody, dx: JointDetails, dy: JointDetails, rtol: float) -> str:
    """By how much loader reading ``x`` differs from ``y`` in ``quantity``, in words with the unit
    ("" where there is no figure to give: type, presence)."""
    if quantity == "mass":
        dm, big = abs(x.mass - y.mass), max(x.mass, y.mass)
        return f"they differ by {dm:.6g} kg ({100 * dm / big:.3g}% of {big:.6g} kg)" if big > 0 else ""
    if quantity == "centre of mass":
        return f"they differ by {np.linalg.norm(x.p_BCm_B - y.p_BCm_B):.3g} m"
    if quantity == "inertia about the centre of mass":
        diff = float(np.abs(x.I_Cm_B - y.I_Cm_B).max())
        big = max(float(np.abs(x.I_Cm_B).max()), float(np.abs(y.I_Cm_B).max()), 1e-300)
        text = f"they differ by up to {diff:.3g} kg m^2 in an entry ({100 * diff / big:.3g}% of the largest entry)"
        ex, ey = np.linalg.eigvalsh(x.I_Cm_B), np.linalg.eigvalsh(y.I_Cm_B)
        if np.abs(ex - ey).max() <= rtol * max(float(np.abs(ey).max()), 1e-300):
            angle = _principal_rotation(x.I_Cm_B, y.I_Cm_B)
            text += ("; same principal moments: the same inertia in a rotated frame"
                     + (f" (principal axes turned by {angle:.3g} rad)" if np.isfinite(angle) else ""))
        else:
            text += f"; principal moments {_fmt(ex)} and {_fmt(ey)} kg m^2"
        return text
    if quantity == "position in parent":
        return f"they differ by {np.linalg.norm(x.p_PB_P - y.p_PB_P):.3g} m"
    if quantity == "orientation in parent":
        return f"they differ by a rotation of {np.linalg.norm(_rotvec(x.R_PB.T @ y.R_PB)):.3g} rad"
    if quantity == "axis":
        return f"the axes are {float(np.arccos(np.clip(x.axis_B @ y.axis_B, -1.0, 1.0))):.3g} rad apart"
    if quantity == "joint point":
        return f"the points are {_point_gap(x, y, dx, dy):.3g} m apart (across the axis)"
    if quantity == "range" and dx.limits is not None and dy.limits is not None:
        unit = _unit("range", x.kind)
        return (f"the lower bounds differ by {abs(dx.limits[0] - dy.limits[0]):.6g} {unit}, the upper by "
                f"{abs(dx.limits[1] - dy.limits[1]):.6g} {unit}")
    field_name = {"damping": "damping", "friction loss": "friction", "armature": "armature"}.get(quantity)
    if field_name is not None:
        return f"they differ by {abs(getattr(dx, field_name) - getattr(dy, field_name)):.6g} {_unit(quantity, x.kind)}"
    return ""


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
            counted = (one_file or quantity not in SETTINGS) and quantity not in NOT_COUNTED
            v = Vote(name, body, quantity, values, groups, counted=counted)
            detail, hint = "", ""
            if not v.agree and (v.odd is not None or len(who) == 2):
                a, b = (v.odd, groups[0][0]) if v.odd is not None else (who[0], who[1])
                detail = _difference(quantity, x[a], x[b], d[a], d[b], rtol)
            if v.odd is not None:
                hint = readings[v.odd].hints.get(quantity, "")
                if quantity == "range":
                    hint = _degrees_hint(d[v.odd].limits, d[groups[0][0]].limits) or hint
            if not v.agree and quantity == "mass":
                hint = hint or _geom_mass_hint(readings, x, [k for g in groups[1:] for k in g] + list(groups[0]))
            out.append(Vote(name, body, quantity, values, groups, hint, counted, detail))
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
    """Term -> the loader the two others agree against (three loaders: exactly one pair agrees).
    Only the loaders vote here; the witnesses are judged by ``witness_odd``."""
    out = {}
    for term in dc.TERMS:
        rows = [d for d in diffs if d.term == term and d.a in LOADERS and d.b in LOADERS]
        sources = {s for d in rows for s in (d.a, d.b)}
        ok = [d for d in rows if d.passed]
        if len(sources) == 3 and len(rows) == 3 and len(ok) == 1:
            (odd,) = sources - {ok[0].a, ok[0].b}
            out[term] = odd
    return out


def witness_odd(diffs: list[dc.TermDiff]) -> dict[str, list[str]]:
    """Witness -> the terms in which it is the odd one out: it differs from MuJoCo (whose reading it
    was built from) while another loader agrees with MuJoCo in that term. A witness never makes a
    loader the odd one out (it is a witness of dynamics, built from MuJoCo's reading)."""
    out: dict[str, list[str]] = {}
    for term in dc.TERMS:
        rows = [d for d in diffs if d.term == term]
        confirmed = any(d.passed and "MuJoCo" in (d.a, d.b) and {d.a, d.b} <= set(LOADERS) for d in rows)
        for d in rows:
            other = d.b if d.a == "MuJoCo" else d.a if d.b == "MuJoCo" else None
            if other in wit.WITNESSES and not d.passed and confirmed:
                out.setdefault(other, []).append(term)
    return out


# --------------------------------------------------------------------------- what the differences come from
#
# Each finding is tested, not guessed: a cause is named only when putting it back reconciles the
# readings within the check's tolerance (rotating the tensor by the URDF's rpy, swapping one fixed
# child's part between two readings, taking the armature off M's diagonal).

_MASS_QUANTITIES = ("mass", "centre of mass", "inertia about the centre of mass")


def _geom_masses(m: mujoco.MjModel, path: Path, frozen: GeomInertials | None = None) -> dict[str, str]:
    """MuJoCo body name -> how MuJoCo got its mass, for the bodies whose file gives no
    ``<inertial>`` (MJCF body, URDF link; all of them under ``<compiler inertiafromgeom="true">``):
    MuJoCo derives their mass and inertia from their geoms (each geom's ``mass``, else its
    ``density`` times its volume) where another loader may read none (a URDF link without
    ``<inertial>``: mass 0). Bodies ``fusestatic`` fused away are left out. ``frozen``: the
    geometry was stripped (``geom_inertials``: the masses kept, or lost when the geometry did not
    compile). An unnamed body is named ``body<k>`` as the loaders' copy names it."""
    spec = read_mujoco_spec(path)
    from_geoms = spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    out = {}
    for k, body in enumerate(spec.bodies):
        name = body.name or f"body{k}"
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        if k == 0 or bid < 0 or (body.explicitinertial and not from_geoms):
            continue
        why = 'the compiler\'s inertiafromgeom="true" ignores its <inertial>' if from_geoms and body.explicitinertial \
            else f"the {file_format(path)} gives it no <inertial>"
        mass = float(m.body_mass[bid])
        if frozen is None:
            n = int(m.body_geomnum[bid])
            got = f"{mass:.6g} kg from {n} geom(s)" if n else "no geoms, 0 kg"
        elif frozen.failed:
            got = ("0 kg: --strip-geometry removed its geoms, which MuJoCo could not compile" if k in frozen.lost
                   else "no geoms, 0 kg")
        else:
            n = frozen.geoms.get(k, 0)
            got = (f"{mass:.6g} kg from {n} geom(s), kept as an explicit inertial when the geometry was stripped" if n
                   else "no geoms, 0 kg")
        out[name] = f"MuJoCo derives the mass of body {name!r} from its geoms since {why}: {got}"
    return out


def _geom_mass_hint(readings: dict[str, Reading], x: dict[str, JointBody], who: list[str]) -> str:
    """The ``geom_masses`` text of MuJoCo's parts of a joint's body, when MuJoCo reads it."""
    mjr = readings.get("MuJoCo")
    if mjr is None or "MuJoCo" not in who or "MuJoCo" not in x or not mjr.geom_masses:
        return ""
    texts = [mjr.geom_masses[p.name] for p in x["MuJoCo"].parts if p.name in mjr.geom_masses]
    return "; ".join(texts)


def _urdf_links(path: Path) -> list:
    """The ``<link>`` elements of a URDF; none for a file that does not parse as XML."""
    import xml.etree.ElementTree as ET

    try:
        return parse_xml(path, "URDF").findall("link")
    except (ET.ParseError, OSError, InputError):
        return []


def urdf_inertial_frames(path: Path) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """Link name -> (the ``rpy`` of its ``<inertial><origin>`` as written, R: the inertial frame's
    orientation in the link frame (fixed-axis roll, pitch, yaw: R = Rz(y) Ry(p) Rx(r)), the
    ``<inertia>`` tensor as written, in the inertial frame (kg m^2)), for the links whose
    inertial frame is rotated. Empty for a file that does not parse as a URDF."""
    from scipy.spatial.transform import Rotation

    out = {}
    for link in _urdf_links(path):
        inertial = link.find("inertial")
        origin = inertial.find("origin") if inertial is not None else None
        tensor = inertial.find("inertia") if inertial is not None else None
        if origin is None or tensor is None or not origin.get("rpy"):
            continue
        try:
            rpy = [float(c) for c in origin.get("rpy").split()]
            c = {k: float(tensor.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
        except ValueError:
            continue
        if len(rpy) != 3 or not any(rpy):
            continue
        I0 = np.array([[c["ixx"], c["ixy"], c["ixz"]], [c["ixy"], c["iyy"], c["iyz"]], [c["ixz"], c["iyz"], c["izz"]]])
        out[link.get("name")] = (" ".join(origin.get("rpy").split()), Rotation.from_euler("xyz", rpy).as_matrix(), I0)
    return out


def _who(loaders) -> str:
    loaders = list(loaders)
    return " and ".join(loaders) if len(loaders) <= 2 else ", ".join(loaders[:-1]) + " and " + loaders[-1]


def _reading(readings: dict[str, Reading], loaders) -> str:
    """``MuJoCo's reading (of the MJCF)``: the loaders' reading and the file they read."""
    loaders = list(loaders)
    formats = {file_format(readings[k].source) for k in loaders}
    return f"{_who(k + chr(39) + 's' for k in loaders)} reading" + (f" (of the {formats.pop()})" if len(formats) == 1 else "")


def _inertial_rotation(readings: dict[str, Reading], joint: str, body: str, rest: list[str], majority: list[str],
                       bodies, rtol: float) -> Finding | None:
    """A URDF ``<inertial><origin rpy>`` that one group of loaders (``rest`` or ``majority``) applies
    and the other does not: the difference between the two readings of the joint's body is exactly
    the rotation's contribution R I0 R^T - I0 of the link's tensor I0 (within ``rtol`` of the
    largest entry)."""
    y, x = majority[0], rest[0]
    Iy, Ix = bodies[y][joint].I_Cm_B, bodies[x][joint].I_Cm_B
    scale = max(float(np.abs(Ix).max()), float(np.abs(Iy).max()), 1e-300)
    for source in dict.fromkeys(readings[k].source for k in (y, x) if file_format(readings[k].source) == "URDF"):
        frames = urdf_inertial_frames(source)
        if body not in frames:
            continue
        rpy, R, I0 = frames[body]
        turn = R @ I0 @ R.T - I0
        for sign, rotated, plain in ((+1, x, y), (-1, y, x)):   # Ix - Iy = +turn: x rotates, y does not
            residual = float(np.abs(Ix - Iy - sign * turn).max())
            if residual > rtol * scale:
                continue
            rot = majority if rotated == y else rest
            unrot = majority if plain == y else rest
            diff = float(np.abs(Ix - Iy).max())
            angle = float(np.linalg.norm(_rotvec(R)))
            text = (f"joint {joint!r} (body {body!r}): inertia about the centre of mass differs by up to {diff:.3g} "
                    f"kg m^2 in an entry ({100 * diff / scale:.3g}% of the largest entry). Cause: the URDF's inertial-frame "
                    f"rotation (rpy): link {body!r} has <inertial><origin rpy=\"{rpy}\"> (a rotation of {angle:.3g} rad); "
                    f"{_reading(readings, rot)} has the tensor rotated by it, {_reading(readings, unrot)} has it "
                    f"unrotated: rotating the unrotated tensor by that rpy reconciles the readings (to {residual:.1e} "
                    "kg m^2). Check which file states the inertial frame as intended")
            return Finding("inertial rotation", joint, body,
                           f"inertial frame of link {body!r} rotated by the URDF's rpy=\"{rpy}\" "
                           f"(not in {_who(unrot)}'s reading)", text)
    return None


def _same_body(x: JointBody, mass: float, com: np.ndarray, inertia: np.ndarray, rtol: float) -> bool:
    """Whether (mass, com, inertia) is the body ``x`` within the check's tolerance (``QUANTITIES``)."""
    from dataclasses import replace

    y = replace(x, mass=mass, p_BCm_B=com, I_Cm_B=inertia)
    return all(bool(QUANTITIES[q][1](x, y, None, None, rtol)) for q in _MASS_QUANTITIES)


def urdf_link_masses(path: Path) -> dict[str, float]:
    """Link name -> the ``<inertial><mass value>`` a URDF states (kg); empty for a file that does
    not parse as a URDF."""
    out = {}
    for link in _urdf_links(path):
        mass = link.find("inertial/mass")
        try:
            out[link.get("name")] = float(mass.get("value")) if mass is not None else 0.0
        except (TypeError, ValueError):
            continue
    return out


def _fixed_child(readings: dict[str, Reading], joint: str, body: str, xs: list[str], ys: list[str], bodies,
                 rtol: float) -> Finding | None:
    """One fixed child whose mass properties account for the difference between the readings
    ``xs`` and ``ys`` (each a group of loaders that agree) of a joint's merged body: a reading of
    ``ys`` with that child's part taken from the ``xs`` reading (or removed, where that reading
    has no such part) is the ``xs`` reading exactly (within ``rtol``)."""
    from harness.tools.loaded_models import _composite

    x = bodies[xs[0]][joint]
    x_parts = {p.name: p for p in x.parts}
    for y_name in ys:
        y = bodies[y_name][joint]
        if not y.parts:
            continue
        y_parts = {p.name: p for p in y.parts}
        for child in [n for n in dict.fromkeys(list(y_parts) + list(x_parts)) if n not in (x.body, y.body)]:
            swapped = [p for p in y.parts if p.name != child] + ([x_parts[child]] if child in x_parts else [])
            if not swapped or not _same_body(x, *_composite(swapped), rtol):
                continue
            m_x = x_parts[child].mass if child in x_parts else 0.0
            m_y = y_parts[child].mass if child in y_parts else 0.0
            state_x = f"{m_x:.6g} kg" if child in x_parts else "absent"
            state_y = f"{m_y:.6g} kg" if child in y_parts else "absent"
            (heavy, m_heavy), light = ((xs, m_x), ys) if m_x > m_y else ((ys, m_y), xs)
            m_light = min(m_x, m_y)
            dm = abs(x.mass - y.mass)
            stated, file_mass = "", None
            for k in dict.fromkeys(xs + ys):
                if file_format(readings[k].source) == "URDF":
                    file_mass = urdf_link_masses(readings[k].source).get(child)
                    if file_mass is not None:
                        stated = f"; the URDF states <mass value=\"{file_mass:g}\"> for link {child!r}"
                        break
            where = f"link {child!r}, on a fixed joint below {body!r},"
            tol_m = rtol * max(x.mass, y.mass, 1e-300)
            if dm > tol_m and m_light == 0.0 and file_mass is not None and abs(file_mass - m_light) <= tol_m:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: a fixed "
                        f"child's mass that the file does not state: {where} weighs {m_heavy:.6g} kg in "
                        f"{_reading(readings, heavy)}, where the URDF states <mass value=\"{file_mass:g}\"> for it, as "
                        f"{_reading(readings, light)} has it; the mass difference equals that {m_heavy:.6g} kg, and with "
                        "the child's part swapped the readings agree")
                short = (f"fixed child {child!r} of body {body!r} given {m_heavy:.6g} kg by {_who(heavy)} "
                         f"(the URDF states {file_mass:g} kg)")
            elif dm > tol_m and m_light == 0.0:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: a fixed "
                        f"child's inertia is missing in {_reading(readings, light)}: {where} weighs {m_heavy:.6g} kg "
                        f"in {_reading(readings, heavy)} and 0 kg in {_reading(readings, light)}; the mass "
                        f"difference equals the child's mass, and with the child's part put back the readings agree{stated}")
                short = f"fixed child {child!r} of body {body!r} missing in {_who(light)}'s reading ({m_heavy:.6g} kg)"
            elif dm > tol_m:
                text = (f"joint {joint!r} (body {body!r}): the merged body's mass differs by {dm:.6g} kg. Cause: the fixed "
                        f"child {child!r} (on a fixed joint below {body!r}) weighs {state_x} in "
                        f"{_reading(readings, xs)} and {state_y} in {_reading(readings, ys)}; with its part swapped the "
                        f"readings agree{stated}")
                short = f"fixed child {child!r} of body {body!r} read differently by {_who(xs)}"
            else:
                I_x = x_parts[child].I_Cm_B if child in x_parts else None
                I_y = y_parts[child].I_Cm_B if child in y_parts else None
                lacking = xs if I_x is None or not np.any(I_x) else (ys if I_y is None or not np.any(I_y) else None)
                mj = bodies.get("MuJoCo", {}).get(joint)
                fused = (" (MuJoCo fused the link into its parent: fusestatic)"
                         if lacking is not None and "MuJoCo" in lacking and mj is not None
                         and child not in {p.name for p in mj.parts} else "")
                if lacking is not None:
                    has = ys if lacking is xs else xs
                    I_has = I_y if lacking is xs else I_x
                    text = (f"joint {joint!r} (body {body!r}): the merged body's inertia differs, its mass does not. Cause: "
                            f"a fixed child's inertia is missing in {_reading(readings, lacking)}: {where} of mass "
                            f"{max(m_x, m_y):.6g} kg, has the rotational inertia {_fmt(I_has, 'kg m^2')} in "
                            f"{_reading(readings, has)} and none in {_reading(readings, lacking)}{fused}; with its part put "
                            f"back the readings agree{stated}")
                    short = f"inertia of fixed child {child!r} of body {body!r} missing in {_who(lacking)}'s reading"
                else:
                    text = (f"joint {joint!r} (body {body!r}): the merged body's inertia differs, its mass does not. Cause: "
                            f"the fixed child {child!r}'s rotational inertia: {_fmt(I_x, 'kg m^2')} in "
                            f"{_reading(readings, xs)}, {_fmt(I_y, 'kg m^2')} in {_reading(readings, ys)}{stated}")
                    short = f"inertia of fixed child {child!r} of body {body!r} read differently by {_who(xs)}"
            hint = _geom_mass_hint(readings, {k: bodies[k][joint] for k in xs + ys}, xs + ys)
            return Finding("fixed child", joint, body, short, text + (f"; {hint}" if hint else ""))
    return None


def _armature_finding(readings: dict[str, Reading], v: Vote, details) -> Finding | None:
    """A joint's armature that some loaders read and others do not (0: a URDF cannot state one),
    with what it adds to M's diagonal entry of the joint (MuJoCo's M at zero joint coordinates)."""
    values = {k: details[k][v.joint].armature for k in v.values}
    nonzero = [k for k, a in values.items() if a]
    zero = [k for k, a in values.items() if not a]
    if not nonzero or not zero or any(set(nonzero) - set(g) and set(nonzero) & set(g) for g in v.groups):
        return None   # nothing read as 0, or the loaders that read an armature read different ones
    kind = next(x.kind for x in readings[nonzero[0]].bodies if x.joint == v.joint)
    unit = _unit("armature", kind)
    arm = values[nonzero[0]]
    urdf_zero = all(file_format(readings[k].source) == "URDF" for k in zero)
    zeros = f"{_who(zero)} read{'s' if len(zero) == 1 else ''} 0"
    only = "only one loader reads it" if len(nonzero) == 1 else f"only {_who(nonzero)} read it"
    text = (f"joint {v.joint!r} (body {v.body!r}): armature: {_who(nonzero)} read{'s' if len(nonzero) == 1 else ''} "
            f"{arm:.6g} {unit}, " + (f"the URDF has no armature ({zeros} — {only})" if urdf_zero else f"{zeros}: {only}"))
    mjr = readings["MuJoCo"]
    jid = mujoco.mj_name2id(mjr.model, mujoco.mjtObj.mjOBJ_JOINT, v.joint)
    if jid >= 0:
        m = mjr.model
        d = mujoco.MjData(m)
        d.qpos[:] = _zero_qpos(m)
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        dof = int(m.jnt_dofadr[jid])
        rigid = float(M[dof, dof]) - float(m.dof_armature[dof])
        text += (f"; it adds {arm:.6g} {unit} to the diagonal entry of {v.joint!r} in the mass matrix M: "
                 f"{rigid + arm:.6g} {unit} with it, {rigid:.6g} {unit} without, at zero joint coordinates "
                 f"(+{100 * arm / rigid:.3g}%)" if rigid > 0 else "")
    return Finding("armature", v.joint, v.body, f"armature of joint {v.joint!r} only in {_who(nonzero)} ({arm:.6g} {unit})",
                   text, f"armature only in {_who(nonzero)}")


def _first_joint_at_parent(readings: dict[str, Reading], v: Vote, details, rtol: float) -> Finding | None:
    """The odd one out's joint point of the first joint of a MuJoCo body with several joints
    lying at the origin of the body's parent (across the axis, within ``rtol`` of the body's
    size): the importer puts that joint at the parent's origin instead of the body's (Drake's
    MJCF parser, which gives such a body a chain of massless bodies, one joint each)."""
    mjr = readings["MuJoCo"]
    m = mjr.model
    j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, v.joint)
    if j < 0 and v.joint.startswith("joint") and v.joint[5:].isdigit():
        j = int(v.joint[5:])
    if j < 0 or j >= m.njnt:
        return None
    b = int(m.jnt_bodyid[j])
    if m.body_jntnum[b] < 2 or m.body_jntadr[b] != j:
        return None
    d = mujoco.MjData(m)
    d.qpos[:] = _zero_qpos(m)
    mujoco.mj_kinematics(m, d)
    parent = int(m.body_parentid[b])
    R_WB = d.xmat[b].reshape(3, 3)
    origin = R_WB.T @ (d.xpos[parent] - d.xpos[b])   # the parent's origin in B
    x = next(y for y in mjr.bodies if y.joint == v.joint)
    odd = details[v.odd][v.joint]
    gap = odd.point_B - origin
    if JOINTS[x.kind].axis is not None:
        gap = gap - (gap @ x.axis_B) * x.axis_B
    size = max(float(np.linalg.norm(origin)), 1e-3)
    if float(np.linalg.norm(gap)) > rtol * size:
        return None
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, k) or f"joint{k}"
             for k in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b]))]
    parent_name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, parent) or ("world" if parent == 0 else f"body{parent}")
    others = [k for k in v.values if k != v.odd]
    far = float(np.linalg.norm(details[others[0]][v.joint].point_B - odd.point_B))
    text = (f"joint {v.joint!r} (body {v.body!r}): joint point: {v.odd} puts the first of the body's {len(names)} joints "
            f"({', '.join(names)}) at the origin of the parent body {parent_name!r}, {far:.3g} m from where "
            f"{_who(others)} put it (at the body, as the file places its joints); the body turns about an axis through "
            "the parent's origin there, so its M, bias and gravity differ too"
            + (" (Drake's MJCF parser gives a body with several joints a chain of massless bodies, one joint each)"
               if v.odd == "Drake" else ""))
    return Finding("several joints", v.joint, v.body,
                   f"{v.odd} puts the first joint of body {v.body!r} ({v.joint}) at its parent's origin", text,
                   f"{v.odd} puts a body's first joint at its parent's origin")


def diagnose(readings: dict[str, Reading], votes: list[Vote], rtol: float) -> list[Finding]:
    """What the model disagreements come from, per joint: a fixed child's mass properties, a
    rotated URDF inertial frame, an armature only some loaders read, the first of a body's several
    joints placed at the parent's origin (see ``Finding``). Each
    group of agreeing loaders of a disagreeing vote is compared with each earlier group, the
    majority first; a cause is named only when it reconciles the two readings within ``rtol``,
    and a pair of readings of a joint is explained once."""
    loaded = [r for r in readings.values() if r.loaded]
    bodies = {r.loader: {x.joint: x for x in r.bodies} for r in loaded}
    details = {r.loader: {x.joint: x for x in r.details} for r in loaded}
    out: list[Finding] = []
    explained: set[tuple[str, str, str]] = set()   # (joint, loader, loader) pairs a finding covers
    for v in votes:
        if v.agree or not v.joint:
            continue
        if v.quantity == "armature":
            f = _armature_finding(readings, v, details)
            if f is not None:
                out.append(f)
            continue
        if v.quantity == "joint point" and v.odd is not None:
            f = _first_joint_at_parent(readings, v, details, rtol)
            if f is not None:
                out.append(f)
            continue
        if v.quantity not in _MASS_QUANTITIES:
            continue
        for i, xs in enumerate(v.groups[1:], start=1):
            for ys in v.groups[:i]:
                pairs = {(v.joint, a, b) for a in xs for b in ys} | {(v.joint, b, a) for a in xs for b in ys}
                if pairs <= explained:
                    continue
                xs_, ys_ = list(xs), list(ys)
                f = _fixed_child(readings, v.joint, v.body, xs_, ys_, bodies, rtol)
                if f is None and v.quantity == "inertia about the centre of mass":
                    f = _inertial_rotation(readings, v.joint, v.body, xs_, ys_, bodies, rtol)
                if f is not None:
                    out.append(f)
                    explained |= pairs
    return out


def diagnose_dynamics(readings: dict[str, Reading], jmap: dc.JointMap, terms: dict[str, list], diffs, rtol: float) -> list[Finding]:
    """M differing between two sources by exactly their armature difference on the diagonal (at
    every state, within ``rtol`` of M's largest entry) while bias and gravity agree."""
    failed = [d for d in diffs if d.term == "M" and not d.passed]
    if not failed:
        return []
    arm = {}
    for k in terms:
        det = {x.joint: x for x in readings[k].details}
        a = np.zeros(jmap.nv)
        for s in jmap.slots:
            if s.joint.nv == 1 and s.name in det and det[s.name].armature:
                a[s.vc] = det[s.name].armature
        arm[k] = a
    explained, worst = [], 0.0
    for d in failed:
        delta = arm[d.a] - arm[d.b]
        if not np.any(delta):
            continue
        scale = max(float(np.max(np.abs(t.M))) for k in (d.a, d.b) for t in terms[k])
        residual = max(float(np.max(np.abs(ta.M - tb.M - np.diag(delta)))) for ta, tb in zip(terms[d.a], terms[d.b]))
        if residual <= rtol * scale:
            explained.append(d)
            worst = max(worst, residual / scale)
    if not explained:
        return []
    first = explained[0]
    delta = arm[first.a] - arm[first.b]
    entries = "; ".join(f"{s.name} {delta[s.vc]:+.6g} {_unit('armature', s.kind)}" for s in jmap.slots
                        if s.joint.nv == 1 and delta[s.vc])
    pairs = " and ".join(f"M_{d.a} - M_{d.b}" for d in explained)
    involved = {e.a for e in explained} | {e.b for e in explained}
    others = [d for d in diffs if d.term != "M" and not d.passed and {d.a, d.b} & involved]
    text = (f"dynamics M: {pairs} {'is' if len(explained) == 1 else 'are'} exactly the armature difference on M's "
            f"diagonal at every state ({entries}); with it taken off, M agrees to {worst:.1e} relative"
            + ("" if others else "; bias and gravity agree: the armature is the whole difference in the dynamics terms"))
    return [Finding("dynamics armature", "", "", "dynamics M differ by the armature on the diagonal", text)]


# --------------------------------------------------------------------------- dynamics: joints of each loader


def _pinocchio_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Pinocchio coordinates for ``dynamics_terms.joint_map``; None (with
    ``r.dynamics`` saying why) when Pinocchio's joints are not MuJoCo's or its bodies are not
    physical."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = r.dynamics or _joint_set_problem(mjr, kinds, r)
    if why:
        r.dynamics = why
        return None
    return {name: {"pin_q": s.idx_q, "pin_v": s.idx_v, "pin_joint": s.jid, "pin_nq": s.nq} for name, s in r.slots.items()}


def _drake_table(mjr: Reading, r: Reading) -> dict | None:
    """Joint name -> Drake coordinates (``position_start``, ``velocity_start``); None (with
    ``r.dynamics`` saying why) when Drake's moving joints are not MuJoCo's, or are of a kind
    whose Drake coordinates are not mapped (Drake's ball joint has roll-pitch-yaw angles)."""
    kinds = {x.joint: x.kind for x in r.bodies}
    why = _joint_set_problem(mjr, kinds, r)
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


def _whole_trees(mjr: Reading, missing: list[str]) -> list[str]:
    """The root bodies of MuJoCo's kinematic trees (bodies on the world) that hold ``missing``
    joints, when every joint of those trees is missing (whole trees); else []."""
    m = mjr.model
    tree = {x.joint: int(m.body_rootid[m.jnt_bodyid[j]]) for j, x in enumerate(mjr.bodies)}
    roots = {tree[n] for n in missing}
    if any(t in roots and n not in missing for n, t in tree.items()):
        return []
    return [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}" for b in sorted(roots)]


def _joint_set_problem(mjr: Reading, kinds: dict[str, str], r: Reading | None = None) -> str:
    """Why a loader's joints (name -> kind) cannot be put into MuJoCo's coordinates ("" when they
    can). A loader that lacks whole kinematic trees of MuJoCo's (every joint of a tree, and has
    some joints) is compared on the trees it has: ``r.partial`` lists the joints it lacks."""
    mj = {x.joint: x.kind for x in mjr.bodies}
    missing, extra = [n for n in mj if n not in kinds], [n for n in kinds if n not in mj]
    if missing and not extra and len(missing) < len(mj) and _whole_trees(mjr, missing) and r is not None:
        r.partial, missing = missing, []
    if missing or extra:
        return "its joints are not MuJoCo's (" + "; ".join(
            ([f"no {', '.join(missing)}"] if missing else []) + ([f"{', '.join(extra)} not in MuJoCo"] if extra else [])) + ")"
    other = [f"{n} is {kinds[n]}, MuJoCo's {k}" for n, k in mj.items() if n in kinds and kinds[n] != k]
    return f"its joint types differ from MuJoCo's ({'; '.join(other)})" if other else ""


def run_check(mjcf: Path | None, urdf: Path | None, *, seed: int = 0, n_states: int = dc.DEFAULT_STATES,
              n_free: int = 3, t_end: float = 0.5, dt: float = 1e-3, save_every: float = 0.01,
              floating_base: bool = False, strip: bool = False, keep_static: bool = False,
              joint_map: dict[str, str] | None = None, witnesses: bool = True, progress=None,
              allowed_dirs: tuple[Path, ...] = ()) -> CheckResult:
    """Load, compare models, dynamics terms and free motion (see module docstring); ``allowed_dirs``:
    folders besides the model's own that its includes and assets may lie in (``load_models``); ``joint_map``:
    MJCF joint name -> URDF joint name (``apply_joint_map``); ``witnesses``: also the in-house
    engine and Exudyn built from MuJoCo's reading (``harness.tools.witnesses``); ``progress``: a
    bar (``harness.io.progress.make_bar``) whose total is set to the stages (the loads, the
    witnesses, the dynamics terms, each free-motion run, the witnesses' runs), ticked as each
    ends; or None."""
    clock = [time.perf_counter()]

    def tick(label: str, n: int = 1) -> None:
        if progress is not None:
            now = time.perf_counter()
            progress.done(f"{label} {now - clock[0]:.1f} s", n)
            clock[0] = now

    for label, value in (("--t-end", t_end), ("--dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"{label} must be positive and finite, got {value!r}")
    check_steps(t_end, dt, "--t-end and --dt")  # before any model is loaded or run
    if n_states < 1 or n_free < 0:
        raise InputError("--states must be >= 1 and --free-runs >= 0")
    if progress is not None:
        progress.total = 4 + n_free
        progress.refresh()
    readings, mode, notes, copies = load_models(mjcf, urdf, floating_base=floating_base, strip=strip,
                                                keep_static=keep_static, joint_map=joint_map, allowed_dirs=allowed_dirs)
    name = Path(urdf if urdf is not None else mjcf).stem
    tick(f"{name} loaded: " + ", ".join(f"{k} {'ok' if r.loaded else 'no'}" for k, r in readings.items()))
    res = CheckResult(name, mode, "floating (free root joint 'root_joint')" if floating_base else "fixed", readings)
    res.notes += notes
    res.copies = copies
    res.not_compared = not_compared(readings["MuJoCo"].model)
    res.mapped = sum(1 for k, v in readings["Pinocchio"].names.items() if k != v)
    mjr, pinr, drr = (readings[k] for k in LOADERS)
    m = mjr.model
    rtol = SAME_FILE_RTOL if len({r.source for r in readings.values() if r.loaded}) == 1 else TWO_FILES_RTOL
    res.votes = vote(readings, rtol)
    res.findings = diagnose(readings, res.votes, rtol)
    res.notes += importer_notes(readings)
    pin_table = _pinocchio_table(mjr, pinr) if pinr.loaded else None
    drake_table = _drake_table(mjr, drr) if drr.loaded else None
    res.notes += _first_tree_note(readings)
    lacking = {n for r, t in ((pinr, pin_table), (drr, drake_table)) if t is not None for n in r.partial}
    jmap = dc.joint_map(m, pin_table, drake_table, only=[x.joint for x in mjr.bodies if x.joint not in lacking])
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
    if witnesses:
        res.witnesses = _witnesses(res, mjr, jmap, sources)
    tick(f"{name} witnesses {'built' if witnesses else 'not asked for'}")
    with captured_warnings() as caught:  # MuJoCo's warnings go into the result, not onto stderr
        try:
            if len(sources) >= 2:
                terms = dc.evaluate(sources, states)
                res.dynamics = dc.compare_terms(terms, rtol=max(dc.DEFAULT_RTOL, rtol))
            w = res.witnesses
            if w is not None and w.source is not None:
                start = time.perf_counter()
                wterms = dc.evaluate({"in-house": w.source}, states)
                loader_terms = terms if len(sources) >= 2 else dc.evaluate(sources, states)
                w.dynamics = dc.compare_terms(loader_terms | wterms, pairs=[(k, "in-house") for k in loader_terms],
                                              rtol=max(dc.DEFAULT_RTOL, rtol))
                w.wall_s += time.perf_counter() - start
            if len(sources) >= 2:
                res.findings += diagnose_dynamics(readings, jmap, {k: t for k, t in terms.items() if k in LOADERS},
                                                  [d for d in res.dynamics if d.a in LOADERS and d.b in LOADERS],
                                                  max(dc.DEFAULT_RTOL, rtol))
            tick(f"{name} dynamics terms at {n_states} states")
            if pin_table is None:
                res.free_skipped = ("Pinocchio does not load the file" if not pinr.loaded
                                    else f"Pinocchio's dynamics are not compared ({pinr.dynamics})")
                res.free_skipped += "; the free motion compares MuJoCo with Pinocchio only"
                tick(f"{name} free motion skipped", n_free)
            else:
                frames = _pinocchio_frames(mjr, pinr)
                for k, (q, v) in enumerate(dc.random_states(jmap, n_free, seed + 1)):
                    res.free.append(free_motion(m, pinr.model, jmap, q, v, k, t_end=t_end, dt=dt, save_every=save_every,
                                                frames=frames))
                    tick(f"{name} free motion {k + 1}/{n_free}")
            w = res.witnesses
            if w is not None and not w.refusal:
                wit.run(w, m, jmap, dc.random_states(jmap, n_free, seed + 1), t_end=t_end, dt=dt, save_every=save_every,
                        rigid=_rigid_copy(m, dt))
            tick(f"{name} witness runs {'done' if w is not None and not w.refusal else 'not run'}")
        finally:
            res.warnings = caught.stats()
    return res


def _witnesses(res: CheckResult, mjr: Reading, jmap: dc.JointMap, sources: dict) -> wit.Witnesses:
    """The witnesses' description of MuJoCo's reading, their model rows and the in-house dynamics
    source (added to ``sources``); refused in one line when the description cannot hold the model."""
    start = time.perf_counter()
    w = wit.describe(mjr.model, mjr.source)
    if not w.refusal:
        try:
            w.rows = wit.model_rows(w, mjr.bodies, res.settings["rtol_model"])
            w.source = wit.inhouse_source(w, jmap)
        except Exception as err:  # noqa: BLE001 - an engine that does not build this model is reported, not a crash
            w = wit.Witnesses(refusal=f"{type(err).__name__}: {_one_line(err)}")
    w.wall_s = time.perf_counter() - start
    return w


def _rigid_copy(m: mujoco.MjModel, dt: float) -> mujoco.MjModel:
    """MuJoCo's rigid model of the free motion (``free_motion``)."""
    rigid = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
                         | mujoco.mjtDisableBit.mjDSBL_DAMPER | mujoco.mjtDisableBit.mjDSBL_SPRING
                         | mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    rigid.body_gravcomp[:] = 0.0
    rigid.opt.density, rigid.opt.viscosity = 0.0, 0.0
    return rigid


def _first_tree_note(readings: dict[str, Reading]) -> list[str]:
    """A note when Pinocchio's reading of an MJCF is exactly the first body under ``<worldbody>``
    and its subtree (its MJCF parser stops there), the other trees missing (``Reading.partial``)."""
    mjr, pinr = readings["MuJoCo"], readings["Pinocchio"]
    if not pinr.loaded or not pinr.partial or file_format(pinr.source) != "MJCF":
        return []
    m = mjr.model
    first = next((b for b in range(1, m.nbody) if m.body_parentid[b] == 0), None)
    trees = {int(m.body_rootid[m.jnt_bodyid[j]]) for j in range(m.njnt)}
    has = {int(m.body_rootid[m.jnt_bodyid[j]]) for j, x in enumerate(mjr.bodies) if x.joint not in pinr.partial}
    if first is None or has != {first}:
        return []
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, first) or f"body{first}"
    return [f"Pinocchio's MJCF parser reads only the first body under <worldbody> ({name!r}) and its subtree: the "
            f"{len(trees) - 1} other kinematic tree(s) of the file, with the joints {_few(pinr.partial, 8)}, are not in "
            "its reading"]


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
        composites = [pmodel.names[jid] for jid in sorted({s.jid for s in pinr.slots.values() if s.sub >= 0})]
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
                         "parsers do not read it): " + "; ".join(friction) + " (compared as `friction loss`, never counted)")
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
    if mjr.geom_masses:
        two = len({r.source for r in readings.values() if r.loaded}) > 1
        notes.append(f"masses derived from geoms vs given: {len(mjr.geom_masses)} body(ies) whose mass MuJoCo derives from "
                     "their geoms (a geom's mass, else its density times its volume); every other body's mass is given by "
                     "its <inertial>" + (" (Pinocchio and Drake read the URDF's <inertial> elements)" if two else "") + ": "
                     + "; ".join(text.removeprefix("MuJoCo derives the mass of ") for text in mjr.geom_masses.values()))
    several = {b: js for b, js in _body_joints(m).items() if len(js) > 1}
    if several and drr.loaded and file_format(drr.source) == "MJCF":
        notes.append(f"{len(several)} body(ies) with several joints (" + _few(f"{b}: {', '.join(js)}" for b, js in
                                                                             several.items()) + "): Drake's MJCF parser "
                     "gives each a chain of massless bodies, one joint each (<body>0, <body>1, ...), compared here as "
                     "the one body MuJoCo moves by its joints in order")
    if m.neq and file_format(mj_file) == "URDF":
        notes.append("MuJoCo turns a URDF <mimic> into an equality constraint (listed under Not compared); Pinocchio's "
                     "default URDF import treats a mimic joint as an independent joint")
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


_EQ_OBJECTS = {"connect": mujoco.mjtObj.mjOBJ_BODY, "weld": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT,
               "tendon": mujoco.mjtObj.mjOBJ_TENDON, "flex": mujoco.mjtObj.mjOBJ_FLEX}
_TRANSMISSIONS = {mujoco.mjtTrn.mjTRN_JOINT: ("joint", mujoco.mjtObj.mjOBJ_JOINT),
                  mujoco.mjtTrn.mjTRN_JOINTINPARENT: ("joint", mujoco.mjtObj.mjOBJ_JOINT),
                  mujoco.mjtTrn.mjTRN_TENDON: ("tendon", mujoco.mjtObj.mjOBJ_TENDON),
                  mujoco.mjtTrn.mjTRN_SITE: ("site", mujoco.mjtObj.mjOBJ_SITE),
                  mujoco.mjtTrn.mjTRN_BODY: ("body", mujoco.mjtObj.mjOBJ_BODY),
                  mujoco.mjtTrn.mjTRN_SLIDERCRANK: ("slider-crank at site", mujoco.mjtObj.mjOBJ_SITE)}


def not_compared(m: mujoco.MjModel) -> list[str]:
    """What MuJoCo's model holds beyond the tree of joints and bodies, which the check does not
    compare: its equality constraints, tendons and actuators, one line per kind with the count and
    each element's name (or kind and index), e.g. ``1 equality constraint: weld world-cylinder``.
    The dynamics terms leave them out (M, bias and gravity of the tree alone) and so does MuJoCo's
    rigid free motion (constraints and actuators off)."""
    def name(obj, i: int, fallback: str) -> str:
        return (mujoco.mj_id2name(m, obj, int(i)) or fallback) if i >= 0 else "world"

    out = []
    if m.neq:
        items = []
        objtypes = getattr(m, "eq_objtype", None)
        for i in range(m.neq):
            kind = mujoco.mjtEq(m.eq_type[i]).name[5:].lower()
            obj = _EQ_OBJECTS.get(kind, mujoco.mjtObj.mjOBJ_BODY)
            if objtypes is not None and kind in ("connect", "weld") and int(objtypes[i]) == int(mujoco.mjtObj.mjOBJ_SITE):
                obj = mujoco.mjtObj.mjOBJ_SITE
            what = obj.name[6:].lower()
            ends = [name(obj, int(o), f"{what}{int(o)}") for o in (m.eq_obj1id[i], m.eq_obj2id[i])
                    if not (kind in ("joint", "tendon") and int(o) < 0)]
            own = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, i)
            items.append(f"{own + ': ' if own else ''}{kind} {'-'.join(ends)}")
        out.append(f"{m.neq} equality constraint{'s' if m.neq != 1 else ''}: {_few(items)}")
    if m.ntendon:
        items = []
        for t in range(m.ntendon):
            first = int(m.wrap_type[m.tendon_adr[t]]) if m.tendon_num[t] else -1
            kind = "fixed" if first == int(mujoco.mjtWrap.mjWRAP_JOINT) else "spatial"
            items.append(f"{name(mujoco.mjtObj.mjOBJ_TENDON, t, f'tendon{t}')} ({kind})")
        out.append(f"{m.ntendon} tendon{'s' if m.ntendon != 1 else ''}: {_few(items)}")
    if m.nu:
        items = []
        for a in range(m.nu):
            what, obj = _TRANSMISSIONS.get(mujoco.mjtTrn(m.actuator_trntype[a]), ("target", None))
            target = name(obj, int(m.actuator_trnid[a, 0]), f"{what}{int(m.actuator_trnid[a, 0])}") if obj else "?"
            gear = np.asarray(m.actuator_gear[a], dtype=float)
            gear_text = f"{gear[0]:g}" if not np.any(gear[1:]) else "[" + " ".join(f"{g:g}" for g in gear) + "]"
            items.append(f"{name(mujoco.mjtObj.mjOBJ_ACTUATOR, a, f'actuator{a}')} ({what} {target}, gear {gear_text})")
        out.append(f"{m.nu} actuator{'s' if m.nu != 1 else ''}: {_few(items)}")
    return out


def free_motion(m: mujoco.MjModel, pmodel: pin.Model, jmap: dc.JointMap, q0: np.ndarray, v0: np.ndarray, k: int, *,
                t_end: float, dt: float, save_every: float, frames: dict[int, int] | None = None) -> FreeMotion:
    """Unforced motion under gravity from (q0, v0) (common coordinates) in both engines.

    MuJoCo: RK4 at ``dt``, contacts, constraints (limits, equalities, friction loss), passive
    forces (damping, springs, gravity compensation, fluid forces) and actuators disabled, so that
    both integrate M a + C v + g = 0. Pinocchio: ``aba`` with zero torque and ``rkmk4_step`` at
    ``dt``. A second MuJoCo run with only contacts off measures how far limits, equality
    constraints, damping and actuators move the joints (``constrained_joint``; informational).
    ``frames``: MuJoCo body id -> Pinocchio frame id of each moving body (``_pinocchio_frames``;
    default: Pinocchio's BODY frame of the MuJoCo body's name).
    """
    steps_per_save = max(1, int(round(save_every / dt)))
    n_saves = max(1, int(round(t_end / (steps_per_save * dt))))
    rigid = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
                         | mujoco.mjtDisableBit.mjDSBL_DAMPER | mujoco.mjtDisableBit.mjDSBL_SPRING
                         | mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    rigid.body_gravcomp[:] = 0.0            # MuJoCo's own passive forces, not in M a + C v + g = 0
    rigid.opt.density, rigid.opt.viscosity = 0.0, 0.0
    as_file = _mujoco_copy(m, dt, mujoco.mjtDisableBit.mjDSBL_CONTACT)
    if frames is None:
        bodies = [b for b in range(1, m.nbody) if m.body_jntnum[b] > 0]
        frames = {b: pmodel.getFrameId(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b), pin.FrameType.BODY)
                  for b in bodies}
    bodies, frames = list(frames), list(frames.values())
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
                worst_body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
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


def _pinocchio_frames(mjr: Reading, pinr: Reading) -> dict[int, int]:
    """MuJoCo body id -> the Pinocchio frame of the same body, for every body a joint moves: the
    body of Pinocchio's joint of the same name (joints are matched by name, through the joint map
    if any), its BODY frame (a URDF link's, an MJCF body's)."""
    m, pmodel = mjr.model, pinr.model
    pin_body = {x.joint: x.body for x in pinr.bodies}
    out = {}
    for j, x in enumerate(mjr.bodies):   # MuJoCo's joint order
        b = int(m.jnt_bodyid[j])
        name = pin_body.get(x.joint)
        if name is None:
            continue
        out[b] = (pmodel.getFrameId(name, pin.FrameType.BODY) if pmodel.existFrame(name, pin.FrameType.BODY)
                  else pmodel.getFrameId(name))
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
    w_dyn = res.witnesses.dynamics if res.witnesses is not None else []
    w_odd = witness_odd(res.dynamics + w_dyn)
    for label, terms in w_odd.items():
        parts.append(f"{label} is the odd one out: " + ", ".join(f"dynamics {t}" for t in terms))
    explained = {(d.a, d.b, d.term) for d in res.dynamics + w_dyn
                 if d.term in dyn_odd and dyn_odd[d.term] in (d.a, d.b)
                 or any(x in w_odd and d.term in w_odd[x] for x in (d.a, d.b))}
    bad_terms = sorted({d.term for d in res.dynamics + w_dyn if not d.passed and (d.a, d.b, d.term) not in explained})
    if bad_terms:
        parts.append(f"dynamics {', '.join(bad_terms)} differ")
    if not res.free_passed:
        parts.append("free motion differs (MuJoCo vs Pinocchio)")
    w = res.witnesses
    if w is not None and not w.refusal:
        held = sorted({r.witness for r in w.rows if not r.ok})
        if held:
            parts.append(f"{' and '.join(held)} hold(s) another model than the description built from MuJoCo's reading")
        for label in wit.WITNESSES:
            bad = [f for f in w.free if f.witness == label and not f.passed]
            if bad:
                parts.append(f"{label} is the odd one out: free motion differs from MuJoCo's (state {bad[0].state}, "
                             f"body {bad[0].worst_body or '-'}, {bad[0].position:.2e} m)")
    if not parts and res.passed:
        loaded = [r.loader for r in res.readings.values() if r.loaded]
        parts.append(f"{', '.join(loaded[:-1])} and {loaded[-1]} agree")
        if w is not None and not w.refusal:
            parts[-1] += "; the in-house engine and Exudyn (built from MuJoCo's reading) agree with MuJoCo's dynamics"
    if res.setting_differences:
        between = "between the MJCF and the URDF" if res.two_files else "between the loaders"
        parts.append(f"{len(res.setting_differences)} joint setting(s) differ {between} (listed, not counted)")
    if res.findings:
        parts.append("causes: " + causes_line(res.findings))
    parts += res.refusals
    if w is not None and w.refusal:
        parts.append(f"in-house and Exudyn: not run: {w.refusal}")
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
         f"- Base: {res.base}; joints matched by name"
         + (f" ({res.mapped} URDF joint(s) through the joint map)" if res.mapped else "")
         + "; common coordinates of `harness.tools.dynamics_terms` (MuJoCo's: free joint linear velocity in world, "
         "angular in the body frame)",
         f"- Settings: {', '.join(f'{k} {v}' for k, v in res.settings.items())}"]
    if res.copies:
        L += ["- What the loaders read differs from the file(s) (each loader reads the file as written otherwise):"]
        L += [f"  - {c}" for c in res.copies]
    L += [""]
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
        L += ["", ("Joint settings that differ between the MJCF and the URDF (listed, not counted: a URDF revolute joint "
                   "must state limits and cannot state an armature; only MuJoCo applies a friction loss):" if res.two_files
                   else "Joint settings that differ (listed, not counted: only MuJoCo applies a friction loss):"), ""]
        L += [f"- {p}" for p in res.setting_differences]
    if res.findings:
        L += ["", "What the differences come from (each cause checked against the readings: putting it back "
              "reconciles them within the tolerance, or, for an armature, the loaders' values show it):", ""]
        L += [f"- {f.text}" for f in res.findings]
    L += settings_table(res, by_joint)
    if res.not_compared:
        L += ["", "### Not compared", "",
              "MuJoCo's model holds these beyond the tree of joints and bodies; the check does not compare them between "
              "the loaders, and the dynamics terms and the free motion below leave them out (M, bias and gravity of the "
              "tree; MuJoCo's rigid run has constraints and actuators off):", ""]
        L += [f"- {line}" for line in res.not_compared]
    L += ["", "Importer differences (informational, not counted):", ""]
    L += [f"- {n}" for n in res.notes] or ["- none"]
    L += ["", "## Engine warnings", ""]
    L += warning_lines(res) or ["- none"]
    sources = sorted({s for d in res.dynamics + (res.witnesses.dynamics if res.witnesses else []) for s in (d.a, d.b)},
                     key=(LOADERS + wit.WITNESSES).index)
    L += ["", "## Dynamics terms at random states", "",
          f"{res.settings.get('states')} seeded random states (hinge angles within MuJoCo's limits where limited, rates "
          "~N(0, 1)); M(q), C(q,v)v and g(q) from MuJoCo `mj_fullM`/`qfrc_bias`, Pinocchio `crba`/`nonLinearEffects`/"
          "`computeGeneralizedGravity`, Drake `CalcMassMatrix`/`CalcBiasTerm`/`CalcGravityGeneralizedForces`, in "
          f"common coordinates; sources compared: {', '.join(sources) or 'none'}. Relative = max abs difference / "
          "largest entry.", ""]
    L += [f"- {r.loader} not compared: {r.dynamics}" for r in res.readings.values() if r.loaded and r.dynamics]
    L += [f"- {partial_line(res, r)}" for r in res.readings.values() if r.loaded and not r.dynamics and r.partial]
    L += [f"- {r.loader} not compared: it does not load the file" for r in res.readings.values() if not r.loaded]
    if any(not r.loaded or r.dynamics or r.partial for r in res.readings.values()):
        L.append("")
    L += ["| sources | term | max abs | max rel | tolerance | verdict |", "|---|---|---|---|---|---|"]
    w_dyn = res.witnesses.dynamics if res.witnesses is not None else []
    for d in res.dynamics + w_dyn:
        L.append(f"| {d.a} vs {d.b} | {d.term} | {d.max_abs:.3e} | {d.max_rel:.3e} | {d.rtol:.0e} | {'ok' if d.passed else 'DIFFERS'} |")
    odd_terms = dynamics_odd(res.dynamics)
    for loader in LOADERS:
        terms = [t for t, k in odd_terms.items() if k == loader]
        if terms:
            L += ["", f"{loader} is the odd one out in {', '.join(terms)} (the two others agree)."]
    for label, terms in witness_odd(res.dynamics + w_dyn).items():
        L += ["", f"{label} is the odd one out in {', '.join(terms)} (MuJoCo, whose reading it was built from, agrees "
              "with another loader)."]
    L += witness_section(res)
    tol = FREE_MOTION_TOL
    L += ["", "## Free motion under gravity", ""]
    if res.free_skipped:
        L += [f"Not run: {res.free_skipped}."]
        return "\n".join(L) + "\n"
    L += [f"{len(res.free)} random initial states, {res.settings.get('t_end')} s at dt {res.settings.get('dt')} s; MuJoCo RK4 with "
          "contacts, constraints (limits, equalities, friction loss), passive forces (damping, springs, gravity "
          "compensation, fluid forces) and actuators disabled; "
          "Pinocchio `aba` + `rkmk4_step` (Drake is compared by its dynamics terms above, not in free motion). Max over "
          f"saved samples (every {res.settings.get('save_every')} s) of the joint-coordinate difference, joint-velocity "
          "difference and every moving body's world position and orientation (geodesic) difference. Last column: how far "
          "MuJoCo's joints move when limits, equalities, damping and actuators are left on (contacts off), against the run "
          "without them.", "",
          f"| state | joints (tol {tol['joint']:.0e}) | joint velocities (tol {tol['velocity']:.0e}) | body position m (tol {tol['position']:.0e}) "
          f"| body orientation rad (tol {tol['orientation']:.0e}) | worst body | MuJoCo as the file says vs rigid |",
          "|---|---|---|---|---|---|---|"]
    for r in res.free:
        L.append(f"| {r.state} | {r.joint:.3e} | {r.velocity:.3e} | {r.position:.3e} | {r.orientation:.3e} | {r.worst_body} "
                 f"| {r.constrained_joint:.3e} |")
    return "\n".join(L) + "\n"


def witness_section(res: CheckResult) -> list[str]:
    """The report's section on the in-house engine and Exudyn (``harness.tools.witnesses``)."""
    w = res.witnesses
    if w is None:
        return []
    L = ["", "## The in-house engine and Exudyn (witnesses of dynamics)", "",
         "Built from MuJoCo's reading of the file (its compiled model as the harness's description, fixed children "
         "merged), not from the file: they test the dynamics, not a parser, and never vote on how the file is read. "
         "The in-house M, bias and gravity (Newton-Euler in maximal coordinates, accelerations for unit generalized "
         "forces) are in the table above as `in-house`; Exudyn holds no joint-space terms and is compared in free "
         "motion."]
    if w.refusal:
        return L + ["", f"- in-house: not run: {w.refusal}", f"- Exudyn: not run: {w.refusal}"]
    bad = [r for r in w.rows if not r.ok]
    L += ["", f"Model terms as each holds them against the description ({len(w.rows)} values: mass, centre of mass, "
          "inertia, axis, position in parent per body; mass and principal moments also against MuJoCo's reading): "
          + ("all agree" if not bad else f"{len(bad)} differ") + f" (relative tolerance {res.settings.get('rtol_model')})."]
    L += [f"- {p}" for p in w.problems]
    if w.free:
        L += ["", "Free motion from the same random states as below, against MuJoCo's rigid run: every moving body's "
              f"centre of mass and frame (in-house `{wit.INHOUSE_METHOD}` at dt; Exudyn `{wit.EXUDYN_METHOD}` at dt/"
              f"{wit.EXUDYN_SUBSTEPS}, order 2, with its own tolerance).", "",
              "| engine | state | body position m | body orientation rad | body velocity m/s, rad/s | tolerance | worst body | verdict |",
              "|---|---|---|---|---|---|---|---|"]
        for f in w.free:
            tol_text = f"{f.tol['position']:.0e} / {f.tol['orientation']:.0e} / {f.tol['velocity']:.0e}"
            verdict_text = "ok" if f.passed else ("DIFFERS" if f.status == "ok" else f.status)
            L.append(f"| {f.witness} | {f.state} | {f.position:.3e} | {f.orientation:.3e} | {f.velocity:.3e} | {tol_text} "
                     f"| {f.worst_body} | {verdict_text} |")
    L += ["", f"Wall time of the witnesses: {w.wall_s:.2f} s."]
    return L


_TABLE_SETTINGS = ("damping", "friction loss", "range", "armature")


def _setting_cell(res: CheckResult, votes: dict, joint: str, quantity: str) -> str:
    """One joint setting across the loaders: ``same: <value>``, ``differs (<by how much>): <values>``
    or ``only <loader> reads it: <value>``, naming the loaders that do not read it."""
    loaded = [r for r in res.readings.values() if r.loaded]
    v = votes.get(quantity)
    field_name = _DETAIL_FIELD.get(quantity)
    held = {}
    for r in loaded:
        x = next((b for b in r.bodies if b.joint == joint), None)
        d = next((b for b in r.details if b.joint == joint), None)
        if x is None or d is None or not QUANTITIES[quantity][0](x):
            continue
        if field_name is None or getattr(d, field_name) is not None:
            held[r.loader] = QUANTITIES[quantity][2](x, d)
    if not held:
        return ""
    absent = [r.loader for r in loaded if r.loader not in held]
    note = f" ({_who(absent)} {'does' if len(absent) == 1 else 'do'} not read it)" if absent else ""
    if v is None:
        if len(held) != 1:
            return ""
        (k, value), = held.items()
        return f"only {k} reads it: {value}{note}"
    if v.agree:
        return f"same: {next(iter(v.values.values()))}{note}"
    if quantity == "armature":
        f = next((f for f in res.findings if f.kind == "armature" and f.joint == joint), None)
        if f is not None and "the URDF has no armature" in f.text:
            nonzero = [k for k, val in v.values.items() if not val.startswith("0 ")]
            return (f"only {_who(nonzero)} {'reads' if len(nonzero) == 1 else 'read'} it: {v.values[nonzero[0]]} "
                    "(the URDF has no armature)")
    by = f" ({v.detail})" if v.detail else ""
    return f"differs{by}: " + ", ".join(f"{k} {val}" for k, val in v.values.items()) + note


def _gear_cell(res: CheckResult, joint: str) -> str:
    """The actuators on a joint with their gear (MuJoCo's ``gear``, Drake's gear ratio): listed, not compared."""
    items = []
    m = res.readings["MuJoCo"].model
    jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
    for a in range(m.nu):
        if jid >= 0 and m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == jid:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator{a}"
            items.append(f"MuJoCo {float(m.actuator_gear[a, 0]):g} ({name})")
    drr = res.readings.get("Drake")
    if drr is not None and drr.loaded:
        plant = drr.model.plant
        for a in plant.GetJointActuatorIndices():
            act = plant.get_joint_actuator(a)
            if drr.names.get(act.joint().name(), act.joint().name()) == joint:   # through the joint map, if any
                items.append(f"Drake {act.default_gear_ratio():g} ({act.name()})")
    return ", ".join(items) + ": not compared" if items else ""


def settings_table(res: CheckResult, by_joint: dict[str, dict[str, Vote]]) -> list[str]:
    """The report's per-joint table of damping, friction loss, range, armature (with units) and the
    actuators' gear, each as ``same`` / ``differs (by how much)`` / ``only <loader> reads it``."""
    rows = []
    for joint, votes in by_joint.items():
        if not joint:
            continue
        cells = [_setting_cell(res, votes, joint, q) for q in _TABLE_SETTINGS] + [_gear_cell(res, joint)]
        if any(cells):
            rows.append(f"| {joint} | " + " | ".join(cells) + " |")
    if not rows:
        return []
    return ["", "### Joint settings", "",
            "Per hinge or slide joint: what each loader reads (units: damping N m s/rad or N s/m, friction loss N m or N, "
            "range rad or m, armature kg m^2 or kg). Gear: the actuators on the joint (MuJoCo's `gear`, Drake's gear ratio "
            "from a URDF transmission), listed, not compared (Pinocchio reads no actuators).", "",
            "| joint | damping | friction loss | range | armature | actuator gear |", "|---|---|---|---|---|---|"] + rows


def partial_line(res: CheckResult, r: Reading) -> str:
    """How a loader that lacks whole kinematic trees is compared (``Reading.partial``)."""
    roots = _whole_trees(res.readings["MuJoCo"], r.partial)
    return (f"{r.loader} compared on the kinematic trees it reads: it lacks {len(roots)} whole tree(s) of MuJoCo's "
            f"(rooted at {_few(roots, 6)}; joints {_few(r.partial, 6)}), which the dynamics terms and the free motion "
            "leave out for every loader")


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
    lines += [f"  copy: {c}" for c in res.copies]
    lines += [f"  not compared: {line}" for line in res.not_compared]
    lines += [f"  MODEL {p}" for p in res.model_problems]
    lines += [f"  setting (not counted) {p}" for p in res.setting_differences]
    lines += [f"  CAUSE {f.text}" for f in res.findings]
    lines += [f"  warnings {line[2:]}" for line in warning_lines(res)]
    for d in res.dynamics:
        lines.append(f"  dynamics {d.term:<8} {d.a} vs {d.b}: max abs {d.max_abs:.3e}, max rel {d.max_rel:.3e}"
                     + ("" if d.passed else f"  DIFFERS (> {d.rtol:.0e})"))
    lines += [f"  dynamics {r.loader} not compared: {r.dynamics}" for r in res.readings.values() if r.loaded and r.dynamics]
    lines += [f"  dynamics {partial_line(res, r)}" for r in res.readings.values() if r.loaded and not r.dynamics and r.partial]
    for r in res.free:
        lines.append(f"  free motion {r.state}: joints {r.joint:.3e}, velocities {r.velocity:.3e}, "
                     f"body position {r.position:.3e} m, orientation {r.orientation:.3e} rad")
    if res.free_skipped:
        lines.append(f"  free motion not run: {res.free_skipped}")
    w = res.witnesses
    if w is not None and w.refusal:
        lines.append(f"  in-house and Exudyn: not run: {w.refusal}")
    elif w is not None:
        lines += [f"  witness model {p}" for p in w.problems]
        for d in w.dynamics:
            lines.append(f"  dynamics {d.term:<8} {d.a} vs {d.b}: max abs {d.max_abs:.3e}, max rel {d.max_rel:.3e}"
                         + ("" if d.passed else f"  DIFFERS (> {d.rtol:.0e})"))
        for f in w.free:
            lines.append(f"  free motion {f.state} {f.witness} vs MuJoCo: body position {f.position:.3e} m, orientation "
                         f"{f.orientation:.3e} rad, velocity {f.velocity:.3e}" + ("" if f.passed else "  DIFFERS"))
    return lines


def write_report(res: CheckResult, out_dir: Path, command: str) -> Path:
    path = Path(out_dir) / f"check_{res.name}.md"
    atomic.write_text(path, render_report(res, command))
    return path
