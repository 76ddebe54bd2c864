"""Scene descriptions: load ``models/<scene>/scene.toml``, apply overrides, build the physics.

A scene's TOML file is the single source of its parameters, initial state, run settings,
textbook provenance and checks. ``load_scene(name, overrides)`` returns a frozen ``Scene`` with
validated parameter values; ``scene.multibody()`` builds the physics (``harness.model.multibody``) that
every engine runs.
"""

from __future__ import annotations

import importlib
import importlib.resources
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

import numpy as np

from harness.model.errors import InputError
from harness.model.multibody import Multibody
from harness.model.sanity import check_multibody

# The repository's models/ folder, installed as the package harness.models (pyproject.toml), so
# an editable install, a plain ``pip install .`` and a wheel all find it. A regular (not zipped)
# install: the resource is a folder on disk, as MuJoCo and Pinocchio need to open the files.
MODELS_DIR = Path(str(importlib.resources.files("harness.models")))

ParamValue = float | tuple[float, ...]


@dataclass(frozen=True)
class Parameter:
    """One physical parameter: its value, unit, kind (validation rule) and meaning."""

    name: str
    value: ParamValue
    unit: str
    kind: str
    doc: str


@dataclass(frozen=True)
class Scene:
    """A scene with parameter values fixed (defaults plus overrides).

    Attributes:
        name, title, textbook: identity and provenance.
        directory: the scene's folder under ``models/``.
        mjcf, urdf: model files (absolute paths).
        urdf_root_joint: root joint Pinocchio adds when loading the URDF (``free``,
            ``spherical`` or ``none``).
        needs: ``{"gravity": bool, "contact": bool, "forcing": bool}``.
        parameters: name -> Parameter (values validated).
        t_end, dt, save_every: default horizon, step and save interval (s).
        integrators: default integrator per engine.
        checks: check name -> settings (tolerances per engine or per quantity).
        builder: the module of ``harness.model.builders`` that builds the multibody (the
            scene's name unless its ``scene.toml`` names another, e.g. a copied scene).

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
    builder: str = ""
    _built: Multibody | None = field(default=None, init=False, repr=False, compare=False)

    def __getstate__(self) -> dict:
        # the built multibody may hold closures (prescribed forces): a pickled scene rebuilds it
        return {k: v for k, v in self.__dict__.items() if k != "_built"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.__dict__["_built"] = None

    @property
    def params(self) -> dict[str, ParamValue]:
        """Parameter values by name."""
        return {k: p.value for k, p in self.parameters.items()}

    def multibody(self) -> Multibody:
        """The scene's mechanical system, built from the parameter values and checked (once:
        later calls return the same object, which nobody may modify)."""
        if self._built is None:
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


def available_scenes(models_dir: Path | None = None) -> list[str]:
    """Names of all scenes under ``models/`` (folders with a ``scene.toml``)."""
    return sorted(p.parent.name for p in (models_dir or MODELS_DIR).glob("*/scene.toml"))


def load_scene(name: str, overrides: Mapping[str, Any] | None = None, *, models_dir: Path | None = None) -> Scene:
    """Load a scene by name and apply parameter overrides.

    Raises:
        InputError: unknown scene, malformed TOML, unknown parameter or a bad value.
    """
    root = models_dir or MODELS_DIR
    path = root / name / "scene.toml"
    if not path.is_file():
        known = ", ".join(available_scenes(root)) or "none"
        raise InputError(f"unknown scene {name!r} (known: {known})")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: malformed TOML: {err}") from None
    try:
        return apply_overrides(_scene_from_toml(data, path), overrides or {})
    except (KeyError, TypeError) as err:
        raise InputError(f"{path}: scene description lacks or misstates {err}") from None


def _scene_from_toml(data: dict, path: Path) -> Scene:
    params = {}
    for pname, spec in data["parameters"].items():
        value = _coerce(pname, spec["value"], spec["kind"], str(path))
        params[pname] = Parameter(pname, value, spec.get("unit", ""), spec["kind"], spec.get("doc", ""))
    sim = data["simulation"]
    for key in ("t_end", "dt", "save_every"):
        value = float(sim[key])
        if not (math.isfinite(value) and value > 0.0):
            raise InputError(f"{path}: [simulation] {key} must be positive and finite, got {sim[key]!r}")
    scene = Scene(
        name=data["name"],
        title=data.get("title", data["name"]),
        textbook=tuple(data.get("textbook", ())),
        directory=path.parent,
        mjcf=path.parent / data["mjcf"],
        urdf=path.parent / data["urdf"],
        urdf_root_joint=data.get("urdf_root_joint", "none"),
        needs=dict(data.get("needs", {})),
        parameters=params,
        t_end=float(sim["t_end"]),
        dt=float(sim["dt"]),
        save_every=float(sim["save_every"]),
        integrators=dict(data.get("integrators", {})),
        checks=dict(data.get("checks", {})),
        builder=str(data.get("builder", "")),
    )
    for engine in ("inhouse", "mujoco", "pinocchio"):
        if engine not in scene.integrators:
            raise InputError(f"{path}: [integrators] lacks a default for {engine}")
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
    return replace(scene, parameters=params)


def parse_set(item: str) -> tuple[str, str]:
    """Split one ``--set KEY=VALUE`` argument; raise InputError when malformed."""
    key, sep, value = item.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise InputError(f"malformed --set {item!r}: expected KEY=VALUE, e.g. omega0=0.02,2,0.05")
    return key.strip(), value.strip()


def _coerce(name: str, raw: Any, kind: str, source: str) -> ParamValue:
    """Convert and validate one parameter value according to its kind."""
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
        raise InputError(f"{source}: parameter {name!r} must be finite, got {raw!r}")
    if kind == "vector3":
        if len(values) != 3:
            raise InputError(f"{source}: parameter {name!r} needs 3 components, got {len(values)}")
        return tuple(values)
    if len(values) != 1:
        raise InputError(f"{source}: parameter {name!r} is a scalar, got {len(values)} values")
    value = values[0]
    if kind == "positive" and not value > 0.0:
        raise InputError(f"{source}: parameter {name!r} must be > 0, got {value!r}")
    if kind == "nonnegative" and value < 0.0:
        raise InputError(f"{source}: parameter {name!r} must be >= 0, got {value!r}")
    return value
