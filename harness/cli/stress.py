"""``harness stress``: run the stress catalogue on the engines, write the stability map.

``add_parser(sub)`` adds the subparser to ``harness.cli.main``'s subparsers object (whose
``parser_class`` turns argparse errors into ``InputError``); ``run(args)`` returns the exit code:
0 when the sweep ran (unstable or inaccurate runs are findings, not failures), 2 on bad input
(unknown variant or engine, malformed catalogue: raised as ``InputError``, one line on stderr).
"""

from __future__ import annotations

import sys
from pathlib import Path
from harness.cli.arg_types import (MODELS_DIR_HELP, add_dask, add_engines, add_out_dir, check_selection, connect_dask,
                                   csv_list as _csv_list, float_arg as _float, int_arg as _int,
                                   models_dir_arg as _models_dir, out_dir)

EXIT_OK = 0
SUBSET = ("quick", "variants", "engines", "catalogue", "models_dir")  # options that make a run partial


def add_parser(sub) -> None:
    """Add the ``stress`` subparser."""
    s = sub.add_parser("stress", help="stiff and extreme variants: largest stable step, failure mode and drift per "
                                      "engine/integrator; write reports/stress.{md,csv} and plots",
                       description="Run the stress catalogue (stiff and extreme variants of the scenes) on every "
                                   "engine and integrator: largest stable step (s), failure mode, drift. Write "
                                   "stress.md, stress.csv and stress/*.png. Exit 0 when the sweep ran (unstable "
                                   "runs are findings), 2 on bad input.")
    s.add_argument("--variants", type=_csv_list, metavar="A,B",
                   help="comma-separated variant names of the catalogue (default: the whole catalogue)")
    add_engines(s)
    s.add_argument("--quick", action="store_true", help="a smoke run: short horizons, a tenth of the step budget, one bisection step")
    s.add_argument("--jobs", type=_int, default=0, metavar="N", help="worker processes (>= 0; default 0: all cores)")
    s.add_argument("--timeout", type=_float, default=120.0, metavar="S",
                   help="seconds allowed per run (> 0, default 120; references 4x)")
    add_dask(s)
    add_out_dir(s, "stress", "stress.md, stress.csv, stress/", SUBSET)
    s.add_argument("--catalogue", type=Path, metavar="FILE.toml",
                   help="stress catalogue TOML (default: harness/studies/stress/catalogue.toml)")
    s.add_argument("--models-dir", type=_models_dir, metavar="DIR", help=MODELS_DIR_HELP)
    s.add_argument("--quiet", action="store_true",
                   help="no progress bar, no per-variant lines and no compile notice on stderr (the summary and "
                        "errors still print); without it, a bar when stderr is a terminal, else one line per event")


def run(args) -> int:
    from harness.model.errors import InputError
    from harness.io.progress import bar_enabled, make_bar
    from harness.engines import provenance
    from harness.studies.stress.run import load_catalogue, run_stress, select
    from harness.studies.stress.report import write_stress_reports

    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    if args.jobs < 0:
        raise InputError(f"--jobs must be >= 0, got {args.jobs!r}")
    for option, chosen in (("--variants", args.variants), ("--engines", args.engines)):
        if chosen is not None:
            check_selection(option, chosen, [])
    catalogue = load_catalogue(args.catalogue, quick=args.quick)
    variants, engines = select(catalogue, args.variants, args.engines)
    connect_dask(args)  # an unreachable scheduler: one line, exit 2, nothing written
    folder = out_dir(args, "stress", SUBSET)
    # a bar on a terminal; the per-variant lines only in a log (stderr not a terminal); neither with --quiet
    lines = not (args.quiet or bar_enabled())
    with make_bar(None, desc="stress", unit="cell", quiet=args.quiet) as bar:
        result = run_stress(catalogue, variants, engines, quick=args.quick, jobs=args.jobs or None,
                            timeout=args.timeout, models_dir=args.models_dir, progress=bar, dask=args.dask,
                            log=(lambda line: print(line, file=sys.stderr, flush=True)) if lines else (lambda line: None))
    paths = write_stress_reports(result, provenance(), folder)
    stable = sum(1 for m in result.rows if m.stable_dt is not None or (m.nominal is not None and m.nominal.stable))
    print(f"stress: {len(variants)} variants ({len(result.skipped)} skipped), {len(result.rows)} engine/integrator "
          f"cells ({stable} with a stable step), {len(result.trials)} runs, {result.wall_s:.0f} s")
    print("wrote " + ", ".join(str(p) for p in paths[:3]) + f" and {len(paths) - 3} plots")
    return EXIT_OK
