"""``harness sweep SCENE``: the engines' disagreement and drift over a scene's parameter space.

``add_parser(sub)`` adds the subparser to ``harness.cli.main``'s subparsers object; ``run(args)``
returns the exit code: 0 when the sweep ran (failing checks, blow-ups, crashes and refused points
are findings, recorded per point), 2 on bad input (a malformed or unknown key, lo >= hi, n < 2, a
range end the scene refuses, an unknown scene or engine, a bad --t-end: one line on stderr,
nothing written). The reports go to ``--out-dir``, by default ``reports/partial/sweep/<scene>/``:
a sweep is never the committed snapshot.
"""

from __future__ import annotations

from harness.cli.arg_types import (ENGINES_HELP, MODELS_DIR_HELP, add_dask, add_engines, check_selection, connect_dask,
                                   float_arg as _float, int_arg as _int, models_dir_arg as _models_dir,
                                   seed_arg as _seed)
from harness.engines import REFERENCE_ENGINE, display, preload

EXIT_OK = 0
MAX_FAIL_LINES = 5  # failing points printed per engine (the report has them all)


def add_parser(sub) -> None:
    """Add the ``sweep`` subparser."""
    from pathlib import Path

    s = sub.add_parser("sweep", help="one scene over a grid or random sample of its parameters: per point and engine "
                                     "the checks' verdicts (class, failing checks), the largest error, trajectory "
                                     "error and energy drift; heatmap",
                       description="Run one scene at every point of a parameter grid (--grid, one or two keys) or "
                                   "of a random sample (--random, any number of keys, --samples, --seed) on the "
                                   f"engines: each point is a validate case (the {display(REFERENCE_ENGINE)} DOP853 reference and each "
                                   "engine, each check judged by how its error converges), each run in its own "
                                   "worker process. "
                                   "Write <scene>_sweep.md, .csv (one row per point x engine) and .png. Exit 0 when "
                                   "the sweep ran (failing points are findings), 2 on bad input (nothing written).")
    s.add_argument("scene", help="scene name (list them and their parameters with `harness scenes`)")
    s.add_argument("--grid", action="append", metavar="KEY=lo:hi:n",
                   help="sweep parameter KEY (its unit, `harness scenes`; a vector's component as KEY[i]) over n >= 2 "
                        "evenly spaced values from lo to hi inclusive (append :log for log spacing, lo > 0); "
                        "repeat for a second key (a 2-D grid, at most two)")
    s.add_argument("--random", action="append", metavar="KEY=lo:hi",
                   help="draw KEY uniformly in [lo, hi) (append :log for log-uniform, lo > 0); repeatable, any "
                        "number of keys; needs --samples; not with --grid")
    s.add_argument("--samples", type=_int, metavar="N", help="random points to draw (>= 1; with --random)")
    s.add_argument("--seed", type=_seed, default=0, metavar="S",
                   help="seed of the random points (an integer >= 0, numpy default_rng; default 0): the same seed, "
                        "the same points")
    add_engines(s)
    s.add_argument("--t-end", type=_float, metavar="S",
                   help="horizon (s, > 0; a whole multiple of the scene's save interval; default: the scene's "
                        "[simulation] t_end)")
    s.add_argument("--jobs", type=_int, default=0, metavar="N", help="worker processes (>= 0; default 0: all cores)")
    s.add_argument("--timeout", type=_float, default=300.0, metavar="S",
                   help="seconds allowed per run (> 0, default 300): a point's reference and each engine's run")
    add_dask(s)
    s.add_argument("--out-dir", type=Path, default=None, metavar="DIR",
                   help="folder for <scene>_sweep.md, .csv and .png (default: reports/partial/sweep/<scene>; a "
                        "sweep never replaces the committed reports)")
    s.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    s.add_argument("--quiet", action="store_true",
                   help="no progress bar and no per-run lines on stderr (the summary and errors still print); "
                        "without it, a bar when stderr is a terminal, else one line per finished run")


