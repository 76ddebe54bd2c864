"""``harness zoo``: ``harness check`` on every model of an installed collection or a folder, each
model in its own worker process, summed up in one table per collection.

Collections (``collection(arg)``):

* ``example-robot-data``: the URDFs of the pip package ``example-robot-data`` (a test
  dependency). Its wheel ships no Python module (``example_robot_data.getModelPath`` belongs to
  the robotpkg/conda build, not to this one); the URDFs are located from the distribution's own
  file list (``importlib.metadata.distribution("example-robot-data").files``), which installs
  them under ``<site-packages>/cmeel.prefix/share/example-robot-data/robots/<robot>_description/
  {urdf,robots}/*.urdf``. Each URDF is a model; its meshes (``package://`` URIs, which MuJoCo
  cannot resolve) are stripped from MuJoCo's copy (``check --strip-geometry``: the mass
  properties come from the ``<inertial>`` elements). Two URDFs with the same file name
  (``anymal.urdf`` of anymal_b and anymal_c) are named ``<robot folder>-<stem>``.
* ``dm_control``: the suite's MJCFs, ``<site-packages>/dm_control/suite/*.xml`` (found with
  ``importlib.resources.files("dm_control")``, without importing the suite). They are checked in
  place, exactly as the ``reports/check_<model>.md`` of the suite were made (``harness check
  --mjcf <dm_control>/suite/<model>.xml``): their ``<include file="./common/...">`` (skybox,
  visual, materials) and ``dog_assets`` resolve next to the file. Geometry is kept: their masses
  and inertias come from the geoms.
* any other argument is a folder: every ``*.xml`` (MJCF) and ``*.urdf`` directly in it (not in its
  subfolders, which usually hold included fragments and meshes); an MJCF and a URDF of the same
  stem are one model, checked as ``--mjcf`` and ``--urdf``. ``--strip-geometry`` applies to it.

Base (``--base``; default ``auto``): ``auto`` floats a URDF checked alone (``check
--floating-base``: a free root joint ``root_joint`` in every loader) unless its root link is
named ``world``, the URDF convention for a robot welded to the world (ur5_robot.urdf); a model
with an MJCF keeps the root joints the MJCF states. ``fixed`` and ``floating`` force one.

Each model runs ``harness.tools.check.run_check`` with ``check``'s defaults (seed 0, 4 random
states, 3 free motions of 0.5 s at 1 ms) in a fresh worker (``harness.validate.workers.run_cases``:
forked, at most one per usable CPU, each with its own wall-clock ``--timeout``): a crash (even a
segfault), a hang or a timeout of one model is that model's row and reaches no other; the workers
are killed when the parent gets SIGTERM, returns or raises, and die with it when it is killed
outright (Linux ``PR_SET_PDEATHSIG``). A worker's stdout and stderr (importers' chatter) go to a
file the parent reads only when the worker dies, for the last Python frame ``faulthandler`` wrote;
that file and the worker's temporary files (``check``'s copies of the model) are in one temporary
folder ``harness-zoo-*``, removed when the zoo ends, raises or gets SIGTERM (``atomic.sigterm_exits``:
the process then exits with status 143).
With ``--dask ADDRESS`` the models are checked the same way on the workers of that Dask scheduler
(``harness.validate.dask_workers``); a worker on another machine, which cannot reach that file,
leaves the chatter in its own log.

One row per model (``ModelRow``):

* which loaders load the file: from the check's readings, or, when the check refuses the model,
  by asking each engine alone (MuJoCo compiles the spec; Pinocchio ``buildModelFrom*``; Drake's
  parser), with the one-line reason where one refuses (none is asked about a file refused before
  loading);
* the verdict: ``pass`` / ``fail`` (``check``'s verdict: the loaders that read the file agree or
  not), ``refused`` (``check`` rejects the model as bad input: a file MuJoCo does not load, a
  non-physical body, no moving joint, only MuJoCo loads it, a comparison that diverged; or,
  before any engine is given the file, one that is not a regular file, is larger than
  ``harness.model.input_files.MAX_INPUT_BYTES``, is not UTF-8 or includes a file outside its folder:
  ``harness.model.input_files.check_model_file``) with ``check``'s one line, ``crashed`` (the worker died, timed out, or ``check`` raised an
  unexpected exception) with how;
* the largest discrepancy (``Discrepancy``): the one largest relative to its tolerance among
  the counted model quantities on which the loaders disagree (the cause in the file) or, when
  they agree on all, among the dynamics terms of every pair and the free motions: its kind
  (the quantity and joint, the term, the free-motion quantity), the loaders it is between, its
  size in SI units and relative (the quantity's scale as ``check`` judges it: masses and
  inertias against the larger value, lengths against the body's size of at least 1 mm,
  dynamics terms against the term's largest entry) and its ratio to the tolerance; a
  difference with no size (a joint type, a joint only some loaders have) ranks first;
* the run time (s, wall clock of the worker from its fork to its result; the engines' imports
  are not in it: the parent makes them before forking);
* the plausibility of every body's inertia as MuJoCo holds it (``mj_model.body_mass``,
  ``body_inertia``: fixed children merged, masses from geoms where the file gives no inertial;
  for a file MuJoCo does not compile, the ``<inertial>`` elements as written), one line per
  body of positive mass in the model's report (``plausibility``):

  - triangle-inequality margin of the principal moments I_1..I_3 (kg m^2, about the centre of
    mass along the principal axes, so no frame enters): min over permutations of
    (I_a + I_b - I_c) / max I (1 for a sphere, 0 for a thin rod, negative for a tensor no
    body has);
  - implied density (kg/m^3): the mass over the volume of the uniform box with the same mass
    and principal moments (sides s_a = sqrt(6 (I_b + I_c - I_a) / m)); undefined when a side
    is not real.

  A body is *suspicious* (listed, never a failure) when its margin is below ``MARGIN_MIN``
  = 1e-3 (a solid rod over ~40 times longer than its diameter, or no real body) or its density is
  outside ``DENSITY_RANGE`` = [50, 25000] kg/m^3 (from rigid foam to beyond osmium, 22600
  kg/m^3; a hollow part or a placeholder inertia lands outside); the density is undefined only
  when the margin is not positive, which is flagged already.

Output, written only after every model ran, all together (``harness.io.atomic.write_set``):
``<out>/<collection>.md`` (headline counts, then the table), ``<out>/<collection>.csv`` (the same
rows), and the per-model reports ``<out>/<collection>/check_<model>.md`` (``check``'s report with
a plausibility section; a refused model gets a short one with its loaders and plausibility).
They sit in a folder per collection because model names repeat across collections (quadruped
is in both).
"""

