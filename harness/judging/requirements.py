"""A project's own requirements, added over the scenes' (``--requirements FILE.toml``).

A requirement bounds one check's value at the scene's step, in the check's unit, for every
engine alike: the accuracy a project needs of every engine, on top of the harness's judging by
convergence (``harness.judging.verdict``). Format (TOML), one table per scene, a key per check
(its full name, ``trajectory.position``, or its table, ``closure`` for every ``closure.*``)::

    [heavy_top]
    exact = 1e-6                      # rad: the nutation within 1e-6 of the closed form
    "trajectory.position" = 1e-7      # of the motion's length scale

    [four_bar]
    "closure.position" = 1e-9         # m

A key names a check the scene makes (its ``[checks.*]``, ``harness validate`` lists every check
it made); the value is a positive finite number. An entry that changes a requirement the scene
states itself is reported (``changes``: "tightens" or "loosens", with both values) and printed by
``harness validate`` as a warning: a scene's requirements are physical, a project should say why
it departs from them. Unknown scenes or checks and values that are not positive finite numbers
are errors (one line naming the file, the table and the key), so a typo cannot leave a check
unbounded.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from harness.model.errors import InputError
from harness.model.scene import CHECKS, Scene, read_toml


def read_requirements(path: Path) -> dict:
    """Parse and check a requirements file: InputError (naming the file, and the table and key
    where one is wrong) if it is missing, not a regular file, not UTF-8, not TOML, or not tables
    ``[<scene>]`` of ``check = bound`` with known checks (``harness.model.scene.CHECKS``, or a
    ``<check>.<quantity>``) and positive finite bounds."""
    from harness.model.input_files import check_input_file

    path = Path(path)
    check_input_file(path, "requirements file")
    table = read_toml(path)
    for scene, entries in table.items():
        if not isinstance(entries, dict):
            raise InputError(f"{path}: {scene} = {entries!r}: expected a table [{scene}] of check = bound")
        for key, value in entries.items():
            head = key.split(".", 1)[0]
            if head not in CHECKS and head != "energy_balance":
                raise InputError(f"{path}: [{scene}] {key}: the harness has no check {head!r} (checks: {', '.join(CHECKS)})")
            _bound(value, path, f"[{scene}] {key}")
    return table


def _bound(value, path: Path, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{path}: {where} is not a number: {value!r}")
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{path}: {where} must be positive and finite, got {value!r}")
    return float(value)


def apply_requirements(scene: Scene, table: dict, source: Path) -> tuple[Scene, list[str]]:
    """``scene`` with the file's requirements for it added over its own, and the changes for the
    report: ``"exact <= 1e-06 (added)"``, ``"closure.position <= 1e-09 (tightens 1e-06)"``.
    InputError (naming ``source``) for a check the scene does not make."""
    entries = table.get(scene.name, {})
    reqs = dict(scene.requirements)
    changes = []
    for key, value in entries.items():
        head = key.split(".", 1)[0]
        if head not in scene.checks and not (head == "energy_balance" and "energy_drift" in scene.checks):
            raise InputError(f"{source}: [{scene.name}] {key}: the scene makes no {head} check "
                             f"(its checks: {', '.join(scene.checks)})")
        new = _bound(value, source, f"[{scene.name}] {key}")
        was = reqs.get(key)
        if was is None:
            changes.append(f"{key} <= {new:g} (added)")
        elif new != was:
            changes.append(f"{key} <= {new:g} ({'tightens' if new < was else 'loosens'} the scene's {was:g})")
        reqs[key] = new
    return replace(scene, requirements=reqs), changes


def check_scenes_known(table: dict, scene_names: list[str], source: Path) -> None:
    """InputError if the file names a scene that does not exist."""
    for name in table:
        if name not in scene_names:
            raise InputError(f"{source}: unknown scene {name!r} in the requirements file (scenes: {', '.join(scene_names)})")
