"""Argument types shared by the command-line modules: a bad value becomes argparse's one-line
error (``argument --dt: not a number: 'abc'``), which ``harness.cli.main`` turns into exit code 2.
Also the checks several commands make before they run (``check_selection``, ``check_samples``)
and the one rule of where a report set goes (``add_out_dir``, ``out_dir``)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from harness.model.errors import InputError
from harness.engines import COMPILED_ENGINES, ENGINE_NAMES, display

#: The registered engines, for help texts (``harness.engines.ENGINE_NAMES``).
ENGINES_HELP = ", ".join(ENGINE_NAMES)
#: The engines with compiled twins of their methods, as help texts write them (``--fast``,
#: ``--per-state``; ``harness.engines.COMPILED_ENGINES``).
COMPILED_HELP = " and ".join(display(e) for e in COMPILED_ENGINES)

#: Help text of every ``--models-dir`` option.
MODELS_DIR_HELP = "folder of scene folders <scene>/scene.toml (default: the project's models/)"


def float_arg(text: str) -> float:
    """A finite number (``nan``, ``inf`` are refused: no option takes them)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def int_arg(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def seed_arg(text: str) -> int:
    """A seed of NumPy's ``default_rng``: an integer >= 0 (it refuses a negative one)."""
    value = int_arg(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"a seed is an integer >= 0, got {text!r}")
    return value


def csv_list(text: str) -> list[str]:
    """``"a, b,,c"`` -> ``["a", "b", "c"]``."""
    return [s for s in (p.strip() for p in text.split(",")) if s]


def models_dir_arg(text: str) -> Path:
    """An existing folder (a typo'd ``--models-dir`` is an error, not an empty selection)."""
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"no such folder: {text!r}")
    return path


def out_file_arg(text: str) -> Path:
    """An output file (``--out``): a path that does not exist or is a regular file (symlinks
    resolved). Writing replaces it by a rename, which would put a regular file in place of a
    FIFO or a device node (``/dev/full``): such a target is refused here, before anything runs
    (``harness.io.atomic.check_out_file``)."""
    from harness.io.atomic import check_out_file

    try:
        return check_out_file(Path(text))
    except InputError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def out_dir_arg(text: str) -> Path:
    """A report folder (``--out-dir``): a path that does not exist (it is created) or is a folder
    (symlinks resolved); anything else (a file, a FIFO, a device) is refused here, before
    anything runs. Whether it can be written is ``harness.io.atomic.check_writable``'s to say."""
    import os
    import stat

    path = Path(text)
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return path
    if not stat.S_ISDIR(mode):
        raise argparse.ArgumentTypeError(f"cannot write to {text}: it is not a folder")
    return path


def check_selection(option: str, chosen: list[str] | None, default: list[str], where: str = "") -> list[str]:
    """The names an option selects (``default`` when it is not given); InputError when it selects
    nothing (``--engines ,``) or there is nothing to select (no scene under ``--models-dir``): a
    run over nothing would be a vacuous verdict."""
    names = default if chosen is None else chosen
    if not names:
        if chosen is not None:
            raise InputError(f"{option} selects nothing: give comma-separated names")
        raise InputError(f"nothing to run: no {option.removeprefix('--')}{' ' + where if where else ''}")
    return list(dict.fromkeys(names))


def check_samples(t_end: float, save_every: float, bodies: int = 1, options: str = "--t-end and --save-every") -> None:
    """InputError when a run would save more than ``harness.model.scene.MAX_SAMPLES`` samples
    times bodies (``t_end``, ``save_every`` in s): its samples would not fit in memory."""
    from harness.model.scene import MAX_SAMPLES

    if not (t_end > 0 and save_every > 0):
        return  # the engines' own checks name a non-positive horizon or interval
    samples = (t_end / save_every + 1) * max(bodies, 1)
    if samples > MAX_SAMPLES:
        raise InputError(f"{options}: a horizon of {t_end:g} s saved every {save_every:g} s for {bodies} "
                         f"bod{'y' if bodies == 1 else 'ies'} is {samples:.3g} samples, more than the "
                         f"{MAX_SAMPLES:.0e} a run may hold; shorten the horizon or save less often")