from __future__ import annotations

import csv
import faulthandler
import importlib.metadata
import importlib.resources
import inspect
import io
import itertools
import os
import re
import shlex
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

import mujoco
import numpy as np

from harness.io import atomic
from harness.model.input_files import check_model_file, parse_xml
from harness.engines import made_with
from harness.model.errors import InputError
from harness.model.joints import FREE
from harness.model.from_model_file import add_root_joint
from harness.tools.check import (LOADERS, compile_spec, load_pinocchio, read_mujoco_spec, render_report, run_check,
                                 strip_geometry, verdict as check_verdict)
from harness.tools.check.classifying import CONSISTENT, DEFECT, IMPORTER, DefectRefusal, KnownRefusal
from harness.tools.check.defects import (DENSITY_RANGE, MARGIN_MIN, BodyPlausibility, mujoco_plausibility,
                                         spec_plausibility)
from harness.tools.check.classifying import witness_line
from harness.tools.check.report import top_findings
from harness.tools.loaded_models import load_drake, load_pybullet
from harness.validate.workers import Outcome, effective_jobs, run_cases

COLLECTIONS = ("example-robot-data", "dm_control")
#: A row's class: the check's (``harness.tools.check.classifying.CLASSES`` but *not compared*, which is
#: listed beside it), or refused (bad input that is not a defect of the file), or crashed.
ROW_CLASSES = (DEFECT, IMPORTER, CONSISTENT, "refused", "crashed")
BASES = ("auto", "fixed", "floating")
#: How to install the collections (the ``robots`` extra of pyproject.toml).
ROBOTS_EXTRA = 'the extra "robots" of harness: pip install ".[robots]" in its checkout'
DEFAULT_TIMEOUT = 300.0               # s per model
# check's own defaults (seed, states, free runs, horizon, step), as `harness check` uses them
CHECK_DEFAULTS = {k: p.default for k, p in inspect.signature(run_check).parameters.items()
                  if k in ("seed", "n_states", "n_free", "t_end", "dt")}


# --------------------------------------------------------------------------- collections


@dataclass(frozen=True)
class ZooModel:
    """One model of a collection: ``name`` (unique in it), its MJCF and/or URDF."""

    name: str
    mjcf: Path | None = None
    urdf: Path | None = None

    @property
    def files(self) -> tuple[Path, ...]:
        return tuple(p for p in (self.mjcf, self.urdf) if p is not None)


