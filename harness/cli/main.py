"""Command-line interface: ``harness scenes | simulate | validate`` (and the commands of
``harness.cli.tools``, ``workprecision``, ``stress``, ``rolling``, ``loops``, ``sweep``).

Exit codes: 0 success (for ``validate``: every check holds), 1 a check fails or a run blows up,
2 bad input or a model that will not load (one line on stderr, no traceback, no report touched).
A run over nothing (no scene under ``--models-dir``, ``--engines`` naming none, a validation in
which no check ran) is bad input, never a pass. Numbers that overflow, memory that runs out and
files that are not UTF-8 also end as one line and exit 2 (``main``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.cli import benchmarks as cli_benchmarks
from harness.cli import loops as cli_loops
from harness.cli import rolling as cli_rolling
from harness.cli import stress as cli_stress
from harness.cli import sweep as cli_sweep
from harness.cli import tools as cli_tools
from harness.cli import workprecision as cli_workprecision
from harness.engines import REFERENCE_ENGINE, display, preload
from harness.io.progress import set_quiet
from harness.io.provenance import set_argv
from harness.model.errors import InputError
from harness.cli.arg_types import (COMPILED_HELP, ENGINES_HELP, MODELS_DIR_HELP, add_dask, add_engines, add_per_state, add_out_dir, check_samples, check_selection,
                                   connect_dask, csv_list as _csv_list,
                                   float_arg as _float, int_arg as _int, models_dir_arg as _models_dir,
                                   out_dir, out_file_arg, require_scene_files_utf8)

EXIT_OK, EXIT_FAIL, EXIT_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(message)


#: ``validate`` options that make a run partial (its reports then go to reports/partial/validate)
VALIDATE_SUBSET = ("scenes", "engines", "set", "requirements", "models_dir", "per_state")

def _overrides(items: list[str] | None) -> dict[str, str]:
    from harness.model.scene import parse_sets

    return parse_sets(items)  # a key set twice: InputError


def _version() -> str:
    """The installed package's version (``importlib.metadata``)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("harness")
    except PackageNotFoundError:  # pragma: no cover - run from a source tree that is not installed
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="harness", description=f"Cross-check rigid-body dynamics on the engines {ENGINES_HELP}. "
                "Exit codes: 0 success, 1 a check fails, 2 bad input (one line on stderr).")
    p.add_argument("--version", action="version", version=f"harness {_version()}",
                   help="print the installed version of harness and exit")
    # no command: main prints this help (the command list) on stderr and returns 2
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=False, parser_class=_Parser)

    sub.add_parser("scenes", help="list the scenes with their parameters (name = value unit -- meaning)",
                   description="List the scenes of the project's models/ with their parameters.")

    s = sub.add_parser("simulate", help="run one scene on one engine, write the common trajectory as CSV",
                       description="Run one scene on one engine and write its trajectory in maximal coordinates "
                                   "as CSV (columns: README). Exit 0 when the run ends ok, 1 when it fails or "
                                   "blows up (non-finite values), 2 on bad input.")
    s.add_argument("scene", help="scene name: a folder of --models-dir (list them with `harness scenes`)")
    s.add_argument("--engine", required=True, metavar="ENGINE", help=f"engine to run: one of {ENGINES_HELP}")
    s.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene parameter, in its unit (`harness scenes`); a vector as a,b,c (repeatable)")
    s.add_argument("--t-end", type=_float, metavar="S", help="horizon (s, > 0; default: the scene's [simulation] t_end)")
    s.add_argument("--dt", type=_float, metavar="S",
                   help="step (s, > 0; the first-step hint of adaptive integrators; default: the scene's)")
    s.add_argument("--integrator", metavar="NAME",
                   help="one of the engine's integrators, as the engine spells it (default: the scene's "
                        "[integrators] entry; an unknown name lists them)")
    s.add_argument("--save-every", type=_float, metavar="S",
                   help="interval between saved samples (s; a whole multiple of dt dividing the horizon; "
                        "default: the scene's)")
    from harness.engines.base import ERROR_CONTROL_ATOL, ERROR_CONTROL_TOL  # validate's too: one set of defaults

    s.add_argument("--rtol", type=_float, default=ERROR_CONTROL_TOL, metavar="X",
                   help=f"relative tolerance (target accuracy) of adaptive integrators (> 0, default "
                        f"{ERROR_CONTROL_TOL:g}, as validate runs them; fixed-step ones ignore it)")
    s.add_argument("--atol", type=_float, default=ERROR_CONTROL_ATOL, metavar="X",
                   help=f"absolute tolerance of adaptive integrators (>= 0, SI units of the state, default "
                        f"{ERROR_CONTROL_ATOL:g}, as validate runs them)")
    s.add_argument("--out", required=True, type=out_file_arg, metavar="FILE.csv",
                   help="CSV file to write (replaced atomically; an existing target must be a regular file)")
    s.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    s.add_argument("--fast", action="store_true",
                   help=f"{COMPILED_HELP} engine: run the compiled twin of the integrator (rk4 -> rk4_compiled, rkmk4 -> "
                        "rkmk4_compiled, DOP853 -> dop853_compiled) where the compiled form models the scene")

    v = sub.add_parser("validate", help="run every scene on every engine, check, write reports/",
                       description=f"Run every selected scene on every selected engine (and the {display(REFERENCE_ENGINE)} reference), "
                                   "judge each check of each run by how its error converges (a coarser step, or a looser "
                                   "tolerance: order, floor, class) against the scene's requirements and declared model "
                                   "differences, write "
                                   "validation.{md,csv,json,junit.xml}. Exit 0 when every check holds, 1 when one "
                                   "fails, 2 on bad input (nothing written).")
    v.add_argument("--scenes", type=_csv_list, metavar="A,B",
                   help="comma-separated scene names (default: every scene of --models-dir)")
    add_engines(v)
    v.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a parameter, in its unit, in every selected scene that has it (repeatable)")
    add_out_dir(v, "validate", "the validation reports", VALIDATE_SUBSET)
    v.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    v.add_argument("--requirements", "--tolerances", dest="requirements", type=Path, metavar="FILE.toml",
                   help="TOML file of [<scene>] tables, check = bound: the accuracy every engine must reach at "
                        "the scene's step, in the check's unit, on top of the judging by convergence "
                        "(harness.judging.requirements); a change to a scene's own requirement is warned about")
    v.add_argument("--jobs", type=_int, default=0, metavar="N", help="worker processes (>= 0; default 0: all cores)")
    v.add_argument("--timeout", type=_float, default=300.0, metavar="S",
                   help="seconds allowed per scene x engine case (> 0, default 300; a scene's own [simulation] timeout where "
                        "larger)")
    add_dask(v)
    add_per_state(v)
    v.add_argument("--quiet", action="store_true",
                   help="no progress bar and no compile notice on stderr (the results and errors still print); "
                        "the bar is drawn only when stderr is a terminal")
    cli_tools.add_parsers(sub)  # inspect, debug, check
    cli_workprecision.add_parser(sub)
    cli_stress.add_parser(sub)
    cli_rolling.add_parser(sub)
    cli_loops.add_parser(sub)
    cli_sweep.add_parser(sub)
    cli_benchmarks.add_parser(sub)
    return p


