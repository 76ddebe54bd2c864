"""``harness workprecision``: error against run time for every scene and engine.

Writes ``<out-dir>/workprecision.md``, ``<out-dir>/workprecision.csv`` and
``<out-dir>/workprecision/<scene>.png`` (see ``harness.studies.workprecision.run``). Exit code 0, or 2 on bad
input (one line on stderr, no report touched). A run that fails is a recorded point, not an error.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace

from harness.model.errors import InputError
from harness.cli.arg_types import (MODELS_DIR_HELP, add_dask, add_engines, add_out_dir, check_selection, connect_dask,
                                   csv_list as _csv_list, float_arg as _float, int_arg as _int,
                                   models_dir_arg as _models_dir, out_dir)

SUBSET = ("quick", "scenes", "engines", "models_dir")  # options that make a run partial


def add_parser(sub) -> None:
    """Add the ``workprecision`` subcommand to the CLI's subparsers."""
    from harness.engines import REFERENCE_ENGINE, display
    from harness.studies.workprecision import BASELINE

    base, ref = display(BASELINE), display(REFERENCE_ENGINE)
    w = sub.add_parser("workprecision", help="work-precision diagrams: error against run time per scene and engine",
                       description="Error against run time for every scene, engine and integrator (fixed steps "
                                   "halved, adaptive tolerances tightened); write workprecision.md, "
                                   "workprecision.csv and workprecision/<scene>.png. Exit 0, or 2 on bad input.")
    w.add_argument("--scenes", type=_csv_list, metavar="A,B",
                   help="comma-separated scene names (default: every scene of --models-dir)")
    add_engines(w)
    w.add_argument("--repeats", type=_int, metavar="N", help="timed runs after the warm-up (>= 1, default 3)")
    w.add_argument("--max-run-s", type=_float, metavar="S",
                   help="stop refining a curve after a run this slow (s, > 0, default 2)")
    w.add_argument("--budget-s", type=_float, metavar="S",
                   help=f"wall time a curve's points may take together (s, > 0, default 0.5; {base}'s loop "
                        "variants half of it)")
    w.add_argument("--key-budget-s", type=_float, metavar="S",
                   help=f"the same for the curves the targets are measured on, {base} RK4 and the {ref} DOP853 "
                        "(s, > 0, default 3; up to 10 while one still converges towards a target)")
    w.add_argument("--no-budget", action="store_true",
                   help="no time budgets: refine every curve until --max-run-s, its error or the ladder stops it "
                        "(much longer: without budgets the sweep took more than an hour)")
    w.add_argument("--per-state", choices=("uncovered", "all", "none"),
                   help=f"where the per-state {ref} curves run: on scenes the compiled form does not model "
                        "(uncovered, the default), on every scene (all), nowhere (none)")
    w.add_argument("--saves", type=_int, metavar="N",
                   help="saved intervals over the horizon, where errors are measured (>= 1, default 20)")
    w.add_argument("--t-end", type=_float, metavar="S", help="horizon (s, > 0) instead of each scene's")
    w.add_argument("--batch", type=_int, metavar="N",
                   help="initial conditions of the batched-throughput benchmark (>= 0, default 1000; 0 skips it)")
    w.add_argument("--batch-steps", type=_int, metavar="N",
                   help="steps per trajectory in that benchmark (>= 1, default 100)")
    w.add_argument("--batch-budget-s", type=_float, metavar="S",
                   help="about the time of that benchmark's timed runs, which sizes its batch (s, > 0, default 3)")
    w.add_argument("--run-timeout", type=_float, metavar="S",
                   help="wall-clock seconds allowed to one point (its warm-up and timed repeats, in its own worker "
                        "process; > 0, default 60): a point over it is recorded as timed out, its curve stops and "
                        "the sweep goes on")
    w.add_argument("--quick", action="store_true", help="a small, fast sweep (for tests and smoke checks)")
    w.add_argument("--quiet", "--no-progress", dest="quiet", action="store_true",
                   help="no progress bar and no compile notice on stderr (the summary and errors still print; "
                        "--no-progress is the same); the bar is drawn only when stderr is a terminal")
    add_out_dir(w, "workprecision", "workprecision.md, workprecision.csv, workprecision/", SUBSET)
    w.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    add_dask(w)  # one case per scene on the workers; locally the scenes run one after the other


