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


def test_no_bar_but_one_line_per_tick_when_the_stream_is_not_a_terminal():
    stream = io.StringIO()
    bar = progress.make_bar(3, desc="demo", stream=stream)
    with bar:
        bar.done("heavy_top mujoco ok 0.8 s")
        bar.set_postfix_str("torque_free: rk4")
        bar.update(2)
        bar.update(0)  # no tick, no line
    assert isinstance(bar, progress.NoBar) and bar.n == 3
    assert stream.getvalue() == "[1/3] heavy_top mujoco ok 0.8 s\n[3/3] torque_free: rk4\n"


def test_no_line_with_quiet_when_the_stream_is_not_a_terminal():
    stream = io.StringIO()
    with progress.make_bar(2, quiet=True, stream=stream) as bar:
        bar.done("a")
    progress.set_quiet(True)
    with progress.make_bar(2, stream=stream) as bar:
        bar.done("b")
        bar.update(1)
    assert stream.getvalue() == ""


def test_a_bar_on_a_terminal_names_the_finished_case():
    stream = _Terminal()
    with progress.make_bar(2, desc="demo", stream=stream) as bar:
        bar.done("heavy_top mujoco ok 0.8 s")
        bar.done("heavy_top inhouse ok 0.2 s")
    assert bar.n == 2 and "2/2" in stream.getvalue() and "heavy_top inhouse ok 0.2 s" in stream.getvalue()
    assert "[1/2]" not in stream.getvalue()  # a bar, not lines


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


def test_validate_prints_one_line_per_case_when_stderr_is_not_a_terminal(tmp_path, capsys, monkeypatch):
    made = _record_bars(monkeypatch)
    assert main(["validate", "--scenes", "torque_free", "--engines", "mujoco", "--jobs", "1",
                 "--out-dir", str(tmp_path)]) in (0, 1)
    err = capsys.readouterr().err
    assert isinstance(made[0], progress.NoBar) and made[0].n == 2
    lines = [line for line in err.splitlines() if line.startswith("[")]
    assert len(lines) == 2 and lines[0].startswith("[1/2] torque_free reference ok ")
    assert lines[1].startswith("[2/2] torque_free mujoco ok ") and lines[1].endswith(" s")


def test_the_kernel_compilation_is_announced_once(monkeypatch, capsys):
    np = pytest.importorskip("numpy")
    from harness.engines.inhouse.compiled import solver
    from harness.engines.inhouse.model import build, initial_state
    from harness.engines import load_scene

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


def _cold_cache(monkeypatch):
    """Numba's cache made to look cold in this process and the workers it forks (nothing is
    recompiled: the kernels still load from the real cache); the real compile-time record kept."""
    from harness.engines.inhouse.compiled import solver

    monkeypatch.setattr(solver, "is_cached", lambda kernel: False)
    monkeypatch.setattr(solver, "_record_time", lambda kernel, seconds: None)
    monkeypatch.setattr(solver, "_warm", set())
    monkeypatch.setattr(solver, "_announced", False)
    progress.set_quiet(False)
    return solver


def _compiled_refuses(monkeypatch):
    """Make the compiled in-house form refuse every model (``pack`` raises NotImplementedError),
    as it refuses one it does not model; it models every scene today."""
    from harness.engines.inhouse.compiled import solver

    def refuse(nem):
        raise NotImplementedError("the compiled in-house solver does not model this scene")

    monkeypatch.setattr(solver, "pack", refuse)


STRESS_COMPILED = """
[defaults]
bisect_iters = 1
search_steps = 1
band = { exact = 1e-4, position = 1e-3, orientation = 1e-3, velocity = 1e-3, angular_velocity = 1e-3, energy = 1e-3 }
max_steps = { inhouse = 10000 }
integrators = { inhouse = ["rk4_compiled", "dop853_compiled"] }

[variants.spin]
scene = "torque_free"
t_end = 0.02
save_every = 1e-3
dt = 1e-3
dt_max = 4e-3
references = []

[variants.disk]
scene = "rolling_disk"
t_end = 0.02
save_every = 1e-3
dt = 1e-3
dt_max = 4e-3
references = []
"""


@pytest.mark.slow  # worker processes
def test_a_cold_compile_is_announced_once_per_stress_run_not_per_worker(monkeypatch, capfd, tmp_path):
    """Every trial of a compiled method runs in its own worker, and each would compile (and
    announce) on a cold cache: the parent announces once before starting them, the workers stay
    silent. Without a compiled method (or only on a scene the compiled form does not model),
    nothing is announced."""
    from harness.studies.stress.run import load_catalogue, run_stress

    _cold_cache(monkeypatch)
    path = tmp_path / "c.toml"
    path.write_text(STRESS_COMPILED)
    cat = load_catalogue(path)
    res = run_stress(cat, list(cat.variants), ["inhouse"], jobs=2, timeout=120)
    assert sum(len(m.trials) for m in res.rows) >= 4  # several workers ran compiled methods
    err = capfd.readouterr().err
    assert err.count("compiling the in-house kernels (once;") == 1, err

    _cold_cache(monkeypatch)
    _compiled_refuses(monkeypatch)  # the compiled form models every scene: made to refuse the disk
    run_stress(cat, [cat.variant("disk")], ["inhouse"], jobs=2, timeout=120)  # unsupported: nothing compiles
    assert "compiling the in-house kernels" not in capfd.readouterr().err


def test_the_parent_announces_a_cold_kernel_once_and_its_workers_inherit_it(monkeypatch, capfd):
    from dataclasses import replace

    import numpy as np

    from harness.engines.inhouse import COMPILED_KERNEL, announce_compilation
    from harness.engines.inhouse.integrators import COMPILED
    from harness.model.multibody import PointForce
    from harness.engines import load_scene

    assert set(COMPILED_KERNEL) == set(COMPILED)
    solver = _cold_cache(monkeypatch)
    top = load_scene("torque_free").multibody()
    # the one model the compiled form refuses: a prescribed force given only as a Python function
    pushed = replace(top, forces=(PointForce("body", np.zeros(3), lambda t: np.ones(3)),))
    assert not announce_compilation([("rk4", top), ("DOP853", top)])  # no compiled method: Numba not needed
    assert not announce_compilation([("rk4_compiled", pushed)])  # the compiled form does not model it
    assert "compiling" not in capfd.readouterr().err and not solver._announced
    assert announce_compilation([("rk4_compiled", top), ("dop853_compiled", top)])
    assert announce_compilation([("rk4_compiled", top)])  # still cold, but said already
    assert capfd.readouterr().err.count("compiling the in-house kernels (once;") == 1 and solver._announced