def require_utf8(path: Path, what: str) -> None:
    """InputError naming ``path`` when it exists but is not a regular file of at most
    ``harness.model.input_files.MAX_INPUT_BYTES`` (a FIFO, a device, a folder) or not UTF-8 text (an
    XML model file the loaders would fail on with a decoding error); a missing file is the
    loaders' to report. Checked before any loader opens the file."""
    from harness.model.input_files import check_input_file, read_input_text

    if check_input_file(path, what, missing_ok=True):
        read_input_text(path, what)


def require_scene_files_utf8(scene) -> None:
    """``harness.model.input_files.check_model_file`` for the model files a scene names: its MJCF
    and URDF, or the one it has (``Scene.mjcf`` and ``Scene.urdf`` are then the same file):
    regular files of bounded size, UTF-8 text, their includes and assets inside the scene's
    folder. A missing file is the loaders' to report."""
    from harness.model.input_files import check_model_file

    for path in dict.fromkeys((scene.mjcf, scene.urdf)):
        check_model_file(path, missing_ok=True)


def add_engines(parser) -> None:
    """The ``--engines A,B`` option of the commands that run a selection of the registered engines."""
    parser.add_argument("--engines", type=csv_list, metavar="A,B",
                        help=f"comma-separated engines among {ENGINES_HELP} (default: all)")


def add_per_state(parser) -> None:
    """The ``--per-state`` option of the commands that run the in-house engine at the scenes'
    defaults (validate, debug): the readable per-state methods instead of their compiled twins."""
    parser.add_argument("--per-state", action="store_true",
                        help=f"run the {COMPILED_HELP} engine's per-state NumPy methods (the readable oracle: rk4, "
                             "DOP853 for the reference) instead of their compiled twins (rk4_compiled, "
                             "dop853_compiled), which run by default wherever the compiled form models the scene")


def dask_address(text: str) -> str:
    """A Dask scheduler address: ``tcp://host:port`` (``host:port`` means tcp; tls://, ws://...
    as Dask spells them). Whether a scheduler answers there is ``connect_dask``'s to say."""
    address = text.strip()
    rest = address.split("://", 1)[-1]
    host, sep, port = rest.rpartition(":")
    if not (sep and host and port.isdigit()):
        raise argparse.ArgumentTypeError(f"not a scheduler address tcp://HOST:PORT: {text!r}")
    return address if "://" in address else "tcp://" + address


def add_dask(parser) -> None:
    """The ``--dask ADDRESS`` option of the sweeps (validate, stress, workprecision, zoo): run their
    cases on the workers of a ``dask.distributed`` scheduler instead of the local pool."""
    parser.add_argument("--dask", type=dask_address, metavar="ADDRESS",
                        help="run the cases on the workers of the Dask scheduler at ADDRESS (tcp://host:port; "
                             "`dask scheduler`, then `dask worker ADDRESS` in this environment on each machine), "
                             "each in its own process there, with the same results as a local run (as many at "
                             "once as the workers have threads, at most --jobs where the command has it)")


def connect_dask(args) -> None:
    """With ``--dask``: reach its scheduler now, before anything is written (InputError, one line,
    when none answers or it has no worker; ``harness.validate.dask_workers.connect``)."""
    if getattr(args, "dask", None):
        from harness.validate.dask_workers import connect

        connect(args.dask)


def add_out_dir(parser, command: str, what: str, subset: tuple[str, ...]) -> None:
    """Add ``--out-dir`` to a report-writing command: ``what`` its files, ``subset`` the
    options (attribute names, e.g. ``("scenes", "quick")``) that make a run partial."""
    flags = ", ".join("--" + o.replace("_", "-") for o in subset)
    parser.add_argument("--out-dir", type=out_dir_arg, default=None, metavar="DIR",
                        help=f"folder for {what} (default: reports for a full run; reports/partial/{command} "
                             f"for a run with {flags}, so that only a full run refreshes the committed snapshot)")


def out_dir(args, command: str, subset: tuple[str, ...]) -> Path:
    """The folder a command writes its report set to: ``--out-dir`` if given, else ``reports``
    for a full run and ``reports/partial/<command>`` when any option of ``subset`` is set
    (``harness.io.atomic.default_out_dir``); checked writable before the run starts."""
    from harness.io.atomic import check_writable, default_out_dir

    folder = args.out_dir or default_out_dir(command, full_run=not any(getattr(args, o) for o in subset))
    check_writable(folder)
    return folder