@dataclass(frozen=True)
class Collection:
    """The models ``harness zoo`` runs: ``name`` (the report's file name), ``root`` (where the
    files are), ``strip`` (geometry stripped from MuJoCo's copy), ``what`` (one sentence for the
    report: what the collection is and where it was found)."""

    name: str
    root: Path
    models: tuple[ZooModel, ...]
    strip: bool
    what: str


def _unique_names(paths: list[Path], root: Path) -> dict[str, Path]:
    """Model name -> file: the file's stem, or ``<first folder under root>-<stem>`` where two
    files share a stem."""
    stems: dict[str, int] = {}
    for p in paths:
        stems[p.stem] = stems.get(p.stem, 0) + 1
    out = {}
    for p in sorted(paths):
        name = p.stem if stems[p.stem] == 1 else f"{p.relative_to(root).parts[0]}-{p.stem}"
        out[name] = p
    return out


def example_robot_data() -> Collection:
    """The URDFs of the installed ``example-robot-data`` distribution (see module docstring)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise InputError("collection example-robot-data: the package is not installed "
                         f"({ROBOTS_EXTRA})") from None
    files = [Path(dist.locate_file(f)) for f in dist.files or ()
             if f.suffix == ".urdf" and "example-robot-data/robots/" in f.as_posix()]
    if not files:
        raise InputError("collection example-robot-data: the installed package lists no URDF under "
                         "share/example-robot-data/robots")
    root = Path(os.path.commonpath(files))
    while root.name != "robots" and root.parent != root:
        root = root.parent
    models = tuple(ZooModel(name, urdf=p) for name, p in sorted(_unique_names(files, root).items(),
                                                                key=lambda item: item[0].lower()))
    version = dist.version
    return Collection("example-robot-data", root, models, True,
                      f"the URDFs of example-robot-data {version} (pip), installed under `{_shown(root)}` "
                      "(located from the distribution's file list); meshes stripped from MuJoCo's copy "
                      "(`package://` URIs), mass properties from the `<inertial>` elements")


def dm_control_suite() -> Collection:
    """dm_control's suite MJCFs, checked in place (see module docstring)."""
    try:
        root = Path(str(importlib.resources.files("dm_control") / "suite"))
    except ModuleNotFoundError:
        raise InputError(f"collection dm_control: the package is not installed ({ROBOTS_EXTRA})") from None
    files = sorted(root.glob("*.xml"))
    if not files:
        raise InputError(f"collection dm_control: no suite MJCF in {root}")
    version = importlib.metadata.version("dm-control")
    models = tuple(ZooModel(p.stem, mjcf=p) for p in files)
    return Collection("dm_control", root, models, False,
                      f"dm_control {version}'s suite MJCFs, `{_shown(root)}/*.xml`, checked in place (their "
                      "`./common/*.xml` includes and `dog_assets` resolve next to them); geometry kept: masses "
                      "and inertias come from the geoms")


def folder_collection(folder: Path, strip: bool) -> Collection:
    """Every ``*.xml`` and ``*.urdf`` directly in ``folder``; an MJCF and a URDF of one stem pair up.
    An entry that is not a regular file (a FIFO, a link to a device) is a model too: its row says
    why it is refused (``check_model``), never read."""
    files = sorted(p for p in folder.iterdir() if not p.is_dir() and p.suffix.lower() in (".xml", ".urdf"))
    if not files:
        raise InputError(f"{folder}: no model file (*.xml, *.urdf) in the folder")
    models = []
    for stem, group in itertools.groupby(sorted(files, key=lambda p: (p.stem, p.suffix.lower())), key=lambda p: p.stem):
        group = list(group)
        kinds = [_kind(p) for p in group]
        if len(set(kinds)) == len(kinds):  # one MJCF and/or one URDF: one model
            models.append(ZooModel(stem, **{k: p for k, p in zip(kinds, group)}))
        else:  # a.xml beside a.XML: each alone, named by its file name
            models += [ZooModel(p.name, **{_kind(p): p}) for p in group]
    name = folder.resolve().name or "folder"
    return Collection(name, folder, tuple(models), strip,
                      f"the model files in `{_shown(folder)}` (*.xml as MJCF, *.urdf; an MJCF and a URDF of one "
                      f"stem checked as a pair){'; geometry stripped from MuJoCo’s copy' if strip else ''}")


def _kind(p: Path) -> str:
    return "urdf" if p.suffix.lower() == ".urdf" else "mjcf"


