"""Atomic file writes: a reader never sees a half-written report, and a set of reports is
replaced together.

* ``write_text`` / ``write_bytes``: one file, written to a temporary name in the same folder,
  flushed to disk and renamed over the old one (``os.replace``).
* ``write_set(out_dir, files)``: a set of files (a report with its CSV, JSON, figures...). Every
  file is first written into a hidden staging folder inside ``out_dir``; only when all of them
  were written completely are they renamed into place, one ``os.replace`` each, in one quick
  pass. A failure while writing (full disk, read-only or forbidden folder) leaves every old file
  untouched and removes the staging folder.
* ``check_writable(out_dir)``: the same permission and disk check, for a command to call
  *before* it spends minutes computing what it will write.
* ``default_out_dir(command, full_run)``: where a study writes when the user gives no
  ``--out-dir`` (a subset run never replaces the committed full-run reports).

Every ``OSError`` on the way becomes an ``InputError`` (one line: the path and the system's
reason), which the command-line interface prints on stderr with exit code 2.

Files get the ordinary mode of a new file, ``0o666`` reduced by the process umask (``0o644``
under the usual umask ``022``), like a file made by ``open(path, "w")``; not ``0o600``.
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
from pathlib import Path

from harness.model.errors import InputError

#: Prefix of the staging folder ``write_set`` makes inside ``out_dir`` (hidden; removed after).
STAGING_PREFIX = ".write-set-"

#: Where full study runs write their reports by default (relative to the working directory).
REPORTS_DIR = Path("reports")


def _error(path: Path, err: OSError, doing: str) -> InputError:
    reason = err.strerror or errno.errorcode.get(err.errno or 0, "") or str(err)
    return InputError(f"cannot {doing} {path}: {reason}")


def _write_file(path: Path, data: bytes) -> None:
    """Create ``path`` (must not exist) with mode ``0o666 & ~umask`` and write ``data`` to disk."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
    try:
        view = memoryview(data)
        while view:
            n = os.write(fd, view)
            view = view[n:]
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (see ``write_bytes``)."""
    write_bytes(path, text.encode("utf-8"))


def write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and ``os.replace``:
    a reader sees the whole old file or the whole new one. Mode ``0o666 & ~umask``. An
    ``OSError`` becomes an ``InputError`` naming the path; the old file is then left as it was."""
    path = Path(path)
    tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_file(tmp, bytes(data))
        os.replace(tmp, path)
    except OSError as err:
        _unlink_quietly(tmp)
        raise _error(path, err, "write") from err
    except BaseException:
        _unlink_quietly(tmp)
        raise


def _unlink_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


def check_writable(out_dir: Path) -> Path:
    """Make sure reports can be written into ``out_dir`` without changing anything: in
    ``out_dir`` if it exists, else in its nearest existing parent folder (where ``out_dir`` would
    be created), create and delete a small probe file. Returns ``out_dir``; raises
    ``InputError`` (``cannot write to <dir>: <reason>``) for a read-only file system, a
    forbidden folder, a full disk or a file in the way. Commands call this before any long run
    (after checking their other options) so that a bad ``--out-dir`` is reported at once, not
    after the run."""
    out_dir = Path(out_dir)
    existing = out_dir
    while not os.path.lexists(existing) and existing.parent != existing:
        existing = existing.parent
    if not existing.is_dir():
        what = "it is" if existing == out_dir else f"{existing} is"
        raise InputError(f"cannot write to {out_dir}: {what} not a folder")
    probe = existing / f"{STAGING_PREFIX}probe-{secrets.token_hex(4)}.tmp"
    try:
        _write_file(probe, b"probe\n")
    except OSError as err:
        raise _error(out_dir, err, "write to") from err
    finally:
        _unlink_quietly(probe)
    return out_dir


def write_set(out_dir: Path, files: dict[str, bytes | str]) -> list[Path]:
    """Write a set of files into ``out_dir`` so that it is replaced as a whole; returns their
    paths, in the order of ``files``.

    ``files`` maps a path relative to ``out_dir`` (``"stress.md"``, ``"stress/map.png"``;
    forward slashes, no ``..``) to its content: ``str`` is written as UTF-8, ``bytes`` as is.

    Steps: (1) ``check_writable(out_dir)``, then ``out_dir`` is created if missing; (2) every
    file is written completely and flushed to disk inside a fresh hidden staging folder
    ``out_dir/.write-set-<random>/`` (same file system, so the next step is a rename); (3) only
    when all were written, each is moved to its place with ``os.replace`` in one quick pass (no
    data is written in this pass; subfolders such as ``stress/`` are created here); (4) the
    staging folder is removed.

    Failures: an ``OSError`` in steps 1-2 (``ENOSPC``, ``EROFS``, ``EACCES``...) raises
    ``InputError`` naming the file and the system's reason, removes the staging folder and
    leaves every old file untouched. A failure inside step 3 (only possible if the file system
    changes under us, e.g. is remounted read-only) raises ``InputError`` listing the files not
    replaced; the files before it are new and the rest old. If the process is killed during
    step 3 (a few microseconds per file) the same mixed state is left, and the staging folder
    still holds the files not yet moved; if it is killed during step 2 only a stale
    ``.write-set-*`` folder is left and every report is old. Each file on its own is always
    whole, old or new. Files get mode ``0o666 & ~umask``.
    """
    out_dir = Path(out_dir)
    items: list[tuple[str, bytes]] = []
    for rel, content in files.items():
        parts = Path(rel).parts
        if not parts or Path(rel).is_absolute() or ".." in parts:
            raise ValueError(f"write_set: {rel!r} is not a relative path inside the folder")
        items.append((rel, content.encode("utf-8") if isinstance(content, str) else bytes(content)))
    check_writable(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise _error(out_dir, err, "create folder") from err
    staging = out_dir / f"{STAGING_PREFIX}{secrets.token_hex(6)}"
    try:
        try:
            staging.mkdir()
        except OSError as err:
            raise _error(out_dir, err, "write to") from err
        for rel, data in items:
            try:
                (staging / rel).parent.mkdir(parents=True, exist_ok=True)
                _write_file(staging / rel, data)
            except OSError as err:
                raise _error(out_dir / rel, err, "write") from err
        _fsync_dir(staging)
        done: list[Path] = []
        for rel, _ in items:
            try:
                (out_dir / rel).parent.mkdir(parents=True, exist_ok=True)
                os.replace(staging / rel, out_dir / rel)
            except OSError as err:
                left = [str(out_dir / r) for r, _ in items[len(done):]]
                raise InputError(f"cannot replace {out_dir / rel}: {err.strerror or err}; "
                                 f"{len(done)} of {len(items)} files replaced, not replaced: {', '.join(left)}") from err
            done.append(out_dir / rel)
        for folder in {(out_dir / rel).parent for rel, _ in items}:
            _fsync_dir(folder)
        return done
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def default_out_dir(command: str, full_run: bool) -> Path:
    """Where a study command writes when the user gives no ``--out-dir``.

    A full run (no subset of scenes or variants, no ``--quick``) writes to ``reports/`` and
    replaces the committed snapshot there; any subset run writes to ``reports/partial/<command>/``
    so that a smoke or partial run never overwrites the full-run reports. Paths are relative to
    the working directory, like the CLI's old default ``reports``. An explicit ``--out-dir``
    always wins (the CLI uses this only when the option is absent)."""
    if not command or "/" in command or command in (".", ".."):
        raise ValueError(f"default_out_dir: bad command name {command!r}")
    return REPORTS_DIR if full_run else REPORTS_DIR / "partial" / command
