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
  *before* it spends minutes computing what it will write; ``check_out_file(path)``, the same
  for a single output file.
* Only regular files are replaced: an existing target that is anything else (a FIFO, a device
  node such as ``/dev/full``, a folder; symlinks resolved) is refused with an ``InputError``
  before anything is written, since the rename would put a regular file in its place (as root,
  ``--out /dev/full`` would otherwise destroy the device node). A report folder (``out_dir``)
  must be a folder where it exists.
* Two ``write_set`` calls on one folder at once (two commands writing the same reports) swap
  their sets one after the other, under an exclusive lock (``fcntl.flock``) on a lock file
  inside the folder, ``.write-set.lock``, removed again by the writer that holds it: the folder
  holds one whole set or the other, never a mix.
* ``sigterm_exits()``: a SIGTERM ends the process through ``SystemExit`` (status 143), so that
  temporary folders are removed on the way out.
* ``default_out_dir(command, full_run)``: where a study writes when the user gives no
  ``--out-dir`` (a subset run never replaces the committed full-run reports).

Every ``OSError`` on the way becomes an ``InputError`` (one line: the path and the system's
reason), which the command-line interface prints on stderr with exit code 2.

Files get the ordinary mode of a new file, ``0o666`` reduced by the process umask (``0o644``
under the usual umask ``022``), like a file made by ``open(path, "w")``; not ``0o600``.
"""

from __future__ import annotations

import errno
import fcntl
import os
import secrets
import shutil
import stat
from contextlib import contextmanager
from pathlib import Path

from harness.model.errors import InputError

#: Prefix of the staging folder ``write_set`` makes inside ``out_dir`` (hidden; removed after).
STAGING_PREFIX = ".write-set-"

#: The lock file ``write_set`` holds (``fcntl.flock``) inside ``out_dir`` while it swaps a set.
LOCK_NAME = ".write-set.lock"

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


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISDIR, "a folder"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def check_out_file(path: Path) -> Path:
    """InputError (``cannot write <path>: it is a character device, not a regular file``) when
    ``path`` exists, symlinks resolved, and is not a regular file: writing it would rename a
    regular file over it. Changes nothing; returns ``path``. Commands call it on their output
    file before they run (``harness simulate --out``); ``write_bytes`` calls it again."""
    path = Path(path)
    try:
        st = os.stat(path)
    except OSError:
        return path  # missing (or unreadable: the write names the reason)
    if not stat.S_ISREG(st.st_mode):
        link = f" (a symlink to {os.path.realpath(path)})" if os.path.islink(path) else ""
        raise InputError(f"cannot write {path}: it is {_kind(st.st_mode)}{link}, not a regular file; "
                         "only a regular file is replaced")
    return path


def write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and ``os.replace``:
    a reader sees the whole old file or the whole new one. Mode ``0o666 & ~umask``. An
    ``OSError`` becomes an ``InputError`` naming the path; the old file is then left as it was.
    An existing ``path`` that is not a regular file is refused (``check_out_file``)."""
    path = Path(path)
    check_out_file(path)
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
    staging folder is removed. Step 3 runs under an exclusive lock of the folder
    (``fcntl.flock`` on ``out_dir/.write-set.lock``, removed after): two writers of one folder
    at once leave one whole set or the other, never a mix. An existing target that is not a
    regular file (a FIFO, a device node, a folder) or a subfolder in the way that is not a
    folder is refused in step 1 (``InputError``), before anything is written.

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
    _check_targets(out_dir, items)
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
        with _folder_lock(out_dir):
            _check_targets(out_dir, items)  # again: another writer may have changed the folder meanwhile
            for rel, _ in items:
                try:
                    (out_dir / rel).parent.mkdir(parents=True, exist_ok=True)
                    os.replace(staging / rel, out_dir / rel)
                except OSError as err:
                    left = [str(out_dir / r) for r, _ in items[len(done):]]
                    raise InputError(f"cannot replace {out_dir / rel}: {err.strerror or err}; {len(done)} of "
                                     f"{len(items)} files replaced, not replaced: {', '.join(left)}") from err
                done.append(out_dir / rel)
        for folder in {(out_dir / rel).parent for rel, _ in items}:
            _fsync_dir(folder)
        return done
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _check_targets(out_dir: Path, items: list[tuple[str, bytes]]) -> None:
    """InputError when a file of the set would replace something that is not a regular file, or
    a folder on its way is not a folder (symlinks resolved); changes nothing."""
    for rel, _ in items:
        path = out_dir
        for part in Path(rel).parts[:-1]:
            path = path / part
            try:
                st = os.stat(path)
            except OSError:
                break  # missing: created in step 3
            if not stat.S_ISDIR(st.st_mode):
                raise InputError(f"cannot write {out_dir / rel}: {path} is {_kind(st.st_mode)}, not a folder")
        else:
            check_out_file(out_dir / rel)


@contextmanager
def _folder_lock(out_dir: Path):
    """Hold an exclusive ``fcntl.flock`` on ``out_dir/.write-set.lock`` (created if missing),
    then remove the file and release it. A writer that was waiting on a lock file its holder
    has just removed finds it gone (or another file in its place) and locks the current one, so
    at most one writer holds the folder's lock at a time and no lock file is left behind."""
    path = out_dir / LOCK_NAME
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o666)
        except OSError as err:
            raise _error(out_dir, err, "write to") from err
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            try:
                current = os.path.samestat(os.fstat(fd), os.stat(path))
            except FileNotFoundError:
                current = False
        except BaseException:
            os.close(fd)
            raise
        if current:
            break
        os.close(fd)
    try:
        yield
    finally:
        _unlink_quietly(path)
        os.close(fd)


#: Exit status of a process ended by SIGTERM through ``sigterm_exits`` (128 + 15, as a shell reports it).
EXIT_SIGTERM = 128 + 15


@contextmanager
def sigterm_exits():
    """Inside it, a SIGTERM to this process raises ``SystemExit(143)`` instead of killing it at
    once, so that the ``with tempfile.TemporaryDirectory()`` blocks it is unwinding (``harness
    zoo``'s log folder, ``harness check``'s copies of a model) remove their folders and the local
    workers are killed and reaped (``harness.validate.local_workers.Workers`` chains its own SIGTERM
    handler to this one) before the process exits with status 143. A second SIGTERM kills at once.

    Installed only in the main thread of a process that is not a ``multiprocessing`` worker (a
    worker dies of the signal, as before) and only where SIGTERM has its default action (a
    handler someone else installed is left alone); the previous action is restored on leaving."""
    import multiprocessing
    import signal
    import threading

    if (threading.current_thread() is not threading.main_thread() or multiprocessing.parent_process() is not None
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL):
        yield
        return

    def terminate(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        raise SystemExit(EXIT_SIGTERM)

    signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        if signal.getsignal(signal.SIGTERM) is terminate:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)


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
