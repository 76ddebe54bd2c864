"""``harness benchmark``: the published benchmarks report (``reports/benchmarks.md``).

Runs ``harness.studies.benchmarks.run`` on every scene whose reference states a ``BENCHMARK``
(the IFToMM library's problems the scenes reproduce): validate's runs and a work-precision sweep
on those scenes, and writes ``benchmarks.md`` and ``benchmarks.csv`` into ``--out-dir``. Exit 0
when every engine that runs a problem passes its ``exact`` check there, 1 otherwise, 2 on bad
input.
"""

from __future__ import annotations

EXIT_OK, EXIT_FAIL = 0, 1
SUBSET = ("scenes", "engines", "quick", "models_dir")  # options that make a run partial


def add_parser(sub) -> None:
    """Add the ``benchmark`` subparser."""
    from harness.cli.arg_types import MODELS_DIR_HELP, add_engines, add_out_dir, csv_list, models_dir_arg

    b = sub.add_parser("benchmark", help="published benchmarks (IFToMM A01, A03, A04, ...): published vs ours per engine, "
                                         "time to the required accuracy; writes reports/benchmarks.md",
                       description="Every scene that reproduces a published benchmark: each engine's error and "
                                   "agreement in digits at the scene's step, the class of its convergence, and the "
                                   "run time of its fastest method to the problem's required accuracy against the "
                                   "baseline engine's. Writes benchmarks.md and benchmarks.csv. Exit 0 when every "
                                   "engine that runs a problem passes its exact check, 1 otherwise, 2 on bad input.")
    add_out_dir(b, "benchmark", "benchmarks.md, benchmarks.csv", SUBSET)
    b.add_argument("--scenes", type=csv_list, metavar="A,B", help="comma-separated benchmark scenes (default: all)")
    add_engines(b)
    b.add_argument("--quick", action="store_true", help="a small work-precision sweep (a smoke run)")
    b.add_argument("--models-dir", type=models_dir_arg, metavar="DIR", help=MODELS_DIR_HELP)
    b.add_argument("--quiet", action="store_true", help="no progress bar on stderr")


def run(args) -> int:
    """Run the study, write the reports, print a summary; returns the exit code."""
    from dataclasses import replace

    from harness.cli.arg_types import check_selection, out_dir
    from harness.engines import ENGINE_NAMES, load_scene, provenance
    from harness.io.progress import make_bar
    from harness.studies.benchmarks.report import write_reports
    from harness.studies.benchmarks.run import benchmark_scenes, benchmark_study
    from harness.studies.workprecision.run import QUICK, SweepOptions

    engines = check_selection("--engines", args.engines, list(ENGINE_NAMES))
    names = check_selection("--scenes", args.scenes, benchmark_scenes(args.models_dir), "with a published benchmark")
    scenes = [load_scene(n, models_dir=args.models_dir) for n in names]
    out = out_dir(args, "benchmark", SUBSET)
    options = replace(QUICK if args.quick else SweepOptions(), progress=False)
    with make_bar(None, desc="benchmark", unit="run", quiet=args.quiet) as bar:
        results = benchmark_study(scenes, engines, options, progress=bar)
    paths = write_reports(results, out, provenance())
    failing = [f"{p.problem} {r.engine}" for p in results for r in p.engines if not r.passed]
    for p in results:
        print(f"{p.problem} ({p.scene}): " + "; ".join(
            f"{r.engine} {r.digits:.1f} digits, {r.time_s:.3g} s" for r in p.engines))
    print("wrote " + ", ".join(str(x) for x in paths))
    if failing:
        print("failing: " + ", ".join(failing))
    return EXIT_FAIL if failing else EXIT_OK