def cmd_scenes(args) -> int:
    from harness.model.scene import available_scenes, load_scene

    for name in available_scenes():
        scene = load_scene(name)
        print(f"{name}: {scene.title} [{'; '.join(scene.textbook)}]")
        for p in scene.parameters.values():
            value = ",".join(f"{x:g}" for x in p.value) if isinstance(p.value, tuple) else f"{p.value:g}"
            print(f"  {p.name} = {value} {p.unit}  -- {p.doc}")
    return EXIT_OK


def cmd_simulate(args) -> int:
    import numpy as np

    from harness.io import atomic
    from harness.engines import check_scene, declaration, get_engine
    from harness.model.scene import check_steps, load_scene
    from harness.io.trajectory_csv import to_frame

    scene = check_scene(load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir))
    engine = get_engine(args.engine)
    if args.engine in scene.not_run:
        raise InputError(f"{args.engine} does not run {scene.name}: {scene.not_run[args.engine]}")
    if args.engine not in scene.integrators:
        raise InputError(f"scene {scene.name!r} has no default integrator for {args.engine}")
    settings = simulate_settings(args, scene)
    require_scene_files_utf8(scene)
    model = scene.multibody()
    check_samples(settings.t_end, settings.save_every, len(model.bodies))
    check_steps(settings.t_end, settings.dt, "--t-end and --dt")  # before any run (MAX_STEPS)
    if args.fast:
        if not declaration(args.engine).compiled:
            raise InputError(f"--fast selects the {COMPILED_HELP} engine's compiled methods; {args.engine} has none")
        from dataclasses import replace

        from harness.engines import fast_method

        settings = replace(settings, integrator=fast_method(args.engine, settings.integrator, model))
    traj = engine.simulate(scene, settings)
    if traj.unsupported:  # the engine/integrator does not model this scene: bad input, nothing written
        raise InputError(f"{args.engine} cannot run {scene.name} with {settings.integrator}: {traj.message}")
    with np.errstate(over="ignore", invalid="ignore"):  # a blow-up is reported below, not warned about
        frame = to_frame(traj, model)
    status, message = traj.status, traj.message
    frame, blowup = finite_rows(frame)  # an engine may miss a blow-up of the state or of the invariants
    if blowup:
        status, message = ("blowup", blowup) if traj.ok else (status, f"{message}; {blowup}" if message else blowup)
    atomic.write_text(args.out, frame.to_csv(index=False))
    print(f"{args.out}: {len(frame)} samples, {traj.engine}/{traj.integrator}, status {status}"
          + (f" ({message})" if message else ""))
    return EXIT_OK if status == "ok" else EXIT_FAIL


