"""A project's own tolerance file, merged over the scenes' declared tolerances.

Format (TOML), one table per scene and check, with the same keys as the scene's
``[checks.<name>]``::

    [heavy_top.energy_drift]
    mujoco = 1e-9            # tighten

    [double_pendulum.trajectory]
    position = 1e-5          # loosen, say why in your repository

    [rolling_disk.trajectory]
    position = { mujoco = 3e-3 }   # a quantity with a tolerance per engine: only MuJoCo's

Unknown scenes, checks or keys, and tolerances that are not positive finite numbers, are errors
(one line naming the file, table and key), so a typo cannot silently leave a check unchanged.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from harness.engines import ENGINE_NAMES
from harness.model.errors import InputError
from harness.model.scene import CHECKS, Scene, read_toml


def read_tolerances(path: Path) -> dict:
    """Parse and check a tolerance file: InputError (naming the file, and the table and key where
    one is wrong) if it is missing, not UTF-8, not TOML, or not tables ``[<scene>.<check>]`` of
    known checks (``harness.model.scene.CHECKS``) whose keys are tolerances of that check, each a
    positive finite number (or, for a quantity that has one per engine, a table of them)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: tolerance file not found")
    table = read_toml(path)
    for scene, checks in table.items():
        if not isinstance(checks, dict):
            raise InputError(f"{path}: {scene} = {checks!r}: expected tables [{scene}.<check>] of tolerances")
        for check, values in checks.items():
            where = f"[{scene}.{check}]"
            if check not in CHECKS:
                raise InputError(f"{path}: {where}: the harness has no check {check!r} (checks: {', '.join(CHECKS)})")
            if not isinstance(values, dict):
                raise InputError(f"{path}: {where} must be a table of tolerances, got {values!r}")
            for key, value in values.items():
                if key not in CHECKS[check] or key == "components":
                    known = ", ".join(k for k in CHECKS[check] if k != "components")
                    raise InputError(f"{path}: {where} has no tolerance {key!r} (tolerances: {known})")
                if isinstance(value, dict) and key not in ENGINE_NAMES:
                    for engine, x in value.items():
                        if engine not in ENGINE_NAMES:
                            raise InputError(f"{path}: {where} {key}: unknown engine {engine!r} "
                                             f"(known: {', '.join(ENGINE_NAMES)})")
                        _tolerance(x, path, f"{where} {key}.{engine}")
                else:
                    _tolerance(value, path, f"{where} {key}")
    return table


def _tolerance(value, path: Path, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{path}: {where} is not a number: {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{path}: {where} must be positive and finite, got {value!r}")
    return float(value)


def apply_tolerances(scene: Scene, table: dict, source: Path) -> tuple[Scene, list[str]]:
    """``scene`` with its tolerances replaced by the file's entries for it, and a list of
    ``"check.key: old -> new"`` changes for the report. ``table`` as ``read_tolerances`` returns
    it; InputError (naming ``source``) for a check or tolerance the scene does not declare."""
    entries = table.get(scene.name, {})
    if not isinstance(entries, dict):
        raise InputError(f"{source}: {scene.name} = {entries!r}: expected tables [{scene.name}.<check>] of tolerances")
    checks = {k: dict(v) for k, v in scene.checks.items()}
    changes = []
    for check, values in entries.items():
        if check not in checks:
            raise InputError(f"{source}: scene {scene.name!r} has no check {check!r} (checks: {', '.join(checks)})")
        if not isinstance(values, dict):
            raise InputError(f"{source}: [{scene.name}.{check}] must be a table of tolerances")
        for key, value in values.items():
            where = f"[{scene.name}.{check}] {key}"
            if key not in checks[check] or key in ("components", "regression_only"):
                raise InputError(f"{source}: [{scene.name}.{check}] has no tolerance {key!r}")
            was = checks[check][key]  # a number, or a table per engine (e.g. rolling_disk's trajectory)
            if isinstance(value, dict):
                old = was if isinstance(was, dict) else {e: was for e in ENGINE_NAMES}
                new = dict(old)
                for engine, x in value.items():
                    if engine not in ENGINE_NAMES:
                        raise InputError(f"{source}: {where}: unknown engine {engine!r} (known: {', '.join(ENGINE_NAMES)})")
                    new[engine] = _tolerance(x, source, f"{where}.{engine}")
                shown = ", ".join(f"{e} {x:g}" for e, x in new.items())
            else:
                new = _tolerance(value, source, where)
                shown = f"{new:g}"
            was = ", ".join(f"{e} {x:g}" for e, x in was.items()) if isinstance(was, dict) else f"{was:g}"
            changes.append(f"{check}.{key}: {was} -> {shown}")
            checks[check][key] = new
    return replace(scene, checks=checks), changes


def check_scenes_known(table: dict, scene_names: list[str], source: Path) -> None:
    """InputError if the file names a scene that does not exist."""
    for name in table:
        if name not in scene_names:
            raise InputError(f"{source}: unknown scene {name!r} in tolerance file")
