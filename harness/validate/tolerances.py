"""A project's own tolerance file, merged over the scenes' declared tolerances.

Format (TOML), one table per scene and check, with the same keys as the scene's
``[checks.<name>]``::

    [heavy_top.energy_drift]
    mujoco = 1e-9            # tighten

    [double_pendulum.trajectory]
    position = 1e-5          # loosen, say why in your repository

Unknown scenes, checks or keys are errors, so a typo cannot silently leave a check unchanged.
"""

from __future__ import annotations

from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

from dataclasses import replace

from harness.model.errors import InputError
from harness.model.scene import Scene


def read_tolerances(path: Path) -> dict:
    """Parse a tolerance file; InputError (naming the file) if missing or malformed."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: tolerance file not found")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise InputError(f"{path}: malformed TOML: {err}") from None


def apply_tolerances(scene: Scene, table: dict, source: Path) -> tuple[Scene, list[str]]:
    """``scene`` with its tolerances replaced by the file's entries for it, and a list of
    ``"check.key: old -> new"`` changes for the report."""
    entries = table.get(scene.name, {})
    checks = {k: dict(v) for k, v in scene.checks.items()}
    changes = []
    for check, values in entries.items():
        if check not in checks:
            raise InputError(f"{source}: scene {scene.name!r} has no check {check!r} (checks: {', '.join(checks)})")
        if not isinstance(values, dict):
            raise InputError(f"{source}: [{scene.name}.{check}] must be a table of tolerances")
        for key, value in values.items():
            if key not in checks[check] or key == "components":
                raise InputError(f"{source}: [{scene.name}.{check}] has no tolerance {key!r}")
            try:
                new = float(value)
            except (TypeError, ValueError):
                raise InputError(f"{source}: [{scene.name}.{check}] {key} is not a number: {value!r}") from None
            if not new > 0:
                raise InputError(f"{source}: [{scene.name}.{check}] {key} must be positive, got {value!r}")
            was = checks[check][key]  # a number, or a table per engine (e.g. rolling_disk's trajectory)
            was = ", ".join(f"{e} {x:g}" for e, x in was.items()) if isinstance(was, dict) else f"{was:g}"
            changes.append(f"{check}.{key}: {was} -> {new:g}")
            checks[check][key] = new
    return replace(scene, checks=checks), changes


def check_scenes_known(table: dict, scene_names: list[str], source: Path) -> None:
    """InputError if the file names a scene that does not exist."""
    for name in table:
        if name not in scene_names:
            raise InputError(f"{source}: unknown scene {name!r} in tolerance file")