def options_from_args(args):
    """``SweepOptions`` from the parsed arguments; InputError for a bad value."""
    from harness.studies.workprecision.run import QUICK, SweepOptions

    from harness.model.scene import MAX_SAMPLES

    opts = QUICK if args.quick else SweepOptions()
    changes = {}
    for name, attr, ok in (("repeats", "repeats", lambda v: v >= 1), ("max_run_s", "max_run_s", lambda v: v > 0),
                           ("saves", "saves", lambda v: 1 <= v <= MAX_SAMPLES), ("t_end", "horizon", lambda v: v > 0),
                           ("batch", "batch", lambda v: 0 <= v <= MAX_SAMPLES),
                           ("batch_steps", "batch_steps", lambda v: 1 <= v <= MAX_SAMPLES),
                           ("budget_s", "curve_budget_s", lambda v: v > 0), ("key_budget_s", "key_budget_s", lambda v: v > 0),
                           ("batch_budget_s", "batch_budget_s", lambda v: v > 0),
                           ("run_timeout", "run_timeout_s", lambda v: v > 0)):
        value = getattr(args, name)
        if value is None:
            continue
        if not ok(value):
            raise InputError(f"--{name.replace('_', '-')} out of range: {value!r}")
        changes[attr] = value
    if "curve_budget_s" in changes and opts.loop_budget_s is not None:
        changes["loop_budget_s"] = changes["curve_budget_s"] / 2
    if args.no_budget:
        changes.update(curve_budget_s=None, key_budget_s=None, loop_budget_s=None, reach_budget_s=None)
    if args.per_state:
        changes["per_state"] = args.per_state
    changes["progress"] = not args.quiet
    return replace(opts, **changes)


def run(args) -> int:
    """Run the sweep and write the reports."""
    from harness.engines import ENGINE_NAMES, check_scene, get_engine, provenance
    from harness.model.scene import available_scenes, load_scene
    from harness.studies.workprecision.run import TARGETS, check_step_budget, run_sweep, time_table
    from harness.studies.workprecision.report import write_reports

    from harness.model.scene import MODELS_DIR

    options = options_from_args(args)
    engines = check_selection("--engines", args.engines, list(ENGINE_NAMES))
    for e in engines:
        get_engine(e)
    names = check_selection("--scenes", args.scenes, available_scenes(args.models_dir),
                            f"under {args.models_dir or MODELS_DIR} (a scene is a folder with a scene.toml)")
    scenes = [check_scene(load_scene(n, models_dir=args.models_dir)) for n in names]
    check_step_budget(scenes, options)  # before any run: no ladder beyond MAX_STEPS
    connect_dask(args)  # an unreachable scheduler: one line, exit 2, nothing written
    folder = out_dir(args, "workprecision", SUBSET)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    results = run_sweep(scenes, engines, options, dask=args.dask)
    wall = time.perf_counter() - start
    paths = write_reports(results, provenance(), options, folder, (load_before, os.getloadavg()[0]), wall_s=wall)
    for sweep in results:
        rows = time_table(sweep)
        parts = []
        for target in TARGETS:
            best = min(((r[f"t({target:g})"], r["label"]) for r in rows if r[f"t({target:g})"] == r[f"t({target:g})"]),
                       default=None)
            parts.append(f"fastest to {target:g}: {best[1]} ({best[0]:.3g} s)" if best else f"{target:g} not reached")
        print(f"{sweep.scene}: {len(sweep.points)} points in {sweep.walls.get('total', float('nan')):.1f} s; "
              + "; ".join(parts))
    print(f"sweep: {wall:.0f} s wall")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0
