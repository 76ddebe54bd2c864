"""Files a user gives, checked before anything reads them (issue #29): regular files of bounded
size only, UTF-8 model files, includes and assets inside the model's folder."""

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from harness.model import input_files as inp
from harness.model.errors import InputError

ROD = ('<mujoco model="rod"><worldbody><body name="rod"><joint name="h" type="hinge"/>'
       '<inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/></body></worldbody></mujoco>')


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "robot.urdf"
    os.mkfifo(fifo)
    for call in (lambda: inp.check_input_file(fifo, "URDF"), lambda: inp.read_input_bytes(fifo, "URDF"),
                 lambda: inp.check_model_file(fifo), lambda: inp.parse_xml(fifo, "URDF")):
        with pytest.raises(InputError, match=r"robot\.urdf: the URDF is not a regular file but a FIFO"):
            call()


def test_a_link_to_a_device_is_refused_unread(tmp_path):
    link = tmp_path / "robot.urdf"
    link.symlink_to("/dev/zero")  # only opened for reading, and refused before a byte is read
    with pytest.raises(InputError, match=r"^\S+robot\.urdf: the URDF is not a regular file but a character device "
                                         r"\(a symlink to /dev/zero\)"):
        inp.read_input_bytes(link, "URDF")
    with pytest.raises(InputError, match="character device"):
        inp.check_model_file(link)


def test_size_limit_and_missing_files(tmp_path):
    big = tmp_path / "big.xml"
    big.write_bytes(b" " * 2048)
    assert inp.MAX_INPUT_BYTES == 64 * 2**20
    with pytest.raises(InputError, match=r"big\.xml: the MJCF is 0\.00195 MiB, more than the 0\.000977 MiB"):
        inp.check_input_file(big, "MJCF", limit=1024)
    with pytest.raises(InputError, match="more than"):
        inp.read_input_bytes(big, "MJCF", limit=1024)
    assert inp.read_input_bytes(big, "MJCF", limit=2048) == b" " * 2048
    with pytest.raises(InputError, match=r"gone\.xml: MJCF file not found"):
        inp.check_model_file(tmp_path / "gone.xml")
    inp.check_model_file(tmp_path / "gone.xml", missing_ok=True)
    with pytest.raises(InputError, match="not a regular file but a folder"):
        inp.check_input_file(tmp_path, "MJCF")


def test_a_model_file_must_be_utf8(tmp_path):
    latin = tmp_path / "cafe.xml"
    latin.write_bytes('<mujoco model="caf\xe9"/>'.encode("latin-1"))
    with pytest.raises(InputError, match=r"cafe\.xml: MJCF file is not UTF-8 text \(byte 0xe9 at offset 18\)"):
        inp.check_model_file(latin)


def _tree(tmp_path: Path) -> tuple[Path, Path]:
    model, outside = tmp_path / "model", tmp_path / "outside"
    (model / "parts").mkdir(parents=True)
    outside.mkdir()
    (outside / "evil.xml").write_text("<mujoco/>")
    (outside / "m.stl").write_text("solid")
    (model / "parts" / "arm.xml").write_text("<mujoco/>")
    return model, outside


@pytest.mark.parametrize("xml, refused", [
    ('<mujoco><include file="parts/arm.xml"/></mujoco>', None),
    ('<mujoco><include file="../outside/evil.xml"/></mujoco>', r"<include file> '\.\./outside/evil\.xml'"),
    ('<mujoco><include file="ABS/evil.xml"/></mujoco>', "<include file>"),
    ('<mujoco><include file="parts/nested.xml"/></mujoco>', r"<include file> '\.\./outside/evil\.xml'"),  # recursive
    ('<mujoco><asset><mesh name="m" file="../outside/m.stl"/></asset></mujoco>', "<mesh file>"),
    ('<mujoco><compiler meshdir="../outside"/><asset><mesh name="m" file="m.stl"/></asset></mujoco>', "<mesh file> 'm.stl'"),
    ('<mujoco><compiler assetdir="ABS"/><asset><texture name="t" type="cube" fileup="m.stl"/></asset></mujoco>',
     "<texture fileup>"),
    ('<mujoco><compiler meshdir="../outside"/></mujoco>', None),  # a folder no file is read from
    ('<mujoco><include file="link.xml"/></mujoco>', r"<include file> 'link\.xml' \(.*outside/evil\.xml\)"),
    ('<mujoco><include file="missing.xml"/></mujoco>', None),  # MuJoCo names a missing include
])
def test_mjcf_includes_and_assets_stay_in_the_models_folder(tmp_path, xml, refused):
    model, outside = _tree(tmp_path)
    (model / "parts" / "nested.xml").write_text('<mujoco><include file="../outside/evil.xml"/></mujoco>')
    (model / "link.xml").symlink_to(outside / "evil.xml")  # inside by name, outside once resolved
    path = model / "robot.xml"
    path.write_text(xml.replace("ABS", str(outside)))
    if refused is None:
        inp.check_model_file(path)
        return
    with pytest.raises(InputError) as err:
        inp.check_model_file(path)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ") and f"outside the model's folder {model}" in msg, msg
    assert __import__("re").search(refused, msg), msg
    inp.check_model_file(path, [outside])  # a folder the user allows (harness check --allow-dir)


def test_urdf_meshes_stay_in_the_models_folder(tmp_path):
    model, outside = _tree(tmp_path)
    path = model / "robot.urdf"
    mesh = '<robot name="r"><link name="a"><visual><geometry><mesh filename="{}"/></geometry></visual></link></robot>'
    for name in ("package://r/meshes/m.stl", "meshes/m.stl", "parts/../m.stl"):
        path.write_text(mesh.format(name))
        inp.check_model_file(path)
    for name in ("../outside/m.stl", f"file://{outside}/m.stl", str(outside / "m.stl")):
        path.write_text(mesh.format(name))
        with pytest.raises(InputError, match=r"<mesh filename> .* is outside the model's folder"):
            inp.check_model_file(path)
        inp.check_model_file(path, [outside])
    path.write_text('<robot name="r"><mujoco><compiler meshdir="../outside"/></mujoco>'
                    + mesh.format("m.stl").removeprefix('<robot name="r">'))
    with pytest.raises(InputError, match=r"<mujoco><compiler meshdir> '\.\./outside'"):
        inp.check_model_file(path)


def test_an_asset_that_is_a_fifo_is_refused(tmp_path):
    os.mkfifo(tmp_path / "m.stl")
    path = tmp_path / "robot.xml"
    path.write_text('<mujoco><asset><mesh name="m" file="m.stl"/></asset></mujoco>')
    with pytest.raises(InputError, match=r"<mesh> file 'm\.stl' is not a regular file but a FIFO"):
        inp.check_model_file(path)


def test_xml_that_does_not_parse_is_left_to_the_loaders(tmp_path):
    path = tmp_path / "broken.xml"
    path.write_text("<mujoco><worldbody>")
    inp.check_model_file(path)
    with pytest.raises(ET.ParseError):
        inp.parse_xml(path, "MJCF")
    (tmp_path / "rod.xml").write_text(ROD)
    assert inp.parse_xml(tmp_path / "rod.xml", "MJCF").get("model") == "rod"
