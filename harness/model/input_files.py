"""The files a user gives, checked before anything reads them.

A model file (an MJCF or a URDF given to ``harness check``, found by ``harness zoo`` in a folder,
or named by a scene's ``scene.toml``), a ``scene.toml``, a ``--requirements`` file and a
``--joint-map`` file are opened by path, by the harness and by the loaders it calls (MuJoCo,
Pinocchio, Drake), and read whole: a FIFO would block the reader forever, a device (a symlink to
``/dev/zero``) would be read until memory runs out. So, before any of them is read:

* ``check_input_file(path, what)``: after resolving symlinks, ``path`` must be a regular file of
  at most ``MAX_INPUT_BYTES``; anything else is an ``InputError``, one line naming the file and
  why (``robot.urdf: the URDF is not a regular file but a character device (a symlink to
  /dev/zero)``).
* ``read_input_bytes`` / ``read_input_text``: read such a file here, safely: opened without
  blocking, checked on the open descriptor (a file swapped for a FIFO after the check is still
  refused), read up to the limit; ``read_input_text`` also refuses text that is not UTF-8.
* ``check_model_file(path, allowed_dirs)``: the above for a model file, which must also be UTF-8
  text, and the files it makes a loader open must lie inside the model's folder or one of
  ``allowed_dirs`` (``harness check --allow-dir DIR``), symlinks resolved: an MJCF's
  ``<include file=...>`` (followed recursively, as MuJoCo resolves them: relative to the main
  file's folder), its meshes, skins, height fields and textures (under the compiler's
  ``meshdir``, ``texturedir``, ``assetdir``) and ``<model file=...>`` assets; a URDF's
  ``<mesh filename=...>`` given as a path (``package://`` URIs are not paths) and the
  ``meshdir`` of its ``<mujoco><compiler>``. One outside is an ``InputError`` naming the
  reference and the folder. An included file is checked as the model file is; an asset file
  that exists must be a regular file (no size limit: a mesh may be large). A missing file and
  XML that does not parse are left to the loaders, whose messages name them.
"""

from __future__ import annotations

import errno
import os
import stat
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Iterable

from harness.model.errors import InputError

#: The largest file the harness reads whole, in bytes (64 MiB). A model file is text: the largest
#: this project checks are a few hundred kB (example-robot-data's tiago_dual.urdf 0.21 MB,
#: dm_control's dog.xml 0.08 MB; meshes are separate files), so 64 MiB leaves a factor of 300 for
#: real models while a file or device that would fill the memory (a generated or corrupted file,
#: a link to /dev/zero) is refused at once. TOML and joint-map files get the same bound.
MAX_INPUT_BYTES = 64 * 2**20

#: How deep ``<include>`` may nest (MuJoCo itself refuses an include cycle; this bounds the walk).
MAX_INCLUDE_DEPTH = 20

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISDIR, "a folder"), (stat.S_ISSOCK, "a socket"))


def _kind(mode: int) -> str:
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def _via(path: Path) -> str:
    """`` (a symlink to <target>)`` when ``path`` is a symlink, else empty."""
    if not os.path.islink(path):
        return ""
    try:
        return f" (a symlink to {os.path.realpath(path)})"
    except OSError:  # pragma: no cover - realpath does not raise on Linux
        return " (a symlink)"


def _mib(n: float) -> str:
    return f"{n / 2**20:.3g} MiB"


def _judge(path: Path, st: os.stat_result, what: str, limit: int | None) -> None:
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{path}: the {what} is not a regular file but {_kind(st.st_mode)}{_via(path)}: "
                         "only a regular file is read")
    if limit is not None and st.st_size > limit:
        raise InputError(f"{path}: the {what} is {_mib(st.st_size)}, more than the {_mib(limit)} a file given to "
                         "the harness may be (harness.model.input_files.MAX_INPUT_BYTES)")