def run(args) -> int:
    from harness.engines import ENGINE_NAMES, declaration, get_engine, prepare
    from harness.io.atomic import check_writable, default_out_dir
    from harness.io.progress import make_bar
    from harness.engines import provenance
    from harness.model.errors import InputError
    from harness.studies.sweep.report import write_sweep_reports
    from harness.studies.sweep.run import (CLASS_ORDER, MAX_GRID_KEYS, MAX_POINTS, check_axes, grid_points,
                                           load_for_sweep, parse_axis, random_points, run_sweep, with_horizon)

    if bool(args.grid) == bool(args.random):
        raise InputError("give --grid KEY=lo:hi:n (one or two) or --random KEY=lo:hi with --samples N, not both")
    if args.grid and len(args.grid) > MAX_GRID_KEYS:
        raise InputError(f"--grid: at most {MAX_GRID_KEYS} keys (a heatmap has two axes); use --random for more")
    if args.random and args.samples is None:
        raise InputError("--random needs --samples N")
    if args.grid and args.samples is not None:
        raise InputError("--samples goes with --random, not --grid")
    if args.samples is not None and not 1 <= args.samples <= MAX_POINTS:
        raise InputError(f"--samples must be 1 .. {MAX_POINTS}, got {args.samples}")
    if args.jobs < 0:
        raise InputError(f"--jobs must be >= 0, got {args.jobs!r}")
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    engines = check_selection("--engines", args.engines, list(ENGINE_NAMES))
    for e in engines:
        if e not in ENGINE_NAMES:
            raise InputError(f"unknown engine {e!r} (known: {ENGINES_HELP})")
        get_engine(e)  # imported here, once, before the workers fork
    grid = bool(args.grid)
    axes = [parse_axis(text, grid=grid) for text in (args.grid or args.random)]
    scene = load_for_sweep(args.scene, args.models_dir)
    axes = check_axes(scene, axes)
    scene = with_horizon(scene, args.t_end)
    if grid:
        size = 1
        for a in axes:
            size *= a.n
        if size > MAX_POINTS:
            raise InputError(f"--grid: {size} points, more than the {MAX_POINTS} a sweep may hold")
        points = grid_points(axes)
    else:
        points = random_points(axes, args.samples, args.seed)
    connect_dask(args)  # an unreachable scheduler: one line, exit 2, nothing written
    folder = args.out_dir or default_out_dir("sweep", full_run=False) / scene.name
    check_writable(folder)
    for e in engines:  # a compiled default: its compilation announced once, here
        if declaration(e).compiled:
            prepare(e, [(scene.integrators.get(e, ""), scene.multibody())])  # once: the forked workers inherit it
    runnable = [e for e in engines if e not in scene.not_run]
    if not args.dask:
        preload(runnable)  # the engines' own lazy imports, once for the forked workers
    # a bar on a terminal, else one line per finished run (harness.io.progress); neither with --quiet
    with make_bar(len(points) * (1 + len(runnable)), desc=f"sweep {scene.name}", unit="run", quiet=args.quiet) as bar:
        result = run_sweep(scene, axes, points, engines, mode="grid" if grid else "random",
                           seed=None if grid else args.seed, jobs=args.jobs or None, timeout=args.timeout,
                           dask=args.dask, progress=bar)
    paths = write_sweep_reports(result, provenance(), folder)
    print(f"sweep {scene.name}: {len(points)} points x {len(engines)} engines, {result.wall_s:.1f} s")
    for e in engines:
        rows = result.of(e)
        ran = [r for r in rows if r.status == "ok"]
        if not ran:
            print(f"  {e}: no run ended ok ({', '.join(sorted({r.status.split(':')[0] for r in rows}))})")
            continue
        worst = max(ran, key=lambda r: r.error if r.error == r.error else -1.0)
        where = ", ".join(f"{a.key}={v:.4g}" for a, v in zip(axes, worst.values))
        bad = len(rows) - len(ran)
        unjudged = sum(1 for r in ran if r.no_value)
        classes = {c: sum(1 for r in ran if r.classification == c) for c in reversed(CLASS_ORDER)}
        print(f"  {e}: largest error {worst.error:.3g} ({worst.error_check or '-'}) at {where}; "
              + ", ".join(f"{c} {n}" for c, n in classes.items() if n) + "; "
              f"{sum(not r.passed for r in ran)} of {len(rows)} points fail a check"
              + (f" ({unjudged} with a check without a value)" if unjudged else "")
              + (f", {bad} not ok or refused" if bad else ""))
        failing = [r for r in ran if r.failing]
        for r in failing[:MAX_FAIL_LINES]:
            at = ", ".join(f"{a.key}={v:.4g}" for a, v in zip(axes, r.values))
            print(f"    FAIL at {at}: " + "; ".join(f"{c} [{cls}]" for c, cls, _ in r.failing))
        if len(failing) > MAX_FAIL_LINES:
            print(f"    ... {len(failing) - MAX_FAIL_LINES} more failing points (the report's table has each reason)")
    print("wrote " + ", ".join(str(p) for p in paths))
    return EXIT_OK