def simulate_settings(args, scene):
    """The ``RunSettings`` of ``harness simulate``: each option given, else the scene's horizon,
    step (s), save interval (s) and default integrator for ``args.engine``, and the tolerances
    validate runs at (``harness.engines.base.ERROR_CONTROL_TOL``, ``ERROR_CONTROL_ATOL``: the
    options' defaults). InputError for a non-positive ``--rtol`` or a negative ``--atol``."""
    from harness.engines.base import RunSettings

    if not args.rtol > 0:
        raise InputError(f"--rtol must be positive, got {args.rtol:g}")
    if not args.atol >= 0:
        raise InputError(f"--atol must be >= 0, got {args.atol:g}")
    return RunSettings(
        t_end=args.t_end if args.t_end is not None else scene.t_end,
        dt=args.dt if args.dt is not None else scene.dt,
        save_every=args.save_every if args.save_every is not None else scene.save_every,
        integrator=args.integrator or scene.integrators[args.engine],
        rtol=args.rtol,
        atol=args.atol,
    )


def finite_rows(frame):
    """``(frame, "")`` when every value is finite; else the rows before the first non-finite
    value and a message naming its columns and time (s). A state or an invariant (energy,
    momentum) that overflowed is a blow-up of the run, never an ok sample."""
    import numpy as np

    values = frame.to_numpy(dtype=float)
    bad = ~np.isfinite(values)
    if not bad.any():
        return frame, ""
    first = int(np.argmax(bad.any(axis=1)))
    cols = [c for c, b in zip(frame.columns, bad[first]) if b]
    more = f" and {len(cols) - 3} more" if len(cols) > 3 else ""
    t = frame["t"].iloc[first] if "t" in frame.columns else float("nan")
    return frame.iloc[:first], f"non-finite {', '.join(cols[:3])}{more} at t = {t:g} s"


