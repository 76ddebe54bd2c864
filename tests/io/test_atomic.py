"""Atomic writes and report sets: all old or all new, one-line errors, ordinary file modes."""

import errno
import os
import stat
from pathlib import Path

import pytest

from harness.io import atomic
from harness.model.errors import InputError

OLD = {"report.md": "old md\n", "report.csv": "a,b\n1,2\n", "report.json": "{}\n", "plots/one.png": b"\x89PNG old"}
NEW = {"report.md": "new md\n", "report.csv": "a,b\n3,4\n", "report.json": '{"new": 1}\n', "plots/one.png": b"\x89PNG new"}


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones included) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _as_bytes(files):
    return {k: v.encode() if isinstance(v, str) else v for k, v in files.items()}


def test_write_set_replaces_the_whole_set(tmp_path):
    out = tmp_path / "reports"
    paths = atomic.write_set(out, OLD)
    assert paths == [out / k for k in OLD]
    assert _snapshot(out) == _as_bytes(OLD)
    atomic.write_set(out, NEW)
    assert _snapshot(out) == _as_bytes(NEW)  # nothing else left behind: no staging folder, no temp file


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_modes_follow_the_umask(tmp_path, mask, mode):
    old = os.umask(mask)
    try:
        paths = atomic.write_set(tmp_path / "set", OLD)
        atomic.write_text(tmp_path / "one.txt", "x")
        atomic.write_bytes(tmp_path / "two.bin", b"y")
    finally:
        os.umask(old)
    for p in paths + [tmp_path / "one.txt", tmp_path / "two.bin"]:
        assert stat.S_IMODE(p.stat().st_mode) == mode, p


def test_enospc_on_the_third_file_keeps_every_old_file(tmp_path, monkeypatch):
    out = tmp_path / "reports"
    atomic.write_set(out, OLD)
    before = _snapshot(out)
    real_open, real_write = os.open, os.write
    staged: list[int] = []  # fds of files created in the staging folder, in order

    def fake_open(path, flags, *args, **kwargs):
        fd = real_open(path, flags, *args, **kwargs)
        if flags & os.O_CREAT and atomic.STAGING_PREFIX in str(path) and "probe" not in str(path):
            staged.append(fd)
        return fd

    def fake_write(fd, data):
        if len(staged) >= 3 and fd == staged[2]:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(fd, data)

    monkeypatch.setattr(atomic.os, "open", fake_open)
    monkeypatch.setattr(atomic.os, "write", fake_write)
    with pytest.raises(InputError) as err:
        atomic.write_set(out, NEW)
    monkeypatch.undo()
    assert len(staged) == 3  # it stopped at the third file
    msg = str(err.value)
    assert "\n" not in msg and "No space left on device" in msg and str(out / "report.json") in msg
    assert _snapshot(out) == before  # every old file intact, no temp file or staging folder left


def test_simulated_read_only_file_system_changes_nothing(tmp_path, monkeypatch):
    out = tmp_path / "reports"
    atomic.write_set(out, OLD)
    before = _snapshot(out)
    real_open = os.open

    def read_only(path, flags, *args, **kwargs):
        if flags & os.O_CREAT and str(path).startswith(str(out)):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(atomic.os, "open", read_only)
    for call in (lambda: atomic.check_writable(out), lambda: atomic.write_set(out, NEW),
                 lambda: atomic.write_text(out / "report.md", "new")):
        with pytest.raises(InputError, match=r"^cannot write (to )?.*: Read-only file system$"):
            call()
    monkeypatch.undo()
    assert _snapshot(out) == before


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_read_only_folder_is_an_input_error(tmp_path):
    out = tmp_path / "reports"
    atomic.write_set(out, OLD)
    before = _snapshot(out)
    out.chmod(0o555)
    try:
        with pytest.raises(InputError, match="Permission denied"):
            atomic.write_set(out, NEW)
    finally:
        out.chmod(0o755)
    assert _snapshot(out) == before


def test_a_file_in_the_way_is_an_input_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(InputError, match="not a folder"):
        atomic.check_writable(blocker)
    with pytest.raises(InputError, match="file is not a folder"):
        atomic.write_set(blocker / "reports", NEW)
    assert blocker.read_text() == "not a folder"


