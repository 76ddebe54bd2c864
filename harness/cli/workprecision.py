"""``harness workprecision``: error against run time for every scene and engine.

Writes ``<out-dir>/workprecision.md``, ``<out-dir>/workprecision.csv`` and
``<out-dir>/workprecision/<scene>.png`` (see ``harness.studies.workprecision.run``). Exit code 0, or 2 on bad
input (one line on stderr, no report touched). A run that fails is a recorded point, not an error.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from harness.model.errors import InputError
from harness.cli.arg_types import csv_list as _csv_list


def add_parser(sub) -> None:
    """Add the ``workprecision`` subcommand to the CLI's subparsers."""
    w = sub.add_parser("workprecision", help="work-precision diagrams: error against run time per scene and engine")
    w.add_argument("--scenes", type=_csv_list, help="comma-separated scene names (default: all)")
    w.add_argument("--engines", type=_csv_list, help="comma-separated engines (default: all)")
    w.add_argument("--repeats", type=int, help="timed runs after the warm-up (default 3)")
    w.add_argument("--max-run-s", type=float, help="stop refining a curve after a run this slow (default 2 s)")
    w.add_argument("--saves", type=int, help="saved intervals over the horizon, where errors are measured (default 20)")
    w.add_argument("--t-end", type=float, help="horizon (s) instead of each scene's")
    w.add_argument("--batch", type=int, help="initial conditions of the batched-throughput benchmark (default 1000; 0 skips it)")
    w.add_argument("--batch-steps", type=int, help="steps per trajectory in that benchmark (default 100)")
    w.add_argument("--quick", action="store_true", help="a small, fast sweep (for tests and smoke checks)")
    w.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    w.add_argument("--out-dir", type=Path, default=Path("reports"))
    w.add_argument("--models-dir", type=Path, help="folder of scene folders (default: the project's models/)")


def options_from_args(args):
    """``SweepOptions`` from the parsed arguments; InputError for a bad value."""
    from harness.studies.workprecision.run import QUICK, SweepOptions

    opts = QUICK if args.quick else SweepOptions()
    changes = {}
    for name, attr, ok in (("repeats", "repeats", lambda v: v >= 1), ("max_run_s", "max_run_s", lambda v: v > 0),
                           ("saves", "saves", lambda v: v >= 1), ("t_end", "horizon", lambda v: v > 0),
                           ("batch", "batch", lambda v: v >= 0), ("batch_steps", "batch_steps", lambda v: v >= 1)):
        value = getattr(args, name)
        if value is None:
            continue
        if not ok(value):
            raise InputError(f"--{name.replace('_', '-')} out of range: {value!r}")
        changes[attr] = value
    changes["progress"] = not args.no_progress
    return replace(opts, **changes)


def run(args) -> int:
    """Run the sweep and write the reports."""
    from harness.engines import ENGINE_NAMES, get_engine
    from harness.io.provenance import provenance
    from harness.model.scene import available_scenes, load_scene
    from harness.studies.workprecision.run import TARGETS, run_sweep, time_table
    from harness.studies.workprecision.report import write_reports

    options = options_from_args(args)
    engines = args.engines or list(ENGINE_NAMES)
    for e in engines:
        get_engine(e)
    names = args.scenes or available_scenes(args.models_dir)
    scenes = [load_scene(n, models_dir=args.models_dir) for n in names]
    load_before = os.getloadavg()[0]
    results = run_sweep(scenes, engines, options)
    paths = write_reports(results, provenance(), options, args.out_dir, (load_before, os.getloadavg()[0]))
    for sweep in results:
        rows = time_table(sweep)
        parts = []
        for target in TARGETS:
            best = min(((r[f"t({target:g})"], r["label"]) for r in rows if r[f"t({target:g})"] == r[f"t({target:g})"]),
                       default=None)
            parts.append(f"fastest to {target:g}: {best[1]} ({best[0]:.3g} s)" if best else f"{target:g} not reached")
        print(f"{sweep.scene}: {len(sweep.points)} points; " + "; ".join(parts))
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0