def preflight(scene) -> None:
    """Reject non-physical parameters and models that do not load, before any run.

    A scene that names one model file only (an MJCF or a URDF) is read by every engine from that
    file. An engine that reads it in the format it does not usually read
    (``harness.engines.reads_other_format``: a loader of MJCF given a URDF, or the reverse) and
    cannot load it is marked not run with its loader's reason (``Scene.mark_not_run``: validate
    lists it as "not run"); a file read in the engine's own format must load (InputError
    otherwise; loaded here where the engine declares ``preflight``, else by its runs)."""
    from harness.engines import LOADERS, declaration, load_model_file, model_file, reads_other_format

    require_scene_files_utf8(scene)
    model = scene.multibody()
    for engine in LOADERS:
        if engine in scene.not_run:
            continue
        if not reads_other_format(scene, engine):
            if declaration(engine).preflight:
                load_model_file(scene, engine, model)
            continue
        try:
            load_model_file(scene, engine, model)
        except (InputError, NotImplementedError) as err:
            path = model_file(scene, engine)
            scene.mark_not_run(engine, f"cannot read the scene's only model file, {path.name}: {_one_line(err)}")


def cmd_validate(args) -> int:
    import time

    start = time.perf_counter()
    from harness.engines import ENGINE_NAMES, check_scene, declaration, get_engine, prepare, provenance
    from harness.validate.report import label as check_label, write_reports
    from harness.model.scene import MODELS_DIR, available_scenes, load_scene
    from harness.judging.requirements import apply_requirements, check_scenes_known, read_requirements
    from harness.validate.run import validate
    from harness.io.progress import make_bar

    names = check_selection("--scenes", args.scenes, available_scenes(args.models_dir),
                            f"under {args.models_dir or MODELS_DIR} (a scene is a folder with a scene.toml)")
    engines = check_selection("--engines", args.engines, list(ENGINE_NAMES))
    for e in engines:
        get_engine(e)
    if args.jobs < 0:
        raise InputError(f"--jobs must be >= 0, got {args.jobs!r}")
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    overrides = _overrides(args.set)
    scenes = []
    for name in names:
        scene = check_scene(load_scene(name, models_dir=args.models_dir))
        if not scene.checks:
            raise InputError(f"{scene.directory / 'scene.toml'}: declares no [checks.<name>] table: "
                             "its validation would judge nothing")
        own = {k: v for k, v in overrides.items() if k in scene.parameters}
        scenes.append(scene.with_params(**own))
    unused = set(overrides) - {k for s in scenes for k in s.parameters}
    if unused:
        raise InputError(f"unknown parameter {sorted(unused)[0]!r} for the selected scenes")
    changes = {}
    if args.requirements is not None:
        table = read_requirements(args.requirements)
        check_scenes_known(table, available_scenes(args.models_dir), args.requirements)
        for i, scene in enumerate(scenes):
            scenes[i], changes[scene.name] = apply_requirements(scene, table, args.requirements)
            for change in changes[scene.name]:
                if "tightens" in change or "loosens" in change:
                    print(f"warning: {scene.name}: {args.requirements} {change}", file=sys.stderr)
    connect_dask(args)  # an unreachable scheduler: one line, exit 2, nothing written
    folder = out_dir(args, "validate", VALIDATE_SUBSET)
    for scene in scenes:
        preflight(scene)
    for engine in engines:  # compiled defaults: their compilation announced once, here, not per worker
        if declaration(engine).compiled:
            from harness.validate.run import default_settings, reference_settings

            runs = [(m.integrator, s.multibody()) for s in scenes
                    for m in ((default_settings(s, engine, not args.per_state),) if engine not in s.not_run else ())
                    + ((reference_settings(s, not args.per_state),) if engine == REFERENCE_ENGINE else ())]
            prepare(engine, runs)  # here, once: the forked workers inherit the kernels
    if not args.dask:
        preload(engines)  # the engines' own lazy imports, once for the forked workers
    cases = sum(1 + sum(e not in s.not_run for e in engines) for s in scenes)  # a reference run per scene
    with make_bar(cases, desc="validate", unit="case", quiet=args.quiet) as bar:
        results = validate(scenes, engines, jobs=args.jobs or None, timeout=args.timeout, tolerance_changes=changes,
                           progress=bar, dask=args.dask, fast=not args.per_state)
    # the model-file checks run before any engine: a scene whose runs gave no check judged nothing
    empty = [r.scene for r in results if not any(not c.check.startswith("model.") for c in r.checks)]
    if not results or empty:
        raise InputError(f"no check ran for {', '.join(empty) or 'any scene'}: a validation that judges nothing "
                         "is not a pass (nothing written)")
    for result in results:
        bad = sum(not c.passed for c in result.checks)
        print(f"{result.scene}: {'PASS' if result.passed else 'FAIL'} ({len(result.checks) - bad}/{len(result.checks)} checks hold)")
        for c in result.checks:
            if not c.passed:  # "FAIL mujoco exact: defect, 2.100e-02 rad: order 0.31 where the method's is 4"
                value = f"{c.value:.3e} {c.unit}".strip() if c.value == c.value else "no value"
                print(f"  FAIL {c.engine} {c.check}: {check_label(c)}, {value}: {c.judged or c.detail}")
    prov = provenance() | {"wall_s": f"{time.perf_counter() - start:.0f}"}  # the whole command, model checks included
    paths = write_reports(results, prov, folder)
    print("wrote " + ", ".join(str(p) for p in paths))
    return EXIT_OK if all(r.passed for r in results) else EXIT_FAIL


