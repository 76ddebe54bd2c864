"""``harness rolling-study``: the rolling-disk report (``reports/rolling_disk.md`` and plots).

Runs ``harness.studies.rolling.run`` (every case on every engine, MuJoCo's contact settings, the
stability threshold of straight rolling) and writes ``rolling_disk.md``,
``rolling_disk.json`` and ``rolling_disk_*.png`` into ``--out-dir``. ``--quick`` runs short
horizons, two settings and two speeds (for tests). Exit code 0 when every engine agrees with
the correct threshold on every speed swept (and so contradicts the printed one between the
two), 1 otherwise. Takes a few minutes in full (the in-house and Pinocchio runs are Python
loops).
"""

from __future__ import annotations


EXIT_OK, EXIT_FAIL = 0, 1
SUBSET = ("quick", "models_dir")  # options that make a run partial


def add_parser(sub) -> None:
    from harness.cli.arg_types import MODELS_DIR_HELP, add_out_dir, models_dir_arg
    from harness.engines import display
    from harness.studies.rolling import SETTINGS_ENGINE

    name = display(SETTINGS_ENGINE)
    r = sub.add_parser("rolling-study", help=f"rolling disk: {name} settings study, stability threshold vs the textbook; "
                                             "writes reports/rolling_disk.md",
                       description=f"The rolling disk on every engine: {name}'s contact settings, the stability "
                                   "threshold v_c (m/s) of straight rolling against the textbook's. Writes "
                                   "rolling_disk.md, rolling_disk.json and rolling_disk_*.png. Exit 0 when every "
                                   "engine agrees with the correct threshold, 1 otherwise, 2 on bad input.")
    add_out_dir(r, "rolling-study", "rolling_disk.md, rolling_disk.json, rolling_disk_*.png", SUBSET)
    r.add_argument("--quick", action="store_true", help="short horizons, few settings and speeds (a smoke run)")
    r.add_argument("--models-dir", type=models_dir_arg, metavar="DIR",
                   help=MODELS_DIR_HELP + "; it must hold rolling_disk")
    r.add_argument("--quiet", action="store_true",
                   help="no progress bar, no per-run lines and no compile notice on stderr (the summary lines and "
                        "errors still print); without it, a bar when stderr is a terminal, else one line per finished run")


def run(args) -> int:
    from harness.cli.arg_types import out_dir
    from harness.io.progress import make_bar
    from harness.engines import provenance
    from harness.studies.rolling.report import write_reports
    from harness.studies.rolling.run import rolling_study, threshold_agrees

    out = out_dir(args, "rolling-study", SUBSET)
    with make_bar(None, desc="rolling-study", unit="run", quiet=args.quiet) as bar:
        result = rolling_study(quick=args.quick, models_dir=args.models_dir, progress=bar)
    pngs = write_reports(result, out, provenance(), args.quick)
    agree = threshold_agrees(result.threshold)
    print(f"wrote {out / 'rolling_disk.md'}, {out / 'rolling_disk.json'}" + "".join(f", {p}" for p in pngs))
    print(f"threshold: every engine agrees with v_c = {result.thresholds['correct']:.4f} m/s on every speed: {agree}")
    return EXIT_OK if agree else EXIT_FAIL
