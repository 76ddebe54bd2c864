"""Reading a model file in the four loaders (MuJoCo, Pinocchio, Drake, PyBullet for a URDF): the file checks, the copies the
loaders read (geometry stripped, inertials frozen, names given), the joint map between an MJCF and a URDF,
and ``load_models``, every loader's ``Reading`` of the file(s)."""

from __future__ import annotations

import os
import re
import tempfile
import tomllib
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from harness.engines import version as engine_version
from harness.io import atomic
from harness.model.input_files import check_input_file, check_model_file, parse_xml, read_input_text
from harness.engines.mujoco.model import joint_kind as mujoco_joint_kind
from harness.engines.mujoco.model import check_spec_inertials
from harness.engines.pinocchio.model import root_joint_model
from harness.engines.pinocchio.model import joint_type as pin_joint_type
from harness.model.errors import InputError
from harness.model.from_model_file import add_root_joint
from harness.model.joints import FREE, JOINTS, by_pinocchio
from harness.tools.loaded_models import (
    DrakeRefusal,
    PyBulletRefusal,
    load_pybullet,
    pybullet_joint_bodies,
    pybullet_joint_details,
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
from harness.tools.check.results import SAME_FILE_RTOL, InertiaTrap, Reading


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
    mode = {(True, True): "MJCF -> MuJoCo, URDF -> Pinocchio, Drake and PyBullet",
            (False, True): "URDF -> MuJoCo, Pinocchio, Drake and PyBullet",
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
    drr = Reading("Drake", other_file, engine_version("drake"))
    try:
        with captured_native_stderr():
            load = load_drake(other_read, root_joint=root)
    except DrakeRefusal as err:
        drr.refusal = str(err).replace(str(tmp), "")
    else:
        drr.model, drr.parser = load, load.warnings
        drr.bodies, drr.details, drr.gravity = drake_joint_bodies(load), drake_joint_details(load), drake_gravity(load)
        notes += [f"Drake: {n}" for n in load.notes]
    pbr = _pybullet_reading(other_file, other_read, tmp, root=root, rtol=SAME_FILE_RTOL)
    notes += [f"PyBullet: {n}" for n in _pybullet_notes(pbr)]
    if copy is not None:
        copies += copy.changes
    readings = {r.loader: r for r in (mjr, pinr, drr, pbr)}
    if not pinr.loaded and not drr.loaded and not pbr.loaded:
        raise InputError(f"{other_file}: only MuJoCo loads the model, nothing to compare it with: "
                         + "; ".join(f"{r.loader}: {r.refusal}" for r in (pinr, drr, pbr)))
    return readings, notes, copies


#: What PyBullet does without URDF_USE_INERTIA_FROM_FILE to a link without collision shapes (measured,
#: PyBullet 3.2.7: a stripped copy of ur5_robot.urdf): a diagonal inertia of mass x 6.667e-7 m^2, as of a
#: solid cube 2 mm across, whatever the file states.
NO_COLLISION_INERTIA = "mass x 6.67e-7 m^2 on the diagonal, a 2 mm cube's"


def _pybullet_reading(other_file: Path, other_read: Path, tmp: Path, *, root: str, rtol: float) -> Reading:
    """PyBullet's reading of the URDF (or its copy ``other_read``) with ``URDF_USE_INERTIA_FROM_FILE``, and
    the file as written (its collision shapes, where PyBullet finds their meshes; else the copy) loaded
    a second time without the flag, PyBullet's default (``Reading.inertia_trap``, ``Reading.trap``); a
    refusal in one line for what PyBullet does not load (an MJCF, a missing mesh)."""
    from harness.tools.loaded_models import _pybullet

    _pybullet()   # imported quietly (it prints its build time on import)
    r = Reading("PyBullet", other_file, engine_version("pybullet"))
    try:
        load = load_pybullet(other_read, root_joint=root)
    except PyBulletRefusal as err:
        r.refusal = _one_line(str(err).replace(str(tmp), ""))
        r.other_format = file_format(other_read) != "URDF"
        return r
    r.model, r.parser = load, load.warnings
    r.bodies, r.details = pybullet_joint_bodies(load), pybullet_joint_details(load)
    odd = [x for x in r.bodies if x.kind not in JOINTS]
    if odd:   # a URDF planar or floating joint: PyBullet's own kind, which the check does not map
        r.refusal = (f"joint {odd[0].joint!r} of {odd[0].kind} cannot be compared between engines ({supported_joints()})")
        r.model, r.parser, r.bodies, r.details = None, (), [], []
        return r
    r.gravity = None   # a URDF states no gravity; PyBullet's default is zero: not compared (module docstring)
    bare = ""
    try:
        default = load_pybullet(other_file, root_joint=root, inertia_from_file=False)
    except PyBulletRefusal as err:
        if other_read == other_file:
            r.trap = f"not loaded without the flag: {_one_line(err)}"
            return r
        default = load_pybullet(other_read, root_joint=root, inertia_from_file=False)
        bare = (f" (the file as written does not load in PyBullet, {_one_line(err)}; read without geometry: no collision "
                f"shape, so PyBullet gives each link {NO_COLLISION_INERTIA})")
    with_flag = {x.joint: x for x in r.bodies}
    for x in pybullet_joint_bodies(default):
        y = with_flag.get(x.joint)
        if y is None or y.mass <= 0:
            continue
        scale = max(float(np.abs(y.I_Cm_B).max()), 1e-300)
        if float(np.abs(x.I_Cm_B - y.I_Cm_B).max()) > rtol * scale:
            r.inertia_trap.append(InertiaTrap(x.joint, x.body, y.mass, y.I_Cm_B, x.I_Cm_B))
    n = len(r.inertia_trap)
    r.trap = (f"loaded again without URDF_USE_INERTIA_FROM_FILE from {other_file.name} as written{bare}: "
              + (f"{n} of {len(r.bodies)} joints' bodies get another inertia" if n else "the same inertias"))
    return r


def _pybullet_notes(r: Reading) -> list[str]:
    """PyBullet's importer warnings (one line each, counted) and what its second load found."""
    notes = []
    if r.loaded and r.parser:
        said = [ln for ln in r.parser if not ln.startswith("b3Warning[") and not ln.startswith("b3Printf")]
        if said:
            notes.append(f"its importer warned {len(said)} time(s): " + "; ".join(list(dict.fromkeys(said))[:6]))
    if r.trap:
        notes.append(r.trap)
    if r.loaded:
        notes.append("a URDF states no gravity and PyBullet's default is zero (its users call setGravity): gravity is "
                     "not compared; its dynamics terms use MuJoCo's")
    return notes


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