def collection(arg: str, *, strip: bool = False) -> Collection:
    """A known collection by name, or the folder ``arg``; InputError for anything else.
    ``strip`` applies to a folder (the known collections have their own setting)."""
    if arg == "example-robot-data":
        return _as_shown(example_robot_data())
    if arg == "dm_control":
        return _as_shown(dm_control_suite())
    folder = Path(arg)
    if folder.is_dir():
        return _as_shown(folder_collection(folder, strip))
    what = "not a folder" if folder.exists() else "no such folder"
    raise InputError(f"{arg}: {what} and not a known collection ({', '.join(COLLECTIONS)})")


def _as_shown(coll: Collection) -> Collection:
    """The collection with every file as ``_shown`` gives it (relative to the working directory
    when inside it), so that reports and commands name the files as a user there would."""
    def shown(p: Path | None) -> Path | None:
        return None if p is None else Path(_shown(p))

    return replace(coll, models=tuple(replace(m, mjcf=shown(m.mjcf), urdf=shown(m.urdf)) for m in coll.models))


def select(coll: Collection, only: list[str] | None) -> Collection:
    """The collection restricted to the models named in ``only`` (None: all); InputError naming
    a name it does not have."""
    if only is None:
        return coll
    names = {m.name for m in coll.models}
    unknown = [n for n in only if n not in names]
    if unknown or not only:
        raise InputError(f"--only: no model named {', '.join(map(repr, unknown)) or 'at all'} in {coll.name} "
                         f"(models: {', '.join(sorted(names))})")
    return replace(coll, models=tuple(m for m in coll.models if m.name in only))


def _shown(path: Path) -> str:
    """``path`` relative to the working directory when it is inside it, else absolute."""
    path = Path(path).absolute()
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def urdf_root_link(path: Path) -> str | None:
    """The name of a URDF's root link (the one link no joint has as child); None when the file
    does not parse or has no single root."""
    try:
        robot = parse_xml(path, "URDF")
    except (ET.ParseError, OSError, InputError):
        return None
    children = {c.get("link") for j in robot.iter("joint") for c in j.findall("child")}
    roots = [link.get("name") for link in robot.findall("link") if link.get("name") not in children]
    return roots[0] if len(roots) == 1 else None


def floating_base(model: ZooModel, base: str) -> bool:
    """Whether ``model`` is checked with a free root joint (``--base``, see module docstring)."""
    if base != "auto":
        return base == "floating"
    return model.mjcf is None and urdf_root_link(model.urdf) not in (None, "world")


# --------------------------------------------------------------------------- one model, in its worker


@dataclass
class ModelRow:
    """One model's line of the table (see module docstring). ``cls``: one of ``ROW_CLASSES``;
    ``loads``: loader -> "" when it loads the file, its one-line refusal otherwise (empty dict when
    unknown: the worker crashed); ``reason``: check's verdict line, the refusal, or how it crashed;
    ``counts``: defects, known and unexplained importer disagreements, not compared; ``top``: the
    first finding with its fix (``check``'s summary); ``witnesses``: the witnesses' line;
    ``report``: the per-model report's text ("" when there is none)."""

    name: str
    files: tuple[str, ...]
    base: str
    cls: str
    reason: str
    loads: dict[str, str] = field(default_factory=dict)
    counts: dict[str, int] = field(default_factory=dict)
    top: str = ""
    witnesses: str = ""
    bodies: list[BodyPlausibility] = field(default_factory=list)
    bodies_from: str = ""
    wall_s: float = 0.0
    report: str = ""

    @property
    def suspicious(self) -> list[BodyPlausibility]:
        return [b for b in self.bodies if b.suspicious]

    @property
    def loaded_by_all(self) -> bool:
        """Every loader that reads the model's format loads it (PyBullet reads a URDF only: ``OTHER_FORMAT``)."""
        return len(self.loads) == len(LOADERS) and not any(v for v in self.loads.values() if v != OTHER_FORMAT)


def check_command(model: ZooModel, floating: bool, strip: bool, witnesses: bool = True) -> str:
    """The ``harness check`` command that checks ``model`` alone, as the zoo does."""
    parts = ["harness", "check"]
    parts += [x for flag, p in (("--mjcf", model.mjcf), ("--urdf", model.urdf)) if p is not None for x in (flag, str(p))]
    c = CHECK_DEFAULTS
    parts += ["--seed", str(c["seed"]), "--states", str(c["n_states"]), "--free-runs", str(c["n_free"]),
              "--t-end", f"{c['t_end']:g}", "--dt", f"{c['dt']:g}"]
    parts += [flag for flag, on in (("--floating-base", floating), ("--strip-geometry", strip),
                                    ("--no-witnesses", not witnesses)) if on]
    return shlex.join(parts)


def _one_line(text) -> str:
    return " ".join(str(text).split())


