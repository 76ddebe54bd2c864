"""A scene's model files as written, each loaded by the engine that reads it and measured against
the scene at the defaults of its ``scene.toml``, which the files must hold.

``load_mjcf``/``load_urdf`` overwrite mass properties with the scene's parameters, so an error in
a file shows here only: MuJoCo compiles the MJCF (``read_spec().compile()``), Pinocchio, Drake and
PyBullet read the URDF with their own parsers, and Exudyn (which reads no file) is built from the
description. Every body's quantities are measured by ``harness.engines.loaded_models``
(``body_discrepancies``). ``harness validate`` checks this at the start of every run (its
``model.*`` checks, ``harness.validate.run.model_checks``) and ``harness inspect`` shows it
(``harness.tools.inspection``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from harness.engines.loaded_models import (
    Discrepancy,
    body_discrepancies,
    check_joint_bodies_physical,
    exudyn_bodies,
    exudyn_gravity,
    gravity_discrepancy,
    mujoco_bodies,
    mujoco_force_discrepancies,
    mujoco_loop_discrepancies,
    pinocchio_bodies,
    pinocchio_joint_bodies,
)
from harness.engines.mujoco.model import check_spec_inertials, read_spec
from harness.engines.pinocchio.model import read_urdf
from harness.model.errors import InputError
from harness.model.multibody import Multibody
from harness.model.scene import Scene, load_scene

AS_WRITTEN_RTOL = 1e-6   # the files carry rounded decimals (e.g. 0.083358333333333)
APPLIED_RTOL = 1e-9
MODEL_FILE_ENGINES = ("mujoco", "pinocchio")  # the engines that read a scene's model file (MJCF, URDF)
MODEL_FILE_ENGINES = MODEL_FILE_ENGINES + ("drake",)  # Drake reads the URDF with its own parser
MODEL_FILE_ENGINES = MODEL_FILE_ENGINES + ("pybullet",)  # PyBullet too (inertia from the file, URDF_USE_INERTIA_FROM_FILE)
MODEL_ENGINES = MODEL_FILE_ENGINES + ("exudyn",)  # ... and those whose model as built is checked (Exudyn: from the description)


@dataclass
class AsWritten:
    """One engine's load of its model file as written, against the scene at its defaults.

    ``engine``: ``mujoco`` (the MJCF, ``read_spec().compile()``), ``pinocchio`` (the URDF,
    ``read_urdf`` with the scene's root joint), ``drake``, ``pybullet`` (the URDF, PyBullet's ``loadURDF`` with
    ``URDF_USE_INERTIA_FROM_FILE``) or ``exudyn`` (no file: the system built from
    the scene's description, ``harness.engines.exudyn.model``); ``path``: the file
    (``scene.toml`` for Exudyn); ``model``: the compiled ``MjModel``, ``pin.Model``, Drake's
    ``(plant, joints)`` (``harness.engines.drake.model.parse``), PyBullet's ``LoadedBody`` list (its server is
    closed: ``harness.engines.pybullet.model.pybullet_bodies``) or the ``ExudynSystem``; ``discrepancies``: every quantity of every body
    (``harness.engines.loaded_models.body_discrepancies`` at ``AS_WRITTEN_RTOL``) and, for the
    MJCF, its gravity (at ``APPLIED_RTOL``; a URDF cannot state gravity).
    """

    engine: str
    path: Path
    model: Any
    discrepancies: list[Discrepancy]

    @property
    def problems(self) -> list[str]:
        return [d.message for d in self.discrepancies if not d.passed]


def scene_defaults(scene: Scene) -> Scene:
    """The scene at the defaults of its ``scene.toml``: the values its model files must hold
    (re-read from the scene's folder, so ``--set`` overrides are not in it)."""
    return load_scene(scene.directory.name, models_dir=scene.directory.parent)


def files_hold(scene: Scene) -> Scene:
    """The scene whose values ``scene``'s model files must hold: its ``scene.toml`` defaults
    (``scene_defaults``), or the scene itself where its files are written from its description
    for its parameters (``Scene.generated``: ``harness.model.model_files``)."""
    return scene if scene.generated else scene_defaults(scene)


def as_written(scene: Scene, engine: str, model0: Multibody | None = None) -> AsWritten:
    """``engine``'s model file of ``scene`` loaded as written and measured against ``model0``
    (default: the scene whose values the files must hold, ``files_hold``). InputError if the file
    does not load or holds a non-physical body."""
    if model0 is None:
        model0 = files_hold(scene).multibody()
    if engine == "mujoco":
        m = _compile_as_written(scene)
        found = body_discrepancies(mujoco_bodies(m, model0), model0, rtol=AS_WRITTEN_RTOL)
        found += mujoco_loop_discrepancies(m, model0, rtol=AS_WRITTEN_RTOL)  # cut joints: the <connect> sites
        found += mujoco_force_discrepancies(m, model0, rtol=AS_WRITTEN_RTOL)  # motors and tendon springs
        found.append(gravity_discrepancy(np.asarray(m.opt.gravity, dtype=float), model0.gravity_W, APPLIED_RTOL))
        return AsWritten(engine, scene.mjcf, m, found)
    if engine == "pinocchio":
        p = read_urdf(scene.urdf, scene.urdf_root_joint)
        check_joint_bodies_physical(pinocchio_joint_bodies(p), str(scene.urdf))
        return AsWritten(engine, scene.urdf, p, body_discrepancies(pinocchio_bodies(p, model0), model0, rtol=AS_WRITTEN_RTOL))
    if engine == "drake":  # the URDF as Drake's own parser reads it (a URDF cannot state gravity)
        from harness.engines.drake.model import drake_bodies, parse

        plant, _, joints = parse(scene.urdf, scene.urdf_root_joint, model0, springs=False)
        return AsWritten(engine, scene.urdf, (plant, joints),
                         body_discrepancies(drake_bodies(plant, joints, model0), model0, rtol=AS_WRITTEN_RTOL))
    if engine == "pybullet":  # the URDF as PyBullet's importer reads it, inertia from the file (a URDF cannot state gravity)
        from harness.engines.pybullet.model import Server, pybullet_bodies
        from harness.engines.pybullet.model import read_urdf as pybullet_read_urdf

        with Server() as client:
            body = pybullet_read_urdf(scene.urdf, scene.urdf_root_joint, client)
            loaded = pybullet_bodies(body, client, model0, scene.urdf_root_joint)
        return AsWritten(engine, scene.urdf, loaded, body_discrepancies(loaded, model0, rtol=AS_WRITTEN_RTOL))
    if engine == "exudyn":  # built from the description (Exudyn reads no model file): what it holds
        from harness.engines.exudyn.integrators import NODE_TYPE
        from harness.engines.exudyn.model import build

        system = build(model0, NODE_TYPE[scene.integrators["exudyn"]])
        found = body_discrepancies(exudyn_bodies(system, model0), model0, rtol=AS_WRITTEN_RTOL)
        found.append(gravity_discrepancy(exudyn_gravity(system), model0.gravity_W, APPLIED_RTOL))
        return AsWritten(engine, scene.directory / "scene.toml", system, found)
    raise ValueError(f"engine {engine!r} builds no model to check (those that do: {', '.join(MODEL_ENGINES)})")


def as_read(scene: Scene, engine: str, model0: Multibody) -> AsWritten:
    """``as_written``, for a scene that names one model file only as each engine reads that file:
    Pinocchio and Drake the MJCF (``as_written`` through their MJCF parsers), MuJoCo the URDF
    with the scene's root joint added (a URDF cannot state gravity, which is not checked there,
    as for Pinocchio and Drake). ``harness validate``'s ``model.*`` checks."""
    from harness.engines import reads_other_format

    if engine == "mujoco" and reads_other_format(scene, engine):  # the URDF into MuJoCo, as written
        m = read_spec(scene.mjcf, root_joint=scene.urdf_root_joint).compile()
        return AsWritten(engine, scene.mjcf, m, body_discrepancies(mujoco_bodies(m, model0), model0, rtol=AS_WRITTEN_RTOL))
    return as_written(scene, engine, model0)


def _compile_as_written(scene: Scene) -> mujoco.MjModel:
    spec = read_spec(scene.mjcf)
    check_spec_inertials(spec, scene.mjcf)
    try:
        return spec.compile()
    except InputError:
        raise
    except Exception as err:
        raise InputError(f"{scene.mjcf}: MJCF does not compile: {' '.join(str(err).split())}") from None
