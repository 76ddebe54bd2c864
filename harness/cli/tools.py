"""Model-debugging commands of the CLI: ``harness inspect | debug | check | zoo``.

``add_parsers(sub)`` adds their subparsers to ``harness.cli.main``'s subparsers object (whose
``parser_class`` turns argparse errors into ``InputError``); ``COMMANDS`` maps each name to its
handler, which takes the parsed arguments and returns the exit code: 0 agreement, 1 a
disagreement beyond tolerance, 2 bad input (raised as ``InputError``; the CLI prints one line).
Heavy modules are imported inside the handlers, as in ``harness.cli.main``.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import sys
import warnings
from pathlib import Path
from harness.cli.arg_types import (ENGINES_HELP, MODELS_DIR_HELP, add_dask, add_per_state, check_samples, connect_dask, csv_list as _csv_list, float_arg as _float,
                                   int_arg as _int, models_dir_arg as _models_dir, require_scene_files_utf8, seed_arg as _seed,
                                   require_utf8)
from harness.cli.arg_types import out_dir_arg as _out_dir
from harness.model.errors import InputError

EXIT_OK, EXIT_FAIL = 0, 1


def _overrides(items: list[str] | None) -> dict[str, str]:
    from harness.model.scene import parse_sets

    return parse_sets(items)  # a key set twice: InputError


def add_parsers(sub) -> None:
    """Add the ``inspect``, ``debug``, ``check`` and ``zoo`` subparsers."""
    i = sub.add_parser("inspect", help="what each engine holds after loading a scene; dynamics at random states",
                       description="Load a scene into every engine and show what each holds against the scene "
                                   "description; compare the dynamics terms at random states. Exit 0 when all "
                                   "agree, 1 on a disagreement, 2 on bad input.")
    i.add_argument("scene", help="scene name: a folder of --models-dir (list them with `harness scenes`)")
    i.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene parameter, in its unit (`harness scenes`); a vector as a,b,c (repeatable)")
    i.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    i.add_argument("--states", type=_int, default=4, metavar="N", help="random states for the dynamics check (>= 1, default 4)")
    i.add_argument("--seed", type=_seed, default=0, metavar="N", help="seed of the random states (an integer >= 0, default 0)")

    d = sub.add_parser("debug", help="where two engines' runs of a scene part, per quantity, and how each engine's "
                                     "error converges; plot of the differences",
                       description="Run a scene on two engines as validate does (with the in-house reference, each "
                                   "engine's checks judged by how their error converges) and show, per quantity "
                                   "(position, orientation, velocity, angular velocity, energy), each engine's error "
                                   "model (class, order, floor, resolution, verdict) and the first time the two runs' "
                                   "difference exceeds 10x its resolution (or the scene's requirement); write "
                                   "debug_<scene>_<A>_<B>.png. Exit 0 when every quantity's checks pass, 1 otherwise, "
                                   "2 on bad input.")
    d.add_argument("scene", help="scene name: a folder of --models-dir (list them with `harness scenes`)")
    d.add_argument("--engines", type=_csv_list, required=True, metavar="A,B",
                   help=f"two of {ENGINES_HELP}, reference (the in-house DOP853 run at rtol 1e-12)")
    d.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene parameter, in its unit (`harness scenes`); a vector as a,b,c (repeatable)")
    d.add_argument("--t-end", type=_float, metavar="S", help="horizon (s, > 0; default: the scene's)")
    d.add_argument("--out-dir", type=_out_dir, default=Path("."), metavar="DIR",
                   help="folder for debug_<scene>_<A>_<B>.png (default: .)")
    d.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    add_per_state(d)

    c = sub.add_parser("check", help="read a model (MJCF and/or URDF) with MuJoCo, Pinocchio, Drake (and PyBullet: a URDF); name the odd one "
                                     "out; write a report",
                       description="Load a model with MuJoCo, Pinocchio and Drake (and a URDF with PyBullet); find the defects "
                                   "of the file itself (element, line, fix); per joint and quantity say which importers "
                                   "agree, name the odd one out and match it against the known importer limitations; "
                                   "compare the dynamics terms at random states and MuJoCo's free motion against "
                                   "Pinocchio's (judged by convergence); run the in-house engine and Exudyn as witnesses "
                                   "(apart: they never vote on the file). Prints the file's class (defect in your file, "
                                   "importer disagreement, consistent; and what is not compared) with the top findings "
                                   "and their fixes; writes check_<model>.md. Exit 0 when the file is consistent or its "
                                   "only disagreements are known importer limitations, 1 on a defect in the file or an "
                                   "unexplained disagreement, 2 on bad input (a file MuJoCo does not load, one whose "
                                   "defect stops every loader, one only MuJoCo loads, a free motion that diverges).")
    c.add_argument("--mjcf", type=Path, metavar="FILE.xml",
                   help="MJCF file (loaded into MuJoCo; into all three when alone)")
    c.add_argument("--urdf", type=Path, metavar="FILE.urdf",
                   help="URDF file (loaded into Pinocchio and Drake; into all three when alone)")
    c.add_argument("--out-dir", type=_out_dir, default=Path("reports"), metavar="DIR",
                   help="folder for check_<model>.md (default: reports)")
    c.add_argument("--seed", type=_seed, default=0, metavar="N", help="seed of the random states (an integer >= 0, default 0)")
    c.add_argument("--states", type=_int, default=4, metavar="N", help="random states for the dynamics terms (>= 1, default 4)")
    c.add_argument("--free-runs", type=_int, default=3, metavar="N", help="free-motion runs from random states (>= 0, default 3)")
    c.add_argument("--t-end", type=_float, default=0.5, metavar="S", help="free-motion horizon (s, > 0, default 0.5)")
    c.add_argument("--dt", type=_float, default=1e-3, metavar="S", help="free-motion step (s, > 0, default 0.001)")
    c.add_argument("--floating-base", action="store_true",
                   help="add a free root joint named root_joint in every loader (default: fixed base)")
    c.add_argument("--strip-geometry", action="store_true",
                   help="every loader reads a copy without geoms, meshes, height fields, textures and materials (mesh "
                        "files need not be found); the masses MuJoCo derives from geoms are kept as explicit inertials "
                        "where MuJoCo can compile the geometry (the report says which)")
    c.add_argument("--keep-static-links", action="store_true",
                   help="turn MuJoCo's fusestatic off (links on fixed joints stay separate bodies)")
    c.add_argument("--joint-map", type=Path, metavar="FILE",
                   help="when the MJCF's and the URDF's joints are named differently: a file of 'mjcf_name = urdf_name' "
                        "lines (TOML, or two columns; # comments); the URDF's joints are compared under the MJCF's names")
    c.add_argument("--map", action="append", metavar="MJCF_NAME=URDF_NAME",
                   help="one joint of the map (repeatable; added to --joint-map's)")
    c.add_argument("--allow-dir", action="append", type=_models_dir, default=[], metavar="DIR",
                   help="a folder besides the model's own whose files its <include>s, meshes, textures and height "
                        "fields may name (repeatable); any other file outside the model's folder is refused unread")
    c.add_argument("--no-witnesses", action="store_true",
                   help="do not run the in-house engine and Exudyn (the fastest check: the loaders only)")
    c.add_argument("--quiet", action="store_true",
                   help="print only the summary and errors: no progress bar or per-stage lines, not what the "
                        "engines printed on stderr during the comparison (numpy's and the importers' warnings)")

    z = sub.add_parser("zoo", help="`check` on every model of a collection or folder, each in its own process; one table",
                       description="Run `harness check` on every model of an installed collection or a folder, each model "
                                   "in its own worker process (a crash, hang or timeout is that model's row); write "
                                   "<collection>.md and .csv (per model: which engines load it, the file's class, the counts "
                                   "of defects and known and unexplained importer disagreements, the first finding and "
                                   "its fix, the witnesses, the run time, suspicious inertias) and "
                                   "<collection>/check_<model>.md. "
                                   "example-robot-data: the URDFs the pip package installs under <site-packages>/"
                                   "cmeel.prefix/share/example-robot-data/robots/ (meshes stripped); dm_control: "
                                   "<site-packages>/dm_control/suite/*.xml, checked in place. Details: the docstring of "
                                   "harness/tools/zoo.py. Exit 0 when the zoo ran (whatever the verdicts), 2 on bad input.")
    z.add_argument("collection", metavar="PATH|NAME",
                   help="example-robot-data, dm_control, or a folder: its *.xml (MJCF) and *.urdf, not its subfolders "
                        "(an MJCF and a URDF of one stem are checked as a pair)")
    z.add_argument("--only", type=_csv_list, metavar="NAME[,NAME]", help="check only these models (names as in the table)")
    z.add_argument("--base", choices=("auto", "fixed", "floating"), default="auto",
                   help="auto (default): a URDF alone gets a free root joint unless its root link is `world`; an MJCF "
                        "keeps its own root joints. fixed / floating: for every model")
    z.add_argument("--strip-geometry", action="store_true",
                   help="for a folder: delete geoms and meshes from MuJoCo's copy (example-robot-data always, dm_control never)")
    z.add_argument("--out-dir", type=_out_dir, default=None, metavar="DIR",
                   help="folder for the table and the per-model reports (default: reports/zoo; reports/partial/zoo "
                        "with --only or --no-witnesses, so that only a full run refreshes the committed snapshot)")
    z.add_argument("--jobs", type=_int, default=0, metavar="N", help="worker processes (>= 0; default 0: all cores)")
    z.add_argument("--no-witnesses", action="store_true",
                   help="check without the in-house engine and Exudyn (the loaders only: the fastest)")
    z.add_argument("--timeout", type=_float, default=300.0, metavar="S",
                   help="seconds allowed per model (> 0, default 300); a model over it is recorded as crashed (timeout)")
    add_dask(z)
    z.add_argument("--quiet", action="store_true",
                   help="no progress bar and no per-model progress lines on stderr (the per-model verdicts, the "
                        "summary and errors still print on stdout); the bar is drawn only when stderr is a terminal")


def cmd_inspect(args) -> int:
    from harness.engines import check_scene
    from harness.tools.inspection import inspect_scene, render
    from harness.model.scene import load_scene

    scene = check_scene(load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir))
    require_scene_files_utf8(scene)
    result = inspect_scene(scene, n_states=args.states, seed=args.seed)
    print(render(result), end="")
    return EXIT_OK if result.passed else EXIT_FAIL


def cmd_debug(args) -> int:
    from harness.engines import check_scene
    from harness.tools.debug import debug, parse_engines, summary, write_plot
    from harness.model.scene import check_steps, load_scene

    from harness.validate.run import save_interval

    engines = parse_engines(args.engines)
    scene = check_scene(load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir))
    require_scene_files_utf8(scene)
    if args.t_end is not None and not (args.t_end > 0):
        raise InputError(f"horizon t_end must be positive and finite, got {args.t_end!r}")
    t_end = args.t_end if args.t_end is not None else scene.t_end
    check_samples(t_end, save_interval(scene), len(scene.multibody().bodies), options="--t-end")
    check_steps(t_end, scene.dt, f"--t-end (at the scene's step dt = {scene.dt:g} s)")
    result = debug(scene, engines, args.t_end, fast=not args.per_state)
    print("\n".join(summary(result)))
    path = write_plot(result, args.out_dir)
    print(f"wrote {path}")
    return EXIT_OK if result.passed else EXIT_FAIL


def cmd_check(args) -> int:
    import numpy as np
    from threadpoolctl import threadpool_limits

    from harness.io.progress import make_bar
    from harness.tools.check import (captured_native_stderr, parse_map_options, read_joint_map, run_check, summary_lines,
                                     write_report)

    for option, path in (("--mjcf", args.mjcf), ("--urdf", args.urdf)):
        if path is not None:
            require_utf8(path, option.removeprefix("--").upper())
    joint_map = read_joint_map(args.joint_map) if args.joint_map is not None else {}
    joint_map.update(parse_map_options(args.map))
    # what a diverging run prints (numpy's warnings, the importers' output on file descriptor 2) is
    # held back: on divergence the one error line says it all; after a run that ends it is shown as
    # before. MuJoCo's warnings are not among it: run_check captures them into the result (report).
    failure = None
    # the progress (a bar, or one line per stage) goes to stderr as it was before the capture
    # one BLAS thread: the check's matrices are small, and a second thread on a busy core only waits
    with _live_stderr() as live, make_bar(None, desc="check", unit="stage", quiet=args.quiet, stream=live) as bar, \
            captured_native_stderr() as native, warnings.catch_warnings(record=True) as held, \
            threadpool_limits(limits=1, user_api="blas"):
        warnings.simplefilter("always", RuntimeWarning)
        try:
            result = run_check(args.mjcf, args.urdf, seed=args.seed, n_states=args.states, n_free=args.free_runs,
                               t_end=args.t_end, dt=args.dt, floating_base=args.floating_base,
                               strip=args.strip_geometry, keep_static=args.keep_static_links, joint_map=joint_map or None,
                               progress=bar, allowed_dirs=tuple(args.allow_dir), witnesses=not args.no_witnesses)
        except (np.linalg.LinAlgError, OverflowError, FloatingPointError) as err:
            failure = err
    if failure is not None:
        model = args.urdf if args.urdf is not None else args.mjcf
        raise InputError(f"{model}: the comparison diverged ({type(failure).__name__}: "
                         f"{' '.join(str(failure).split())}): check the model's masses and inertias, or shorten "
                         f"--t-end ({args.t_end:g} s) or --dt ({args.dt:g} s)")
    if not args.quiet:
        sys.stderr.write(native["text"])
        for w in held:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    path = write_report(result, args.out_dir, _command_line(args))
    print("\n".join(summary_lines(result, path)))
    return EXIT_OK if result.passed else EXIT_FAIL


@contextlib.contextmanager
def _live_stderr():
    """``sys.stderr``, or, when it writes to file descriptor 2 (which ``captured_native_stderr``
    redirects), a stream on a copy of that descriptor: what is written to it shows at once."""
    stream = sys.stderr
    try:
        fd = stream.fileno()
    except (AttributeError, ValueError, OSError):
        fd = None
    if fd != 2:
        yield stream
        return
    stream.flush()
    with os.fdopen(os.dup(2), "w", buffering=1, encoding=getattr(stream, "encoding", None) or "utf-8",
                   errors="replace") as live:
        yield live


def _command_line(args) -> str:
    parts = ["harness", "check"]
    for flag, value in (("--mjcf", args.mjcf), ("--urdf", args.urdf)):
        if value is not None:
            parts += [flag, str(value)]
    parts += ["--seed", str(args.seed), "--states", str(args.states), "--free-runs", str(args.free_runs),
              "--t-end", f"{args.t_end:g}", "--dt", f"{args.dt:g}"]
    parts += [flag for flag, on in (("--floating-base", args.floating_base), ("--strip-geometry", args.strip_geometry),
                                    ("--keep-static-links", args.keep_static_links),
                                    ("--no-witnesses", args.no_witnesses)) if on]
    if args.joint_map is not None:
        parts += ["--joint-map", str(args.joint_map)]
    for item in args.map or []:
        parts += ["--map", item]
    for folder in args.allow_dir:
        parts += ["--allow-dir", str(folder)]
    return shlex.join(parts)


def cmd_zoo(args) -> int:
    from harness.io.atomic import REPORTS_DIR, check_writable, default_out_dir
    from harness.io.progress import make_bar
    from harness.engines import provenance
    from harness.io.provenance import command_line
    from harness.tools.zoo import collection, headline, made_line, run_zoo, select, write_zoo

    if args.jobs < 0:
        raise InputError(f"--jobs must be >= 0, got {args.jobs!r}")
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    coll = select(collection(args.collection, strip=args.strip_geometry), args.only)
    connect_dask(args)  # an unreachable scheduler: one line, exit 2, nothing written
    partial = bool(args.only) or args.no_witnesses   # only a whole run with the witnesses refreshes the snapshot
    out = args.out_dir or (default_out_dir("zoo", full_run=False) if partial else REPORTS_DIR / "zoo")
    check_writable(out)

    print(f"zoo {coll.name}: {len(coll.models)} model(s)", flush=True)
    with make_bar(len(coll.models), desc=f"zoo {coll.name}", unit="model", quiet=args.quiet) as bar:
        def done(row) -> None:
            print(f"  {row.cls:<21} {row.name} ({row.wall_s:.1f} s)", flush=True)
            bar.done(f"{row.name} {row.cls} {row.wall_s:.1f} s")

        zoo = run_zoo(coll, base=args.base, jobs=args.jobs or None, timeout=args.timeout, on_done=done,
                      witnesses=not args.no_witnesses,
                      dask=args.dask)
    paths = write_zoo(zoo, out, made_line(provenance()), command_line())
    print(f"zoo {coll.name}: {headline(zoo)}")
    print(f"wrote {paths[0]}, {paths[1]} and {len(paths) - 2} per-model report(s) in {out / coll.name}")
    return EXIT_OK


COMMANDS = {"inspect": cmd_inspect, "debug": cmd_debug, "check": cmd_check, "zoo": cmd_zoo}