def _without_path(text: str, model: ZooModel) -> str:
    """A one-line message without its leading ``<file>: ``."""
    text = _one_line(text)
    for p in model.files:
        text = text.removeprefix(f"{p}: ")
    return text


def probe_loaders(model: ZooModel, floating: bool, strip: bool) -> tuple[dict[str, str], mujoco.MjModel | None]:
    """Ask each engine alone whether it loads the model's file (MuJoCo the MJCF if there is one,
    the others the URDF if there is one): loader -> "" or its one-line refusal; and MuJoCo's
    compiled model (None when it refuses)."""
    mj_file = model.mjcf or model.urdf
    other = model.urdf or model.mjcf
    root = FREE.name if floating else "none"
    loads, m = {}, None
    try:
        spec = read_mujoco_spec(mj_file)
        add_root_joint(spec, root, mj_file)
        if strip:
            strip_geometry(spec)
        m = compile_spec(spec, mj_file)
        loads["MuJoCo"] = ""
    except Exception as err:  # an engine's refusal, whatever it raises
        loads["MuJoCo"] = _without_path(err, model) or type(err).__name__
    try:
        load_pinocchio(other, root_joint=root)
        loads["Pinocchio"] = ""
    except Exception as err:
        loads["Pinocchio"] = _without_path(err, model).replace("Pinocchio cannot load", "cannot load", 1) \
            or type(err).__name__
    try:
        load_drake(other, root_joint=root)
        loads["Drake"] = ""
    except Exception as err:  # DrakeRefusal, or whatever its parser raises
        loads["Drake"] = _without_path(err, model) or type(err).__name__
    if model.urdf is None:
        loads["PyBullet"] = OTHER_FORMAT
    else:
        try:
            load_pybullet(model.urdf, root_joint=root)
            loads["PyBullet"] = ""
        except Exception as err:  # PyBulletRefusal, or whatever its importer raises
            loads["PyBullet"] = _without_path(err, model) or type(err).__name__
    return loads, m


#: A loader that does not read the model's format (PyBullet: a URDF only), not a refusal.
OTHER_FORMAT = "reads a URDF only"


AS_MUJOCO_HOLDS = ("as MuJoCo holds it (fixed children merged; masses from geoms where the file gives no "
                   "inertial)")
AS_WRITTEN = "as the file's inertial elements state it (MuJoCo does not compile the file)"


def _file_bodies(model: ZooModel, m: mujoco.MjModel | None) -> tuple[list[BodyPlausibility], str]:
    """The plausibility of the bodies, from MuJoCo's model if it compiled, else from the file as
    written; and which of the two."""
    if m is not None:
        return mujoco_plausibility(m), AS_MUJOCO_HOLDS
    try:
        return spec_plausibility(read_mujoco_spec(model.mjcf or model.urdf)), AS_WRITTEN
    except InputError:
        return [], "not read (MuJoCo does not parse the file)"


