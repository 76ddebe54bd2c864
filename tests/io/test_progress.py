"""The shared progress bar (harness.io.progress): drawn only on a terminal and never with
--quiet; it counts the cases of a validate run; the compile notice of the in-house kernels."""

import io

import pytest

from harness.cli.main import main
from harness.io import progress


class _Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.fixture(autouse=True)
def _not_quiet():
    progress.set_quiet(False)
    yield
    progress.set_quiet(False)


def test_no_bar_when_the_stream_is_not_a_terminal():
    stream = io.StringIO()
    bar = progress.make_bar(3, stream=stream)
    with bar:
        bar.update(2)
        bar.update(1)
    assert isinstance(bar, progress.NoBar) and bar.n == 3
    assert stream.getvalue() == ""


def test_a_bar_on_a_terminal_counts_and_draws():
    stream = _Terminal()
    with progress.make_bar(3, desc="demo", stream=stream) as bar:
        bar.update(3)
    assert not isinstance(bar, progress.NoBar) and bar.n == 3
    assert "demo" in stream.getvalue() and "3/3" in stream.getvalue()


def test_no_bar_with_quiet_even_on_a_terminal():
    stream = _Terminal()
    assert isinstance(progress.make_bar(3, quiet=True, stream=stream), progress.NoBar)
    progress.set_quiet(True)
    assert isinstance(progress.make_bar(3, stream=stream), progress.NoBar)
    progress.note("a note", stream=stream)
    assert stream.getvalue() == ""


def test_a_note_is_one_line():
    stream = io.StringIO()
    progress.note("compiling", stream=stream)
    assert stream.getvalue() == "compiling\n"


def _record_bars(monkeypatch):
    made = []
    original = progress.make_bar

    def recording(*args, **kwargs):
        made.append(original(*args, **kwargs))
        return made[-1]

    monkeypatch.setattr(progress, "make_bar", recording)
    return made


@pytest.mark.parametrize("quiet", [False, True])
def test_the_validate_bar_counts_its_cases(tmp_path, capsys, monkeypatch, quiet):
    monkeypatch.setattr(progress, "_is_terminal", lambda stream: True)
    made = _record_bars(monkeypatch)
    args = ["validate", "--scenes", "torque_free", "--engines", "mujoco,pinocchio", "--jobs", "1",
            "--out-dir", str(tmp_path)] + (["--quiet"] if quiet else [])
    assert main(args) in (0, 1)
    err = capsys.readouterr().err
    (bar,) = made
    assert bar.total == 3 and bar.n == 3  # the reference run, then one run per engine
    assert isinstance(bar, progress.NoBar) == quiet
    assert ("3/3" in err) != quiet


def test_validate_draws_no_bar_when_stderr_is_not_a_terminal(tmp_path, capsys, monkeypatch):
    made = _record_bars(monkeypatch)
    assert main(["validate", "--scenes", "torque_free", "--engines", "mujoco", "--jobs", "1",
                 "--out-dir", str(tmp_path)]) in (0, 1)
    err = capsys.readouterr().err
    assert isinstance(made[0], progress.NoBar) and made[0].n == 2
    assert "2/2" not in err and "validate" not in err


def test_the_kernel_compilation_is_announced_once(monkeypatch, capsys):
    np = pytest.importorskip("numpy")
    from harness.engines.inhouse.compiled import solver
    from harness.engines.inhouse.model import build, initial_state
    from harness.model.scene import load_scene

    scene = load_scene("torque_free")
    nem = build(scene.multibody())
    packed, y0 = solver.pack(nem), np.asarray(initial_state(scene.multibody(), nem))
    monkeypatch.setattr(solver, "is_cached", lambda kernel: False)  # as in a fresh environment
    monkeypatch.setattr(solver, "_record_time", lambda kernel, seconds: None)  # keep the real record
    for quiet, expected in ((True, 0), (False, 1)):
        monkeypatch.setattr(solver, "_warm", set())
        monkeypatch.setattr(solver, "_announced", False)
        progress.set_quiet(quiet)
        solver.warm_up(packed, y0, "erk")
        solver.warm_up(packed, y0, "dop853")  # a second kernel in the same process: no second line
        err = capsys.readouterr().err
        assert err.count("compiling the in-house kernels (once;") == expected
        assert "then cached)" in err or expected == 0
