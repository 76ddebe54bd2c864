"""Scene descriptions: load ``models/<scene>/scene.toml``, apply overrides, build the physics.

A scene's TOML file is the single source of its parameters, initial state, run settings,
textbook provenance and checks. ``load_scene(name, overrides)`` returns a frozen ``Scene`` with
validated parameter values; ``scene.multibody()`` builds the physics (``harness.model.multibody``) that
every engine runs: from the scene's builder module (``harness.model.builders.<scene>``, or the
one its ``builder`` key names), or, for a scene without code (no builder module and no
``builder`` key), from its model file, with each parameter put where its ``sets`` key says
(``scene_multibody``; ``harness.model.from_model_file``: ``TARGETS``). A scene whose builder
generates its system (``generated = true``: N copies of a unit) keeps no model file: its MJCF
and URDF are written from that system for its current parameters (``harness.model.model_files``)
and the ``Scene`` points at them.
"""

from __future__ import annotations

import difflib
import importlib
import importlib.resources
import importlib.util
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

import numpy as np

from harness.model.errors import InputError
from harness.model.from_model_file import ZERO, apply_parameters, check_runnable, parse_target, read_model_file
from harness.model.model_files import generated_files
from harness.model.multibody import Multibody
from harness.model.sanity import check_multibody

# The repository's models/ folder, installed as the package harness.models (pyproject.toml), so
# an editable install, a plain ``pip install .`` and a wheel all find it. A regular (not zipped)
# install: the resource is a folder on disk, as MuJoCo and Pinocchio need to open the files.
MODELS_DIR = Path(str(importlib.resources.files("harness.models")))

ParamValue = float | tuple[float, ...]

#: Conserved momentum components a ``[checks.momentum_drift]`` may list:
#: ``harness.measure.compare.MOMENTUM_COMPONENTS`` (kept equal by tests/model/test_scene.py).
MOMENTUM_COMPONENTS = ("px", "py", "pz", "Lx", "Ly", "Lz", "L3")

#: The check tables a scene may declare (``[checks.<name>]``) and the keys each may hold: the
#: checks ``harness.judging.checks.check_run`` and ``harness.measure.contact_metrics.add_checks``
#: make. A check table says only that the check applies (an empty table) and, for
#: ``momentum_drift``, which components are conserved (``components``, required). It holds no
#: number: every check is judged by how its error converges (``harness.judging``); what a scene
#: demands of every engine alike is a ``[requirements]`` entry, what it expects of one engine a
#: ``[model_differences.<engine>]`` table.
CHECKS: dict[str, tuple[str, ...]] = {
    "energy_drift": (),
    "momentum_drift": ("components",),
    "trajectory": (),
    "constraint": (),
    "closure": (),
    "exact": (),
    "reaction": (),
    "slip": (),
    "contact_height": (),
    "contact_force": (),
}

#: The keys a ``[model_differences.<engine>]`` table holds: ``model`` (what differs from the
#: scene's ideal model, one line) and ``bound`` (a bound on each check's error at the scene's step
#: relative to its quantity's scale, a positive number; ``harness.judging.verdict``).
MODEL_DIFFERENCE_KEYS = ("model", "bound")

#: The checks a scene without code may declare besides ``exact`` (which needs its closed forms,
#: ``references/<scene>.py``): those that need no builder (no loop, no rolling contact).
CHECKS_WITHOUT_CODE = ("energy_drift", "momentum_drift", "trajectory", "constraint", "reaction")

#: Parameter kinds (``kind = ...`` of a ``[parameters]`` entry) and the values each takes.
KINDS = {"positive": "a number > 0", "nonnegative": "a number >= 0", "real": "any finite number",
         "vector3": "three finite numbers"}

#: The largest magnitude of a parameter value (SI units): far beyond any physical value, and small
#: enough that products of a few parameters (inertias ~ m L^2, energies) stay finite in float64.
MAX_PARAMETER = 1e100

#: The most saved samples times bodies one run may hold in memory (its state alone is about
#: 15 float64 per body and sample: 1e7 is ~1.2 GB, before the CSV or the report is made).
MAX_SAMPLES = 10_000_000

#: The most integration steps one run may take: its horizon over its step, ``t_end / dt`` (for a
#: fixed-step method its step count; Drake's error-controlled methods take at least that many,
#: ``dt`` being their maximum step). Checked before any run (``check_steps``: ``simulate``,
#: ``validate`` through ``scene.toml``, ``check``, ``debug``, the studies, and every engine's
#: ``check_settings``). 1e8 steps are 100 s of MuJoCo at ~1 us per step and hours of the Python
#: step loops; MuJoCo counts its steps in 32 bits (2.1e9), which this refuses long before.
MAX_STEPS = 100_000_000