def check_model(model: ZooModel, base: str, strip: bool, log_path: str | None = None,
                witnesses: bool = True) -> ModelRow:
    """Run ``harness check`` on one model and make its row (runs in a worker process; stdout and
    stderr go to ``log_path`` when given, and ``faulthandler`` writes a crash's frames there);
    ``witnesses``: also the in-house engine and Exudyn (``check --no-witnesses`` when False)."""
    if log_path is not None and os.path.isdir(os.path.dirname(log_path) or "."):  # not on another machine's worker
        log = open(log_path, "w")  # left open: faulthandler writes a crash's frames to it until the worker exits
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        faulthandler.enable(file=log)
        # this worker's temporary files (check's copies of the model) go into the zoo's log folder, which
        # the parent removes however the worker ends (killed at its timeout, or with the parent)
        tempfile.tempdir = os.path.dirname(log_path) or None
    warnings.simplefilter("ignore")
    floating = floating_base(model, base)
    command = check_command(model, floating, strip, witnesses)
    row = ModelRow(model.name, tuple(str(p) for p in model.files), "floating" if floating else "fixed", "", "")
    try:  # what `harness check` refuses before any loader opens the file: no loader is asked either
        for path in model.files:
            check_model_file(path)
    except InputError as err:
        row.cls, row.reason = "refused", _without_path(str(err), model)
        row.bodies_from = "not read (the file is refused before any engine reads it)"
        row.report = refused_report(row, command)
        return row
    try:
        res = run_check(model.mjcf, model.urdf, floating_base=floating, strip=strip, witnesses=witnesses,
                        **CHECK_DEFAULTS)
    except (InputError, np.linalg.LinAlgError, OverflowError, FloatingPointError) as err:
        row.reason = _without_path(err, model) if isinstance(err, InputError) else (
            f"the comparison diverged ({type(err).__name__}: {_one_line(err)})")
        # a defect that stops every loader is the file's class (its line names the element and the fix)
        row.cls = DEFECT if isinstance(err, DefectRefusal) else "refused"
        if isinstance(err, (DefectRefusal, KnownRefusal)):   # KnownRefusal: MuJoCo, which every check needs, refuses a valid file
            row.counts = {"defects": int(isinstance(err, DefectRefusal)), "known": int(isinstance(err, KnownRefusal)),
                          "unexplained": 0, "not compared": 0}
            row.top = err.finding
        row.loads, m = probe_loaders(model, floating, strip)
        row.bodies, row.bodies_from = _file_bodies(model, m)
        row.report = refused_report(row, command)
        return row
    res.name = model.name
    c = res.classes
    row.cls = c.file_class
    row.reason = check_verdict(res)
    row.loads = {r.loader: r.refusal or "" for r in res.readings.values()}
    if model.urdf is None and "PyBullet" in row.loads:   # an MJCF alone: PyBullet is not a loader of its format
        row.loads["PyBullet"] = OTHER_FORMAT
    row.counts = {"defects": len(c.defects), "known": len(c.known), "unexplained": len(c.unexplained),
                  "not compared": len(c.uncompared)}
    found = top_findings(res)
    row.top = f"{found[0][0]}; {found[0][1]}" if found else ""
    row.witnesses = witness_line(res)
    row.bodies, row.bodies_from = mujoco_plausibility(res.readings["MuJoCo"].model), AS_MUJOCO_HOLDS
    row.report = render_report(res, command) + "\n" + "\n".join(plausibility_section(row)) + "\n"
    return row


def plausibility_section(row: ModelRow) -> list[str]:
    """The per-model report's section: one line per body."""
    lines = ["## Plausibility of the inertias", "",
             f"Every body of positive mass {row.bodies_from}: triangle-inequality margin of the principal moments, "
             f"min over permutations of (I_a + I_b - I_c) / max I, and implied density, the mass over the volume of the uniform box with the same "
             f"principal moments. Suspicious (listed, not a failure): margin < {MARGIN_MIN:g} or density outside "
             f"[{DENSITY_RANGE[0]:g}, {DENSITY_RANGE[1]:g}] kg/m^3. {len(row.suspicious)} of {len(row.bodies)} "
             f"suspicious.", ""]
    return lines + ([f"- {b.line()}" for b in row.bodies] or ["- no body of positive mass"])


def refused_report(row: ModelRow, command: str) -> str:
    """A short report for a model ``check`` refuses: the reason, which engines load the file, the
    plausibility of its inertias."""
    lines = [f"# harness check: {row.name}", "", f"Verdict: **{row.cls}**: {row.reason}", "", f"Command: `{command}`", "",
             f"- Files: {', '.join(f'`{f}`' for f in row.files)}; base: {row.base}",
             ("- Loads (each engine asked alone): " + "; ".join(
                 f"{k} {'loads it' if not why else 'does not load it: ' + why}" for k, why in row.loads.items())
              if row.loads else "- Loads: no engine is given a file refused before loading"), ""]
    return "\n".join(lines + plausibility_section(row)) + "\n"


# --------------------------------------------------------------------------- the zoo


@dataclass
class Zoo:
    """A collection's rows (collection order), the base option, wall time (s) and workers."""

    collection: Collection
    rows: list[ModelRow]
    base: str
    wall_s: float
    jobs: int

    witnesses: bool = True

    def count(self, cls: str) -> int:
        return sum(r.cls == cls for r in self.rows)


def _crash_detail(log_path: Path) -> str:
    """The innermost Python frame ``faulthandler`` wrote before the worker died, if any."""
    try:
        text = log_path.read_text(errors="replace")
    except OSError:
        return ""
    frames = re.findall(r'^\s+File "([^"]+)", line (\d+) in (\S+)', text, flags=re.M)
    if not frames:
        return ""
    path, line, fn = frames[0]
    return f"; last Python frame: {os.path.basename(path)}:{line} in {fn}"


def _crashed_row(model: ZooModel, base: str, outcome: Outcome, log_path: Path) -> ModelRow:
    floating = floating_base(model, base)
    how = {"timeout": "timed out", "crashed": "crashed", "error": "raised"}.get(outcome.status, outcome.status)
    detail = _crash_detail(log_path) if outcome.status == "crashed" else ""
    return ModelRow(model.name, tuple(str(p) for p in model.files), "floating" if floating else "fixed", "crashed",
                    f"check {how}: {_one_line(outcome.message)}{detail}", wall_s=outcome.wall_s)