def test_a_failed_rename_names_the_files_left_old(tmp_path, monkeypatch):
    out = tmp_path / "reports"
    atomic.write_set(out, OLD)
    real_replace = os.replace
    calls = []

    def fail_second(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real_replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", fail_second)
    with pytest.raises(InputError, match=r"1 of 4 files replaced") as err:
        atomic.write_set(out, NEW)
    monkeypatch.undo()
    assert str(out / "report.csv") in str(err.value)
    # the first file is new, the rest old, and no staging folder is left
    assert _snapshot(out) == {**_as_bytes(OLD), "report.md": b"new md\n"}


def test_write_bytes_failure_keeps_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "a.md"
    atomic.write_text(path, "old")

    def full(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(atomic.os, "write", full)
    with pytest.raises(InputError, match=r"^cannot write .*a\.md: No space left on device$"):
        atomic.write_text(path, "new")
    monkeypatch.undo()
    assert _snapshot(tmp_path) == {"a.md": b"old"}


def test_check_writable_creates_nothing(tmp_path):
    target = tmp_path / "a" / "b"
    assert atomic.check_writable(target) == target
    assert list(tmp_path.iterdir()) == []


def test_paths_outside_the_folder_are_refused(tmp_path):
    for bad in ("../x.md", "/etc/x.md", ""):
        with pytest.raises(ValueError):
            atomic.write_set(tmp_path, {bad: "x"})
    assert list(tmp_path.iterdir()) == []


def test_default_out_dir_keeps_subset_runs_apart():
    assert atomic.default_out_dir("stress", full_run=True) == Path("reports")
    assert atomic.default_out_dir("stress", full_run=False) == Path("reports/partial/stress")
    assert atomic.default_out_dir("workprecision", full_run=False) == Path("reports/partial/workprecision")
    with pytest.raises(ValueError):
        atomic.default_out_dir("../x", full_run=False)


# ----------------------------------------------------------------------------- issue #29: targets and races


def test_a_target_that_is_not_a_regular_file_is_refused_before_anything_is_written(tmp_path):
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    link = tmp_path / "link.csv"
    link.symlink_to(fifo)
    for target in (fifo, link):
        with pytest.raises(InputError, match=r"^cannot write .*: it is a FIFO \(named pipe\).*not a regular file"):
            atomic.check_out_file(target)
        with pytest.raises(InputError, match="not a regular file"):
            atomic.write_text(target, "new")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and link.is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.csv", "out.csv"]  # no temporary file left
    atomic.check_out_file(tmp_path / "missing.csv")  # a new file is fine


def test_write_set_refuses_a_fifo_among_its_targets_and_changes_nothing(tmp_path):
    out = tmp_path / "reports"
    atomic.write_set(out, OLD)
    (out / "report.csv").unlink()
    os.mkfifo(out / "report.csv")
    with pytest.raises(InputError, match=r"report\.csv: it is a FIFO"):
        atomic.write_set(out, NEW)
    assert stat.S_ISFIFO(os.stat(out / "report.csv").st_mode)
    assert (out / "report.md").read_text() == "old md\n"  # nothing replaced
    (out / "report.csv").unlink()
    os.rename(out / "plots", tmp_path / "plots")
    os.mkfifo(out / "plots")  # a subfolder of the set in the way
    with pytest.raises(InputError, match=r"plots is a FIFO \(named pipe\), not a folder"):
        atomic.write_set(out, NEW)
    assert sorted(p.name for p in out.iterdir()) == ["plots", "report.json", "report.md"]  # no staging, no lock left


def test_an_out_dir_that_is_a_fifo_is_refused(tmp_path):
    os.mkfifo(tmp_path / "reports")
    with pytest.raises(InputError, match="not a folder"):
        atomic.write_set(tmp_path / "reports", NEW)
    assert stat.S_ISFIFO(os.stat(tmp_path / "reports").st_mode)


def test_two_writers_of_one_folder_at_once_leave_one_whole_set(tmp_path):
    """A forced race: two threads write distinct sets into one folder at the same moment, 30 times;
    every time the folder holds one writer's whole set (without the lock, about a third mix)."""
    import threading

    sets = [{**{f"f{i:02d}.txt": f"{w} {i}\n" for i in range(16)}, "sub/x.txt": f"{w}\n"} for w in "AB"]
    out = tmp_path / "reports"
    wholes = [_as_bytes(s) for s in sets]
    errors = []
    for _ in range(30):
        barrier = threading.Barrier(2)

        def writer(files):
            barrier.wait()
            try:
                atomic.write_set(out, files)
            except BaseException as err:  # pragma: no cover - reported below
                errors.append(err)

        threads = [threading.Thread(target=writer, args=(s,)) for s in sets]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert not errors
        assert _snapshot(out) in wholes  # no lock file or staging folder left either