def check_steps(t_end: float, dt: float, options: str = "--t-end and --dt") -> None:
    """InputError when a run of horizon ``t_end`` (s) at step ``dt`` (s) would take more than
    ``MAX_STEPS`` integration steps (``t_end / dt``), naming ``options`` (what set them), the step
    count and the limit. A non-positive or non-finite value is left to the callers' own checks."""
    if not (math.isfinite(t_end) and math.isfinite(dt) and t_end > 0 and dt > 0):
        return
    steps = t_end / dt
    if steps > MAX_STEPS:
        raise InputError(f"{options}: a horizon of {t_end:g} s at a step of {dt:g} s is {steps:.3g} integration "
                         f"steps, more than the {MAX_STEPS:.0e} a run may take; lengthen the step or shorten "
                         "the horizon")

# Top-level keys of scene.toml: key -> (what it must be, required)
_TOP_KEYS = {
    "name": ("string", True), "title": ("string", False), "textbook": ("list of strings", False),
    "mjcf": ("string", False), "urdf": ("string", False), "urdf_root_joint": ("string", False),
    "builder": ("string", False), "initial_state": ("string", False), "generated": ("boolean", False),
    "needs": ("table", True),
    "parameters": ("table", True),
    "simulation": ("table", True), "integrators": ("table", False), "checks": ("table", False),
    "not_run": ("table", False), "requirements": ("table", False), "model_differences": ("table", False),
}
#: The model-file keys of scene.toml: a scene names at least one (``check_description``).
MODEL_FILE_KEYS = ("mjcf", "urdf")
_NEEDS = ("gravity", "contact", "forcing")
_SIMULATION = {"t_end": "the horizon in s", "dt": "the step in s", "save_every": "the save interval in s"}
#: Optional [simulation] keys: validate's per-case wall-clock limit for this scene (s; default the
#: command's ``--timeout``), for a scene whose every engine takes long (four_bar_chain: A02's 81
#: bodies over 20 s at three steps).
_SIMULATION_OPTIONAL = {"timeout": "validate's per-case limit in s"}
_PARAMETER_KEYS = {"value": True, "kind": True, "unit": False, "doc": False, "sets": False}


@dataclass(frozen=True)
class Parameter:
    """One physical parameter: its value, unit, kind (validation rule) and meaning; ``sets``:
    where a scene without code puts it in the multibody (``harness.model.from_model_file.TARGETS``,
    "" in a scene with a builder)."""

    name: str
    value: ParamValue
    unit: str
    kind: str
    doc: str
    sets: str = ""