def run_zoo(coll: Collection, *, base: str = "auto", jobs: int | None = None, timeout: float = DEFAULT_TIMEOUT,
            on_done=None, dask: str | None = None, witnesses: bool = True) -> Zoo:
    """Check every model of ``coll``, each in its own worker (see module docstring); ``on_done(row)``
    is called in this process as each model ends. ``dask``: the address of a ``dask.distributed``
    scheduler whose workers check the models (same rows), else the local pool. ``witnesses``: also
    run the in-house engine and Exudyn (``check --no-witnesses`` when False)."""
    if base not in BASES:
        raise InputError(f"--base must be one of {', '.join(BASES)}, got {base!r}")
    if not (timeout > 0):
        raise InputError(f"--timeout must be positive, got {timeout!r}")
    by_name = {m.name: m for m in coll.models}
    rows: dict[str, ModelRow] = {}
    start = time.perf_counter()
    # the log folder goes on SIGTERM too (the workers, killed first, write their copies into it)
    with atomic.sigterm_exits(), tempfile.TemporaryDirectory(prefix="harness-zoo-") as logs:
        log = {m.name: Path(logs) / f"{i}.log" for i, m in enumerate(coll.models)}

        def done(name, outcome: Outcome) -> None:
            if outcome.status == "ok":
                row = outcome.value
                row.wall_s = outcome.wall_s
            else:
                row = _crashed_row(by_name[name], base, outcome, log[name])
            rows[name] = row
            if on_done is not None:
                on_done(row)

        cases = [(m.name, check_model, (m, base, coll.strip, str(log[m.name]), witnesses)) for m in coll.models]
        run_cases(cases, jobs, timeout, on_done=done, dask=dask)
    if dask:
        from harness.validate.dask_workers import slots

        jobs = slots(dask, jobs)
    else:
        jobs = effective_jobs(jobs)
    return Zoo(coll, [rows[m.name] for m in coll.models], base, time.perf_counter() - start, jobs, witnesses)


# --------------------------------------------------------------------------- tables


def _cell(text: str) -> str:
    return _one_line(text).replace("|", "\\|")


def _load_cell(row: ModelRow, loader: str) -> str:
    if loader not in row.loads:
        return "?"
    why = row.loads[loader]
    return "yes" if not why else f"({why})" if why == OTHER_FORMAT else f"**no**: {_cell(why)}"


def report_path(coll: Collection, row: ModelRow) -> str:
    """The per-model report's path relative to the output folder."""
    return f"{coll.name}/check_{row.name}.md"


def headline(zoo: Zoo) -> str:
    """Models, loaded by every loader of their format, the count per class, suspicious inertias, wall time."""
    rows = zoo.rows
    suspicious = sum(bool(r.suspicious) for r in rows)
    known = sum(r.counts.get("known", 0) for r in rows)
    unexplained = sum(r.counts.get("unexplained", 0) for r in rows)
    return (f"{len(rows)} models; loaded by every loader of their format: {sum(r.loaded_by_all for r in rows)}; class: "
            + ", ".join(f"{zoo.count(c)} {c}" for c in ROW_CLASSES)
            + f"; importer disagreements: {known} known, {unexplained} unexplained; {suspicious} model(s) with a "
            f"suspicious inertia; {zoo.wall_s:.0f} s wall on {zoo.jobs} worker(s)"
            + ("" if zoo.witnesses else " (--no-witnesses)"))