def _os_error(path: Path, err: OSError, what: str) -> InputError:
    if err.errno == errno.ENOENT:
        return InputError(f"{path}: {what if what.endswith('file') else what + ' file'} not found")
    return InputError(f"{path}: cannot read the {what}: {err.strerror or err}")


def check_input_file(path: Path, what: str, *, limit: int | None = MAX_INPUT_BYTES, missing_ok: bool = False) -> bool:
    """InputError unless ``path`` (symlinks resolved) is a regular file of at most ``limit``
    bytes (None: any size); ``what`` names it in the message (``MJCF``, ``URDF``, ``tolerance
    file``). A missing file is an InputError too, unless ``missing_ok`` (then False is returned:
    the caller's loader reports it with its own message); True when the file passed."""
    path = Path(path)
    try:
        st = os.stat(path)
    except OSError as err:
        if missing_ok and err.errno in (errno.ENOENT, errno.ENOTDIR):
            return False
        raise _os_error(path, err, what) from None
    _judge(path, st, what, limit)
    return True


def read_input_bytes(path: Path, what: str, *, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (``check_input_file``'s conditions, checked on the
    open file): opened non-blocking, so a FIFO is refused, not waited on; read up to ``limit``."""
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as err:
        if err.errno == errno.ENXIO:  # a FIFO without a writer, opened for reading only: never here
            raise InputError(f"{path}: the {what} is not a regular file but a FIFO (named pipe)") from None
        raise _os_error(path, err, what) from None
    try:
        _judge(path, os.fstat(fd), what, limit)
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:  # it grew while read (a file being written, /proc)
            raise InputError(f"{path}: the {what} is more than the {_mib(limit)} a file given to the harness may be "
                             "(harness.model.input_files.MAX_INPUT_BYTES)")
        return b"".join(chunks)
    except OSError as err:
        raise _os_error(path, err, what) from None
    finally:
        os.close(fd)


def utf8_error(path: Path, what: str, err: UnicodeDecodeError) -> InputError:
    """The one line for a file that is not UTF-8 text."""
    return InputError(f"{path}: {what} file is not UTF-8 text (byte 0x{err.object[err.start]:02x} at offset "
                      f"{err.start})")


def read_input_text(path: Path, what: str, *, limit: int = MAX_INPUT_BYTES) -> str:
    """``read_input_bytes`` decoded as UTF-8; InputError naming the first bad byte otherwise."""
    data = read_input_bytes(path, what, limit=limit)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise utf8_error(path, what, err) from None


def parse_xml(path: Path, what: str) -> ET.Element:
    """The root element of the XML file ``path``, read with ``read_input_bytes``; ``ET.ParseError``
    as ElementTree raises it for XML that does not parse."""
    return ET.fromstring(read_input_bytes(path, what))


def model_format(path: Path) -> str:
    """``URDF`` for ``*.urdf``, else ``MJCF`` (as the loaders decide)."""
    return "URDF" if Path(path).suffix.lower() == ".urdf" else "MJCF"


# ----------------------------------------------------------------------------- references


def _inside(target: Path, folders: list[Path]) -> bool:
    return any(target == f or f in target.parents for f in folders)


def _folders_text(folders: list[Path]) -> str:
    return folders[0].as_posix() if len(folders) == 1 else "any of " + ", ".join(f.as_posix() for f in folders)


def check_model_file(path: Path, allowed_dirs: Iterable[Path] = (), *, what: str | None = None,
                     missing_ok: bool = False) -> None:
    """Check a model file before any loader opens it (module docstring): a regular file of at
    most ``MAX_INPUT_BYTES``, UTF-8 text, whose includes and asset files lie inside its own
    folder or one of ``allowed_dirs``. InputError (one line) otherwise. ``missing_ok``: a
    missing file passes (its loader reports it)."""
    path = Path(path)
    what = what or model_format(path)
    if not check_input_file(path, what, missing_ok=missing_ok):
        return
    data = read_input_bytes(path, what)
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise utf8_error(path, what, err) from None
    try:
        root = ET.fromstring(data)
    except ET.ParseError:
        return  # the loaders name the line
    folders = [path.parent.resolve()] + [Path(d).resolve() for d in allowed_dirs]
    if what == "URDF":
        _check_urdf_references(path, root, folders)
    else:
        _check_mjcf_references(path, root, folders)


def _refuse_outside(path: Path, kind: str, given: str, target: Path, folders: list[Path]) -> None:
    resolved = target.resolve()
    if not _inside(resolved, folders):
        shown = "" if Path(given) == resolved else f" ({resolved})"
        allow = " or a folder given with --allow-dir" if len(folders) == 1 else ""
        raise InputError(f"{path}: {kind} {given!r}{shown} is outside the model's folder {_folders_text(folders)}: "
                         f"a model may only read files inside its folder{allow}")


def _check_mjcf_references(path: Path, root: ET.Element, folders: list[Path]) -> None:
    base = path.parent
    elements: list[ET.Element] = []

    def walk(element: ET.Element, source: Path, depth: int) -> None:
        for child in element:
            if child.tag == "include":
                name = child.get("file", "")
                if not name:
                    continue
                target = base / name  # MuJoCo: relative to the main file's folder
                _refuse_outside(path, "<include file>", name, target, folders)
                if depth >= MAX_INCLUDE_DEPTH:
                    raise InputError(f"{path}: <include> nested more than {MAX_INCLUDE_DEPTH} deep (at {name!r})")
                if not check_input_file(target, "included MJCF", missing_ok=True):
                    continue  # MuJoCo names the missing include
                try:
                    included = parse_xml(target, "included MJCF")
                except ET.ParseError:
                    continue  # MuJoCo names the line
                elements.append(included)
                walk(included, target, depth + 1)
            else:
                elements.append(child)
                walk(child, source, depth)

    elements.append(root)
    walk(root, path, 0)
    dirs: dict[str, str] = {}
    for c in (e for e in elements if e.tag == "compiler"):
        for key in ("assetdir", "meshdir", "texturedir"):
            if c.get(key) is not None:
                dirs[key] = c.get(key)
    asset = dirs.get("assetdir", "")
    mesh_dir, texture_dir = dirs.get("meshdir", asset), dirs.get("texturedir", asset)
    for e in elements:
        folder = {"mesh": mesh_dir, "skin": mesh_dir, "hfield": mesh_dir, "texture": texture_dir}.get(e.tag)
        if folder is None and e.tag != "model":
            continue
        for attr, name in e.attrib.items():
            if not attr.startswith("file") or not name:
                continue
            target = base / (folder or "") / name
            _refuse_outside(path, f"<{e.tag} {attr}>", name, target, folders)
            _check_asset(path, e.tag, name, target)


def _check_asset(path: Path, tag: str, name: str, target: Path) -> None:
    """An asset file that exists must be a regular file (a FIFO would block the loader)."""
    try:
        st = os.stat(target)
    except OSError:
        return  # missing: the loader names it
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{path}: <{tag}> file {name!r} is not a regular file but {_kind(st.st_mode)}{_via(target)}: "
                         "only a regular file is read")


def _check_urdf_references(path: Path, root: ET.Element, folders: list[Path]) -> None:
    base = path.parent
    meshdir = next((c.get("meshdir") for m in root.iter("mujoco") for c in m.iter("compiler")
                    if c.get("meshdir") is not None), None)
    meshes = [m.get("filename", "") for m in root.iter("mesh")]
    for name in meshes:
        if not name or ("://" in name and not name.startswith("file://")):
            continue  # package:// and other URIs: not a path (MuJoCo cannot read them)
        plain = name.removeprefix("file://")
        target = base / plain
        _refuse_outside(path, "<mesh filename>", name, target, folders)
        _check_asset(path, "mesh", name, target)
    if meshdir is not None and meshes:
        _refuse_outside(path, "<mujoco><compiler meshdir>", meshdir, base / meshdir, folders)