COMMANDS = {"scenes": cmd_scenes, "simulate": cmd_simulate, "validate": cmd_validate}
COMMANDS.update(cli_tools.COMMANDS)
COMMANDS["workprecision"] = cli_workprecision.run
COMMANDS["stress"] = cli_stress.run
COMMANDS["rolling-study"] = cli_rolling.run
COMMANDS["loop-study"] = cli_loops.run
COMMANDS["sweep"] = cli_sweep.run
COMMANDS["benchmark"] = cli_benchmarks.run


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns its exit code. Bad input (``InputError``) and the failures that
    only bad input causes here (a number that overflows, memory that runs out, a file that is
    not UTF-8) print one line ``harness: error: ...`` on stderr and return 2; every report is
    written atomically at the end of a command, so none is half written."""
    args = None
    try:
        set_argv(sys.argv[1:] if argv is None else argv)
        parser = build_parser()
        args = parser.parse_args(argv)
        if args.command is None:  # `harness` alone: the command list, as a usage error
            parser.print_help(sys.stderr)
            return EXIT_INPUT
        set_quiet(getattr(args, "quiet", False))
        return COMMANDS[args.command](args)
    except InputError as err:
        return _error(str(err))
    except (OverflowError, FloatingPointError) as err:
        given = getattr(args, "set", None)
        return _error(f"a value overflows ({type(err).__name__}: {_one_line(err)}): "
                      "a parameter or option is too large for the computation"
                      + (f" (--set {', '.join(given)})" if given else ""))
    except MemoryError as err:
        return _error(f"out of memory{' (' + _one_line(err) + ')' if str(err) else ''}: "
                      "the run is too large (horizon, save interval, parameters)")
    except UnicodeDecodeError as err:
        return _error(f"a file is not UTF-8 text: {_one_line(err)}")
    except KeyboardInterrupt:
        print("harness: interrupted", file=sys.stderr)
        return 130
    finally:
        set_argv(None)
        set_quiet(False)


def _error(message: str) -> int:
    print(f"harness: error: {_one_line(message)}", file=sys.stderr)
    return EXIT_INPUT


def _one_line(text) -> str:
    return " ".join(str(text).split())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