def render_table(zoo: Zoo, made: str, command: str) -> str:
    """``<collection>.md``: provenance, headline counts, the table, the suspicious inertias."""
    coll = zoo.collection
    lines = [f"# harness zoo: {coll.name}", "", f"Made {made}. Reproduce with `{command}`.", "",
             f"**{headline(zoo)}.**", "",
             f"Collection: {coll.what}. Each model: `harness check` with its defaults (seed {CHECK_DEFAULTS['seed']}, "
             f"{CHECK_DEFAULTS['n_states']} random states, {CHECK_DEFAULTS['n_free']} free motions of "
             f"{CHECK_DEFAULTS['t_end']:g} s at {CHECK_DEFAULTS['dt']:g} s, judged by convergence"
             + (", the witnesses too" if zoo.witnesses else ", without the witnesses") + ") in its own worker process; base "
             f"`--base {zoo.base}`" + (" (a URDF alone floats unless its root link is `world`; an MJCF keeps its own "
                                       "root joints)" if zoo.base == "auto" else "") + ".", "",
             "Columns: which engines load the file (the one-line reason where one refuses); the file's class (*defect in "
             "your file*: fix the file; *importer disagreement*: the loaders read a valid element differently, each "
             "matched to a known limitation of `harness/tools/check/known_limitations.toml` or unexplained; "
             "*consistent*; *refused*: bad input that is not a defect of the file; *crashed*: the worker died, timed out "
             "or `check` raised); the count of defects, of known and unexplained importer disagreements and of what is "
             "not compared; the first finding with its fix (the whole list: the model's report); the witnesses (the "
             "in-house engine and Exudyn, judged by convergence, never a vote on the file); the run time. Per-model "
             f"reports: `{coll.name}/check_<model>.md`.",
             "", "| model | base | " + " | ".join(LOADERS) + " | class | defects | known | unexplained | not compared "
             "| first finding and its fix | witnesses | run time (s) |", "|---|---|" + "---|" * len(LOADERS)
             + "---|---|---|---|---|---|---|---|"]
    for r in zoo.rows:
        name = f"[{r.name}]({report_path(coll, r)})" if r.report else r.name
        n = r.counts
        top = r.top or (r.reason if r.cls in ("refused", "crashed") else "")
        lines.append(f"| {name} | {r.base} | " + " | ".join(_load_cell(r, k) for k in LOADERS)
                     + f" | **{r.cls}** | {n.get('defects', '')} | {n.get('known', '')} | {n.get('unexplained', '')} | "
                     f"{n.get('not compared', '')} | {_cell(_cut(top))} | {_cell(r.witnesses.removeprefix('witnesses (never vote): '))} "
                     f"| {r.wall_s:.1f} |")
    lines += ["", "## Suspicious inertias", "", f"Per model, the bodies whose inertia is near-degenerate (triangle margin "
              f"< {MARGIN_MIN:g}: a rod over ~40 times longer than thick) or implausible (implied density outside "
              f"[{DENSITY_RANGE[0]:g}, {DENSITY_RANGE[1]:g}] kg/m^3; a defect when the file states it); each body's mass, "
              "principal moments, margin and density: the model's report.", ""]
    lines += [f"- {r.name}: " + "; ".join(f"{b.body} ({', '.join(b.flags)})" for b in r.suspicious)
              for r in zoo.rows if r.suspicious] or ["- none"]
    return "\n".join(lines) + "\n"


CELL = 240  # characters of a finding the table shows (the CSV and the report: all of it)


def _cut(text: str) -> str:
    text = _one_line(text)
    return text if len(text) <= CELL else text[:CELL].rsplit(" ", 1)[0] + " ... (whole: the report)"


CSV_COLUMNS = ("collection", "model", "files", "base", *(f"{k.lower()}_{c}" for k in LOADERS for c in ("loads", "refusal")),
               "class", "reason", "defects", "known", "unexplained", "not_compared", "first_finding", "witnesses",
               "run_time_s", "bodies", "suspicious_bodies", "suspicious", "report")


def render_csv(zoo: Zoo) -> str:
    """``<collection>.csv``: the table's rows (one per model; ``*_loads`` yes/no, empty when unknown)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in zoo.rows:
        loads = [x for k in LOADERS for x in (("" if k not in r.loads else "n/a" if r.loads[k] == OTHER_FORMAT
                                               else "no" if r.loads[k] else "yes"), r.loads.get(k, ""))]
        n = r.counts
        w.writerow([zoo.collection.name, r.name, ";".join(r.files), r.base, *loads, r.cls, r.reason,
                    n.get("defects", ""), n.get("known", ""), n.get("unexplained", ""), n.get("not compared", ""),
                    r.top, r.witnesses, f"{r.wall_s:.2f}",
                    len(r.bodies), len(r.suspicious), "; ".join(f"{b.body}: {', '.join(b.flags)}" for b in r.suspicious),
                    report_path(zoo.collection, r) if r.report else ""])
    return buf.getvalue()


def write_zoo(zoo: Zoo, out_dir: Path, made: str, command: str) -> list[Path]:
    """Write the table, the CSV and the per-model reports together (``atomic.write_set``)."""
    name = zoo.collection.name
    files = {f"{name}.md": render_table(zoo, made, command), f"{name}.csv": render_csv(zoo)}
    files.update({report_path(zoo.collection, r): r.report for r in zoo.rows if r.report})
    return atomic.write_set(out_dir, files)


def made_line(prov: dict[str, str]) -> str:
    """``"<date> with <versions>"`` for the table's header (``harness.io.provenance``)."""
    return f"{prov['date_utc']} with {made_with(prov)}"