@dataclass(frozen=True)
class Scene:
    """A scene with parameter values fixed (defaults plus overrides).

    Attributes:
        name, title, textbook: identity and provenance.
        directory: the scene's folder under ``models/``.
        mjcf: the file MuJoCo reads (absolute path): the scene's MJCF, or its URDF when it names
            only a URDF (MuJoCo compiles URDF: ``harness.engines.mujoco.model.read_spec``).
        urdf: the file Pinocchio and Drake read: the scene's URDF, or its MJCF when it names only
            an MJCF (Pinocchio's ``buildModelFromMJCF``, Drake's parser).
        model_files: the model-file keys its ``scene.toml`` names: ``("mjcf", "urdf")``,
            ``("mjcf",)`` or ``("urdf",)`` (``harness.engines.reads_other_format``).
        urdf_root_joint: root joint Pinocchio adds when loading the URDF (``free``,
            ``spherical`` or ``none``; ``none`` for a scene without a URDF, whose MJCF states
            its root joint).
        needs: ``{"gravity": bool, "contact": bool, "forcing": bool}``.
        parameters: name -> Parameter (values validated).
        t_end, dt, save_every: default horizon, step and save interval (s).
        timeout: validate's per-case wall-clock limit for this scene (s), or None for the
            command's ``--timeout`` (``[simulation] timeout``).
        checks: check name -> its table (which checks apply; ``components`` of momentum_drift).
        requirements: check name (``closure.position``) or check table (``closure``) -> a bound
            on its value at the scene's step that every engine must meet, in the check's unit
            (``[requirements]``; a project's ``--requirements`` file adds to it).
        model_differences: engine -> ``{"model": what differs, "bound": its size}``: an engine whose
            model differs from the scene's ideal one (``[model_differences.<engine>]``,
            ``harness.judging.verdict``).
        not_run: engine -> why it does not run this scene (``[not_run]``, and the engines'
            declared capabilities: ``harness.engines.check_scene`` adds an engine without loops
            on a loop scene, without the ideal rolling contact on a rolling one); ``validate``
            reports such an engine as not run.
        integrators: engine -> the integrator it runs this scene with (``[integrators]``, where
            the scene names one; ``harness.engines.check_scene`` adds each engine's declared
            default).
        builder: the module of ``harness.model.builders`` that builds the multibody (the
            scene's name unless its ``scene.toml`` names another, e.g. a copied scene).
        from_model_file: True for a scene without code: no builder module and no ``builder``
            key; its multibody is read from its model file (``harness.model.from_model_file``).
        initial_state: for a scene without code, ``zero`` (the default), ``qpos0`` or the name of
            a keyframe of its MJCF (``harness.model.from_model_file``); "" otherwise.
        generated: True for a scene whose model files are written from its built system for
            its current parameters (``generated = true``; ``mjcf`` and ``urdf`` are then those
            files, in the user's cache: ``harness.model.model_files``), False for files kept in
            its folder.

    The multibody is built once per ``Scene`` (on first use of ``multibody()``) and shared by
    every engine, check and tool that runs this scene; a copy with other parameters
    (``with_params``) builds its own.
    """

    name: str
    title: str
    textbook: tuple[str, ...]
    directory: Path
    mjcf: Path
    urdf: Path
    urdf_root_joint: str
    needs: Mapping[str, bool]
    parameters: Mapping[str, Parameter]
    t_end: float
    dt: float
    save_every: float
    integrators: Mapping[str, str]
    checks: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    requirements: Mapping[str, float] = field(default_factory=dict)
    model_differences: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    not_run: Mapping[str, str] = field(default_factory=dict)
    builder: str = ""
    from_model_file: bool = False
    initial_state: str = ""
    model_files: tuple[str, ...] = MODEL_FILE_KEYS
    generated: bool = False
    timeout: float | None = None
    _built: Multibody | None = field(default=None, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict:
        # the built multibody may hold closures (prescribed forces): a pickled scene rebuilds it
        return {k: v for k, v in self.__dict__.items() if k != "_built"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.__dict__["_built"] = None
        if self.generated and not (self.mjcf.is_file() and self.urdf.is_file()):  # another machine (a Dask worker)
            self.__dict__["mjcf"], self.__dict__["urdf"] = _write_generated(self)

    def mark_not_run(self, engine: str, why: str) -> None:
        """Record, before any run, that ``engine`` does not run this scene and why (as a
        ``[not_run]`` entry would): an engine that cannot read the scene's one model file
        (``harness.engines.reads_other_format``; ``harness.cli.main.preflight``). Changes this ``Scene`` only."""
        object.__setattr__(self, "not_run", {**self.not_run, engine: why})

    def default_integrators(self, defaults: Mapping[str, str]) -> None:
        """Give each engine of ``defaults`` (engine -> integrator) its default where the scene's
        ``[integrators]`` names none (``harness.engines.check_scene``, from the engines'
        declarations). Changes this ``Scene`` only."""
        object.__setattr__(self, "integrators", {**defaults, **self.integrators})

    @property
    def params(self) -> dict[str, ParamValue]:
        """Parameter values by name."""
        return {k: p.value for k, p in self.parameters.items()}

    def multibody(self) -> Multibody:
        """The scene's mechanical system, built from the parameter values and checked (once:
        later calls return the same object, which nobody may modify)."""
        if self._built is None:
            if self.from_model_file:
                model = scene_multibody(self)
            else:
                name = self.builder or self.name
                try:
                    module = importlib.import_module(f"harness.model.builders.{name}")
                except ModuleNotFoundError:
                    raise InputError(f"{self.directory / 'scene.toml'}: no builder harness.model.builders.{name} for scene "
                                     f"{self.name!r} (a copied scene names its system with builder = \"<original scene>\")") from None
                model = module.build(self.params)
            check_multibody(model, source=str(self.directory / "scene.toml"))
            object.__setattr__(self, "_built", model)
        return self._built

    def with_params(self, **overrides: Any) -> "Scene":
        """A copy with parameters overridden (values as numbers, sequences or strings)."""
        return apply_overrides(self, overrides)


def _write_generated(scene: Scene) -> tuple[Path, Path]:
    """The paths of a generated scene's MJCF and URDF, written from its built system
    (``harness.model.model_files.generated_files``; the step for the loops' ``solref``)."""
    return generated_files(scene.multibody(), scene.name, scene.mjcf.name, scene.urdf.name, scene.dt,
                           str(scene.directory / "scene.toml"))


def _with_generated_files(scene: Scene) -> Scene:
    """``scene`` pointing at its model files written for its parameters when it is generated
    (its system built once, here: a point its builder refuses is an InputError now); else as is."""
    if not scene.generated:
        return scene
    mjcf, urdf = _write_generated(scene)
    out = replace(scene, mjcf=mjcf, urdf=urdf)
    object.__setattr__(out, "_built", scene.multibody())
    return out


# --------------------------------------------------------------------------- scenes without code


def model_file_of(scene: Scene) -> Path:
    """The file a scene without code reads its system from: its MJCF when its ``scene.toml``
    names one, its URDF when it names only a URDF (``Scene.model_files``). A named MJCF that is
    missing is an InputError naming it, never a silent read of the URDF beside it."""
    files = list(dict.fromkeys((scene.mjcf, scene.urdf)))
    if "mjcf" in scene.model_files and not scene.mjcf.is_file() and scene.urdf.is_file() and len(files) == 2:
        raise InputError(f"{scene.directory / 'scene.toml'}: its MJCF {scene.mjcf.name} is not in {scene.directory}: "
                         f"a scene without a builder reads its system from the MJCF it names (not from "
                         f"{scene.urdf.name}; name only urdf = \"{scene.urdf.name}\" to read the URDF)")
    for path in files:
        if path.is_file():
            return path
    if len(files) == 1:
        raise InputError(f"{scene.directory / 'scene.toml'}: no model file: {files[0].name} is not in {scene.directory} "
                         "(a scene without a builder reads its system from its model file)")
    raise InputError(f"{scene.directory / 'scene.toml'}: no model file: neither {scene.mjcf.name} nor {scene.urdf.name} "
                     f"is in {scene.directory} (a scene without a builder reads its system from its MJCF, else its URDF)")


def scene_multibody(scene: Scene) -> Multibody:
    """The multibody of a scene without code: its model file (``model_file_of``) read in the
    harness's frames (``harness.model.from_model_file.read_model_file``), checked for what the
    engines cannot run from it (``check_runnable``), with the scene's parameters applied
    (``apply_parameters``)."""
    path = model_file_of(scene)
    mf = read_model_file(path, root_joint=scene.urdf_root_joint, initial=scene.initial_state or ZERO)
    # without a URDF the MJCF states the root joint: no urdf_root_joint to agree with
    check_runnable(mf, scene.urdf_root_joint if "urdf" in scene.model_files else None)
    return apply_parameters(mf, scene.parameters.values(), scene.directory / "scene.toml")


def builder_names() -> list[str]:
    """The builder modules of ``harness.model.builders`` (each has ``build(params)``): the
    values a ``builder`` key may take."""
    import pkgutil

    from harness.model import builders

    return sorted(m.name for m in pkgutil.iter_modules(builders.__path__)
                  if not m.ispkg and not m.name.startswith("_"))


def has_builder(name: str) -> bool:
    """Whether a builder module ``harness.model.builders.<name>`` exists (a package's
    ``__init__`` or a private module is none)."""
    if not name.isidentifier() or name.startswith("_"):
        return False
    return importlib.util.find_spec(f"harness.model.builders.{name}") is not None


def available_scenes(models_dir: Path | None = None) -> list[str]:
    """Names of all scenes under ``models/`` (folders with a ``scene.toml``)."""
    return sorted(p.parent.name for p in (models_dir or MODELS_DIR).glob("*/scene.toml"))


def is_plain_name(name: str) -> bool:
    """Whether ``name`` is a plain folder name (a scene name): not empty, not ``.`` or ``..``,
    no path separator, no leading or trailing blank, no NUL."""
    return (bool(name) and name not in (".", "..") and not any(c in name for c in "/\\\0")
            and name == name.strip())


def load_scene(name: str, overrides: Mapping[str, Any] | None = None, *, models_dir: Path | None = None) -> Scene:
    """Load a scene by name and apply parameter overrides.

    Raises:
        InputError: unknown scene; a scene.toml that is not UTF-8, not TOML or not a valid
            description (``check_description``); unknown parameter or a bad value.
    """
    root = models_dir or MODELS_DIR
    if not is_plain_name(name):
        raise InputError(f"scene name {name!r} is not a plain folder name of {root} (no / or \\, not . or ..): "
                         f"give one of {', '.join(available_scenes(root)) or 'none'}")
    path = root / name / "scene.toml"
    if not path.is_file():
        known = ", ".join(available_scenes(root)) or "none"
        raise InputError(f"unknown scene {name!r} (known: {known})")
    data = read_toml(path)
    try:
        scene = apply_overrides(_scene_from_toml(data, path), overrides or {})
        if not overrides:
            scene = _with_generated_files(scene)
    except (KeyError, TypeError) as err:  # pragma: no cover - check_description catches these first
        raise InputError(f"{path}: scene description lacks or misstates {err}") from None
    from harness.model.input_files import check_model_file

    for model_file in dict.fromkeys((scene.mjcf, scene.urdf)):  # before any engine opens them; missing: theirs to say
        check_model_file(model_file, missing_ok=True)
    return scene


def read_toml(path: Path) -> dict:
    """Parse a TOML file; InputError naming the file if it is not a regular file of bounded size
    (``harness.model.input_files``: a FIFO or a device is refused unread), not UTF-8 text or not
    valid TOML."""
    from harness.model.input_files import read_input_bytes

    try:
        text = read_input_bytes(Path(path), "TOML file").decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{path}: not UTF-8 text (byte 0x{err.object[err.start]:02x} at offset {err.start})") from None
    except OSError as err:
        raise InputError(f"{path}: cannot read: {err.strerror or err}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: malformed TOML: {err}") from None


def check_description(data: dict, path: Path) -> None:
    """Validate a parsed ``scene.toml`` as the loader reads it; InputError naming the file, the
    table and the key for: an unknown or missing top-level key, table or check table, a value of
    the wrong type, a parameter of unknown kind, a run setting that is not a positive finite
    number (or saves more than ``MAX_SAMPLES`` samples, or takes more than ``MAX_STEPS`` steps),
    a default integrator or a ``[not_run]`` reason that is not a string, a check table holding a
    number (``CHECKS``: no per-engine tolerances), a requirement naming no check of the scene or
    not a positive finite number, and a model difference without its model and floor. Which
    engines the per-engine tables may and must name is the registry's to say
    (``check_engine_tables``, called by ``harness.engines.check_scene``)."""
    _known_keys(data, _TOP_KEYS, path, "top level")
    for key, (what, required) in _TOP_KEYS.items():
        if key not in data:
            if required:
                raise InputError(f"{path}: lacks {_where(key)} ({what})")
            continue
        value = data[key]
        ok = {"string": lambda v: isinstance(v, str) and v.strip() != "",
              "list of strings": lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
              "table": lambda v: isinstance(v, dict), "boolean": lambda v: isinstance(v, bool)}[what](value)
        if not ok:
            raise InputError(f"{path}: {_where(key)} must be a {'non-empty ' if what == 'string' else ''}{what}, "
                             f"got {_show(value)}")
    if data["name"] != path.parent.name:
        raise InputError(f"{path}: name = {data['name']!r} differs from the scene's folder {path.parent.name!r}")
    if not any(key in data for key in MODEL_FILE_KEYS):
        raise InputError(f"{path}: names no model file: give mjcf = \"<file>.xml\", urdf = \"<file>.urdf\" or both "
                         "(every engine reads the one the scene has)")
    if "urdf" in data and not data["urdf"].lower().endswith(".urdf"):
        raise InputError(f"{path}: urdf = {data['urdf']!r} is not a *.urdf file")
    if "mjcf" in data and data["mjcf"].lower().endswith(".urdf"):
        raise InputError(f"{path}: mjcf = {data['mjcf']!r} is a URDF: name it urdf = {data['mjcf']!r}")
    if "urdf_root_joint" in data and "urdf" not in data:
        raise InputError(f"{path}: urdf_root_joint is for a URDF, which cannot state a free or ball root joint; this "
                         "scene names no urdf (its MJCF states its root joint): remove urdf_root_joint")
    if "urdf_root_joint" in data:
        from harness.model.joints import JOINTS

        roots = ["none"] + [jt.urdf_root for jt in JOINTS.values() if jt.urdf_root]
        if data["urdf_root_joint"] not in roots:
            raise InputError(f"{path}: urdf_root_joint = {data['urdf_root_joint']!r} is not one of {', '.join(roots)}")

    needs = data["needs"]
    _known_keys(needs, _NEEDS, path, "[needs]")
    for key in _NEEDS:
        if key not in needs:
            raise InputError(f"{path}: [needs] lacks {key} (true or false)")
        if not isinstance(needs[key], bool):
            raise InputError(f"{path}: [needs] {key} must be true or false, got {_show(needs[key])}")

    for pname, spec in data["parameters"].items():
        where = f"[parameters] {pname}"
        if not isinstance(spec, dict):
            raise InputError(f"{path}: {where} must be a table {{ value = ..., unit = ..., kind = ..., doc = ... }}, "
                             f"got {_show(spec)}")
        _known_keys(spec, _PARAMETER_KEYS, path, where)
        for key, required in _PARAMETER_KEYS.items():
            if required and key not in spec:
                raise InputError(f"{path}: {where} lacks {key}")
            if key in ("kind", "unit", "doc", "sets") and key in spec and not isinstance(spec[key], str):
                raise InputError(f"{path}: {where} {key} must be a string, got {_show(spec[key])}")
        if spec["kind"] not in KINDS:
            raise InputError(f"{path}: {where} kind = {spec['kind']!r} is not one of {', '.join(KINDS)}")
        raw = spec["value"]
        if not (_is_number(raw) or (isinstance(raw, list) and raw and all(_is_number(x) for x in raw))):
            raise InputError(f"{path}: {where} value must be a number or a list of numbers, got {_show(raw)}")

    sim = data["simulation"]
    _known_keys(sim, {**_SIMULATION, **_SIMULATION_OPTIONAL}, path, "[simulation]")
    if "timeout" in sim:
        _positive(sim["timeout"], path, "[simulation] timeout", _SIMULATION_OPTIONAL["timeout"])
    for key, what in _SIMULATION.items():
        if key not in sim:
            raise InputError(f"{path}: [simulation] lacks {key} ({what})")
        _positive(sim[key], path, f"[simulation] {key}", what)
    if sim["t_end"] / sim["save_every"] > MAX_SAMPLES:
        raise InputError(f"{path}: [simulation] t_end = {sim['t_end']!r} s over save_every = {sim['save_every']!r} s "
                         f"saves more than {MAX_SAMPLES:.0e} samples")
    check_steps(sim["t_end"], sim["dt"], f"{path}: [simulation] t_end and dt")

    for engine, why in data.get("not_run", {}).items():
        if not (isinstance(why, str) and why.strip()):
            raise InputError(f"{path}: [not_run] {engine} must say why the engine does not run this scene (a string), "
                             f"got {_show(why)}")
    for engine, method in data.get("integrators", {}).items():
        if not (isinstance(method, str) and method.strip()):
            raise InputError(f"{path}: [integrators] {engine} must be an integrator's name (a string), "
                             f"got {_show(method)}")

    for check, table in data.get("checks", {}).items():
        where = f"[checks.{check}]"
        if check not in CHECKS:
            close = difflib.get_close_matches(check, CHECKS, n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise InputError(f"{path}: unknown check table {where} ({hint}known: {', '.join(CHECKS)})")
        if not isinstance(table, dict):
            raise InputError(f"{path}: {where} must be a table (empty, or momentum_drift's components), got {_show(table)}")
        for key, value in table.items():
            if key in CHECKS[check]:
                continue
            if key in ("position", "orientation", "velocity", "regression_only") or isinstance(value, (int, float, dict)):
                raise InputError(f"{path}: {where} {key}: a check holds no tolerance (no per-engine numbers): every "
                                 "check is judged by how its error converges; a bound every engine must meet is a "
                                 "[requirements] entry, an engine's expected model difference a "
                                 "[model_differences.<engine>] table")
            _known_keys(table, CHECKS[check], path, where)
        if "components" in CHECKS[check]:
            value = table.get("components")
            if not (isinstance(value, list) and value and all(c in MOMENTUM_COMPONENTS for c in value)):
                raise InputError(f"{path}: {where} components must be a non-empty list of "
                                 f"{', '.join(MOMENTUM_COMPONENTS)}, got {_show(value)}")
    checks = data.get("checks", {})
    for key, value in data.get("requirements", {}).items():
        if key.split(".", 1)[0] not in checks and key.split(".", 1)[0] != "energy_balance":
            raise InputError(f"{path}: [requirements] {key}: names no check the scene makes ([checks.*]: "
                             f"{', '.join(checks) or 'none'})")
        _positive(value, path, f"[requirements] {key}", "a bound")
    for engine, table in data.get("model_differences", {}).items():
        where = f"[model_differences.{engine}]"
        if not isinstance(table, dict):
            raise InputError(f"{path}: {where} must be a table with model and floor, got {_show(table)}")
        _known_keys(table, MODEL_DIFFERENCE_KEYS, path, where)
        if not (isinstance(table.get("model"), str) and table["model"].strip()):
            raise InputError(f"{path}: {where} model must say what differs (a string)")
        _positive(table.get("bound"), path, f"{where} bound", "the error's bound relative to the quantity's scale")
    _check_code_or_data(data, path)


def check_engine_tables(scene: Scene, engines: Sequence[str]) -> None:
    """InputError naming the scene's ``scene.toml`` when its per-engine tables do not fit the
    registered ``engines`` (``harness.engines.ENGINE_NAMES``; ``harness.engines.check_scene``): a
    key of ``[not_run]`` or ``[integrators]`` that is no engine, a ``[model_differences.<engine>]``
    of an unknown engine, an engine neither excluded by ``[not_run]`` nor given a default
    integrator. The model layer knows no engine: the registry passes them."""
    path = scene.directory / "scene.toml"
    _known_keys(scene.not_run, engines, path, "[not_run]")
    _known_keys(scene.integrators, engines, path, "[integrators]")
    for engine in engines:
        if engine not in scene.not_run and engine not in scene.integrators:
            raise InputError(f"{path}: [integrators] lacks a default for {engine}")
    for engine in scene.model_differences:
        if engine not in engines:
            raise InputError(f"{path}: [model_differences.{engine}]: unknown engine (known: {', '.join(engines)})")


def without_code(data: dict) -> bool:
    """Whether a parsed ``scene.toml`` describes a scene without code: it names no ``builder``
    and no module ``harness.model.builders.<name>`` exists."""
    return "builder" not in data and not has_builder(str(data["name"]))


def _check_code_or_data(data: dict, path: Path) -> None:
    """A scene with a builder maps no parameter (``sets``, ``initial_state`` are refused); a
    scene without code maps every parameter onto its model file (``sets`` of
    ``harness.model.from_model_file.TARGETS``), has no contact and declares only the checks that
    need no builder (``CHECKS_WITHOUT_CODE``, and ``exact`` where ``references/<scene>.py`` has
    its closed forms: ``harness.measure.exact`` says when it has not)."""
    params = data["parameters"]
    if "builder" in data and not has_builder(data["builder"]):
        raise InputError(f"{path}: builder = {data['builder']!r} is not a builder: one of "
                         f"{', '.join(builder_names())} (or no builder key: a scene without code)")
    if data.get("generated"):
        _check_generated(data, path)
    if not without_code(data):
        system = data.get("builder") or data["name"]
        mapped = next((p for p, spec in params.items() if "sets" in spec), None)
        if mapped is not None or "initial_state" in data:
            what = f"[parameters] {mapped} sets" if mapped is not None else "initial_state"
            raise InputError(f"{path}: {what} is for a scene without a builder, and harness.model.builders.{system} "
                             "builds this one (it reads the parameters itself)")
        return
    for pname, spec in params.items():
        if "sets" not in spec:
            raise InputError(f"{path}: [parameters] {pname} lacks sets: a scene without a builder (no "
                             f"harness.model.builders.{data['name']}, no builder = \"<scene>\") puts each parameter into "
                             "its model file's system, e.g. sets = \"body.link1.mass\" (harness.model.from_model_file.TARGETS)")
        try:
            parse_target(spec["sets"])
        except ValueError as err:
            raise InputError(f"{path}: [parameters] {pname} {err}") from None
    if data["needs"]["contact"]:
        raise InputError(f"{path}: [needs] contact = true: a scene without a builder has no contact")
    for check in data.get("checks", {}):
        if check not in CHECKS_WITHOUT_CODE + ("exact",):
            raise InputError(f"{path}: [checks.{check}] needs a builder (a closed loop or a rolling contact): a scene "
                             f"without one can ask for {', '.join(CHECKS_WITHOUT_CODE)} (and exact with references/"
                             f"{data['name']}.py)")


def _check_generated(data: dict, path: Path) -> None:
    """``generated = true``: a builder makes the system (a scene without code reads its files),
    the scene names both files (the names they are written under) and keeps neither in its
    folder (one source: the description)."""
    if without_code(data):
        raise InputError(f"{path}: generated = true writes the model files from the system a builder makes; this scene "
                         f"has no builder (harness.model.builders.{data['name']}, or builder = \"<scene>\")")
    for key in MODEL_FILE_KEYS:
        if key not in data:
            raise InputError(f"{path}: generated = true writes an MJCF and a URDF: name both (mjcf = \"<file>.xml\", "
                             f"urdf = \"<file>.urdf\"); {key} is missing")
        if (path.parent / data[key]).exists():
            raise InputError(f"{path}: generated = true, yet {data[key]} is in {path.parent}: a generated scene's "
                             "files are written from its description; remove the file or the generated key")


def _where(key: str) -> str:
    return f"[{key}]" if _TOP_KEYS.get(key, ("",))[0] == "table" else key


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _positive(value: Any, path: Path, where: str, what: str) -> None:
    if not _is_number(value):
        raise InputError(f"{path}: {where} must be a number ({what}), got {_show(value)}")
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{path}: {where} must be positive and finite ({what}), got {value!r}")


def _known_keys(table: dict, known, path: Path, where: str) -> None:
    for key in table:
        if key not in known:
            close = difflib.get_close_matches(key, list(known), n=1)
            hint = f"did you mean {close[0]}? " if close else ""
            raise InputError(f"{path}: unknown key {key!r} at {where} ({hint}known: {', '.join(known)})")


def _scene_from_toml(data: dict, path: Path) -> Scene:
    check_description(data, path)
    params = {}
    for pname, spec in data["parameters"].items():
        value = _coerce(pname, spec["value"], spec["kind"], str(path))
        params[pname] = Parameter(pname, value, spec.get("unit", ""), spec["kind"], spec.get("doc", ""), spec.get("sets", ""))
    sim = data["simulation"]
    files = tuple(key for key in MODEL_FILE_KEYS if key in data)
    mjcf, urdf = (path.parent / data.get(key, data.get(other, "")) for key, other in (("mjcf", "urdf"), ("urdf", "mjcf")))
    scene = Scene(
        name=data["name"],
        title=data.get("title", data["name"]),
        textbook=tuple(data.get("textbook", ())),
        directory=path.parent,
        mjcf=mjcf,
        urdf=urdf,
        urdf_root_joint=data.get("urdf_root_joint", "none"),
        needs=dict(data.get("needs", {})),
        parameters=params,
        t_end=float(sim["t_end"]),
        dt=float(sim["dt"]),
        save_every=float(sim["save_every"]),
        integrators=dict(data.get("integrators", {})),
        checks=dict(data.get("checks", {})),
        requirements={k: float(v) for k, v in data.get("requirements", {}).items()},
        model_differences={e: {"model": str(d["model"]), "bound": float(d["bound"])}
                           for e, d in data.get("model_differences", {}).items()},
        not_run=dict(data.get("not_run", {})),
        builder=str(data.get("builder", "")),
        from_model_file=without_code(data),
        initial_state=str(data.get("initial_state", "")),
        model_files=files,
        generated=bool(data.get("generated", False)),
        timeout=float(sim["timeout"]) if "timeout" in sim else None,
    )
    return scene


def apply_overrides(scene: Scene, overrides: Mapping[str, Any]) -> Scene:
    """Return ``scene`` with parameter values replaced; each value is validated by its kind."""
    if not overrides:
        return scene
    params = dict(scene.parameters)
    source = f"scene {scene.name!r}"
    for key, raw in overrides.items():
        if key not in params:
            known = ", ".join(params)
            raise InputError(f"unknown parameter {key!r} for {source} (parameters: {known})")
        p = params[key]
        params[key] = replace(p, value=_coerce(key, raw, p.kind, source))
    return _with_generated_files(_follow(replace(scene, parameters=params), set(overrides)))


def _follow(scene: Scene, explicit: set[str]) -> Scene:
    """Recompute each parameter that the scene's builder lists in ``FOLLOWS`` (parameter name ->
    function of the parameter values) and that the overrides did not set: a default that follows
    the others, such as rolling_disk's ``dpsi0``, the steady spin for its ``theta0`` and
    ``dphi0``. A function that raises an arithmetic or value error, or gives a non-finite
    value, leaves the file's value."""
    name = scene.builder or scene.name
    if scene.from_model_file or not has_builder(name):
        return scene
    follows = getattr(importlib.import_module(f"harness.model.builders.{name}"), "FOLLOWS", {})
    params, values = dict(scene.parameters), scene.params
    for key, fn in follows.items():
        if key in explicit or key not in params:
            continue
        try:
            with np.errstate(all="raise"):
                value = float(fn(values))
        except (ArithmeticError, ValueError):  # FloatingPointError (np.errstate) is an ArithmeticError
            continue
        if math.isfinite(value):
            params[key] = replace(params[key], value=value)
    return replace(scene, parameters=params)


def parse_set(item: str) -> tuple[str, str]:
    """Split one ``--set KEY=VALUE`` argument; raise InputError when malformed."""
    key, sep, value = item.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise InputError(f"malformed --set {item!r}: expected KEY=VALUE, e.g. omega0=0.02,2,0.05")
    return key.strip(), value.strip()


def parse_sets(items: list[str] | None) -> dict[str, str]:
    """The ``--set KEY=VALUE`` arguments of a command as overrides (``parse_set`` each);
    InputError when a key is set twice (which value was meant is not for the harness to guess)."""
    overrides: dict[str, str] = {}
    for item in items or []:
        key, value = parse_set(item)
        if key in overrides:
            raise InputError(f"--set {key} is given twice ({key}={overrides[key]} and {key}={value}): set each "
                             "parameter once")
        overrides[key] = value
    return overrides


def _as_given(raw: Any) -> str:
    """A parameter value for a message as it was given: text as typed (quoted), a number (a
    Python or NumPy scalar: a sweep's values are NumPy's) plainly (``{x:g}``, never
    ``np.float64(0.0005)``), a sequence as its numbers joined by commas (``--set``'s form)."""
    if isinstance(raw, str):
        return repr(raw)
    if isinstance(raw, (list, tuple, np.ndarray)):
        return ",".join(_as_given(v) for v in raw)
    try:
        return f"{float(raw):g}"
    except (TypeError, ValueError):
        return repr(raw)


def _coerce(name: str, raw: Any, kind: str, source: str) -> ParamValue:
    """Convert and validate one parameter value according to its kind."""
    if isinstance(raw, bool) or (isinstance(raw, (list, tuple)) and any(isinstance(v, bool) for v in raw)):
        raise InputError(f"{source}: parameter {name!r}: not a number: {raw!r}")
    if kind not in KINDS:
        raise InputError(f"{source}: parameter {name!r} has unknown kind {kind!r} (known: {', '.join(KINDS)})")
    if isinstance(raw, str):
        parts = [s for s in raw.replace(" ", "").split(",") if s != ""]
        try:
            values = [float(s) for s in parts]
        except ValueError:
            raise InputError(f"{source}: parameter {name!r}: not a number: {raw!r}") from None
    elif isinstance(raw, (list, tuple, np.ndarray)):
        try:
            values = [float(v) for v in raw]
        except (TypeError, ValueError):
            raise InputError(f"{source}: parameter {name!r}: not a number: {raw!r}") from None
    else:
        try:
            values = [float(raw)]
        except (TypeError, ValueError):
            raise InputError(f"{source}: parameter {name!r}: not a number: {raw!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"{source}: parameter {name!r} must be finite, got {_as_given(raw)}")
    if any(abs(v) > MAX_PARAMETER for v in values):
        raise InputError(f"{source}: parameter {name!r} = {_as_given(raw)} is beyond +-{MAX_PARAMETER:g} (SI units): "
                         "no physical value is that large, and the computation would overflow")
    if kind == "vector3":
        if len(values) != 3:
            raise InputError(f"{source}: parameter {name!r} needs 3 components, got {len(values)}")
        return tuple(values)
    if len(values) != 1:
        raise InputError(f"{source}: parameter {name!r} is a scalar, got {len(values)} values")
    value = values[0]
    if kind == "positive" and not value > 0.0:
        raise InputError(f"{source}: parameter {name!r} must be > 0, got {value:g}")
    if kind == "nonnegative" and value < 0.0:
        raise InputError(f"{source}: parameter {name!r} must be >= 0, got {value:g}")
    return value
