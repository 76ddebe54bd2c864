"""The tolerance file (``harness validate --tolerances``): every mistake is one InputError naming
the file, table and key; per-engine tolerances merge."""

import pytest

from harness.model.errors import InputError
from harness.model.scene import load_scene
from harness.validate.tolerances import apply_tolerances, read_tolerances


def _write(tmp_path, text: str | bytes):
    path = tmp_path / "tol.toml"
    (path.write_bytes if isinstance(text, bytes) else path.write_text)(text)
    return path


@pytest.mark.parametrize("text,fragment", [
    ("heavy_top = 5\n", "heavy_top = 5: expected tables [heavy_top.<check>] of tolerances"),
    ("[heavy_top]\nenergy_drift = 1e-9\n", "[heavy_top.energy_drift] must be a table of tolerances"),
    ("[heavy_top.enrgy_drift]\nmujoco = 1e-9\n", "[heavy_top.enrgy_drift]: the harness has no check 'enrgy_drift'"),
    ("[heavy_top.energy_drift]\nmujco = 1e-9\n", "[heavy_top.energy_drift] has no tolerance 'mujco'"),
    ("[heavy_top.momentum_drift]\ncomponents = [\"Lz\"]\n", "has no tolerance 'components'"),
    ("[heavy_top.energy_drift]\nmujoco = \"1e-9\"\n", "[heavy_top.energy_drift] mujoco is not a number: '1e-9'"),
    ("[heavy_top.energy_drift]\nmujoco = true\n", "[heavy_top.energy_drift] mujoco is not a number"),
    ("[heavy_top.energy_drift]\nmujoco = 0\n", "[heavy_top.energy_drift] mujoco must be positive and finite"),
    ("[heavy_top.energy_drift]\nmujoco = inf\n", "[heavy_top.energy_drift] mujoco must be positive and finite"),
    ("[heavy_top.energy_drift]\nmujoco = nan\n", "[heavy_top.energy_drift] mujoco must be positive and finite"),
    ("[heavy_top.trajectory]\nposition = { mujco = 1e-5 }\n", "[heavy_top.trajectory] position: unknown engine 'mujco'"),
    ("[heavy_top.trajectory]\nposition = { mujoco = -1 }\n", "[heavy_top.trajectory] position.mujoco must be positive"),
    (b"[heavy_top.energy_drift]\nmujoco = 1e-9 # \xe9\n", "not UTF-8 text (byte 0xe9 at offset 41)"),
    ("[heavy_top", "malformed TOML"),
])
def test_bad_tolerance_file_is_one_input_error(tmp_path, text, fragment):
    path = _write(tmp_path, text)
    with pytest.raises(InputError) as err:
        read_tolerances(path)
    message = str(err.value)
    assert message.startswith(f"{path}: ") and fragment in message, message
    assert "\n" not in message


def test_missing_tolerance_file(tmp_path):
    with pytest.raises(InputError, match="tolerance file not found"):
        read_tolerances(tmp_path / "nope.toml")


def test_tolerances_merge_and_are_reported(tmp_path):
    path = _write(tmp_path, "[rolling_disk.trajectory]\nposition = { mujoco = 3e-3 }\norientation = 1e-2\n"
                            "[rolling_disk.energy_drift]\nmujoco = 1e-3\n")
    scene = load_scene("rolling_disk")
    before = dict(scene.checks["trajectory"]["position"])
    assert before["mujoco"] != 3e-3 and scene.checks["energy_drift"]["mujoco"] != 1e-3
    new, changes = apply_tolerances(scene, read_tolerances(path), path)
    traj = new.checks["trajectory"]
    assert traj["position"] == before | {"mujoco": 3e-3}
    assert traj["orientation"] == 1e-2 and new.checks["energy_drift"]["mujoco"] == 1e-3
    assert scene.checks["trajectory"]["position"] == before  # the loaded scene is unchanged
    show = lambda table: ", ".join(f"{e} {v:g}" for e, v in table.items())  # noqa: E731
    assert f"trajectory.position: {show(before)} -> {show(traj['position'])}" in changes
    assert f"energy_drift.mujoco: {scene.checks['energy_drift']['mujoco']:g} -> 0.001" in changes


def test_tolerance_for_a_check_the_scene_lacks(tmp_path):
    path = _write(tmp_path, "[torque_free.reaction]\nmujoco = 1e-3\n")
    with pytest.raises(InputError, match="scene 'torque_free' has no check 'reaction'"):
        apply_tolerances(load_scene("torque_free"), read_tolerances(path), path)
