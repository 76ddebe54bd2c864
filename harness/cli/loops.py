"""``harness loop-study``: the closed-loop report (``reports/loop_closure.md`` and plots).

Runs ``harness.studies.loops.run`` (every scene with a cut joint, at the scene's step times 2,
1, 1/2 and 1/4, on the ideal-constraint engines and on MuJoCo with its loop equalities set four
ways) and writes ``loop_closure.md``, ``loop_closure.json`` and ``loop_closure_<scene>.png``
into ``--out-dir``. ``--quick`` runs 0.5 s at two steps (for tests). Each run is made in its
own worker process (``--jobs`` at a time, ``--timeout`` s each). Exit code 0 when every
ideal-constraint engine (in-house, Pinocchio, Exudyn) keeps the closure gap below 1e-9 m at
every step and every run that should run ends ok, 1 otherwise, 2 on bad input.
"""

from __future__ import annotations

EXIT_OK, EXIT_FAIL = 0, 1
SUBSET = ("quick", "models_dir")  # options that make a run partial


def add_parser(sub) -> None:
    """Add the ``loop-study`` subparser."""
    from harness.cli.arg_types import MODELS_DIR_HELP, add_out_dir, float_arg, int_arg, models_dir_arg
    from harness.engines import display
    from harness.studies.loops import SOFT_LOOP_ENGINE

    name = display(SOFT_LOOP_ENGINE)
    r = sub.add_parser("loop-study", help="closed kinematic loops: closure gap, energy and exact error against the "
                                          f"step per engine, {name}'s solref/solimp; writes reports/loop_closure.md",
                       description="Every scene with a closed kinematic loop at the scene's step times 2, 1, 1/2, "
                                   f"1/4: closure gap (m) and velocity (m/s), energy, exact error per engine, {name} "
                                   f"with the MJCF's solref/solimp, solref 2 dt, {name}'s default solimp and {name}'s "
                                   "defaults. Writes "
                                   "loop_closure.md, loop_closure.json and loop_closure_<scene>.png. Exit 0 when "
                                   "every ideal-constraint engine closes the loop below 1e-9 m at every step and "
                                   "every run ends ok, 1 otherwise, 2 on bad input.")
    add_out_dir(r, "loop-study", "loop_closure.md, loop_closure.json, loop_closure_<scene>.png", SUBSET)
    r.add_argument("--quick", action="store_true", help="0.5 s (at most a tenth of a scene's horizon) at two steps (2 dt and dt; a smoke run)")
    r.add_argument("--models-dir", type=models_dir_arg, metavar="DIR",
                   help=MODELS_DIR_HELP + "; its scenes with a cut joint are studied")
    r.add_argument("--jobs", type=int_arg, default=0, metavar="N", help="worker processes (>= 0; default 0: all cores)")
    r.add_argument("--timeout", type=float_arg, default=300.0, metavar="S",
                   help="seconds allowed per run (> 0, default 300); a run over it is recorded as 'timeout'")
    r.add_argument("--quiet", action="store_true",
                   help="no progress bar and no compile notice on stderr (the summary lines and errors still print); "
                        "the bar is drawn only when stderr is a terminal")


def run(args) -> int:
    """Run the study, write the reports, print a summary; returns the exit code."""
    from harness.cli.arg_types import out_dir
    from harness.io.progress import case_label, make_bar
    from harness.engines import provenance
    from harness.model.errors import InputError
    from harness.studies.loops.report import write_reports
    from harness.studies.loops.run import failures, loop_scenes, loop_study, planned_runs

    if args.jobs < 0:
        raise InputError(f"--jobs must be >= 0, got {args.jobs!r}")
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    scenes = loop_scenes(args.models_dir)
    out = out_dir(args, "loop-study", SUBSET)
    with make_bar(planned_runs(scenes, args.quick), desc="loop-study", unit="run", quiet=args.quiet) as bar:
        study = loop_study(quick=args.quick, jobs=args.jobs or None, timeout=args.timeout, scenes=scenes,
                           on_done=lambda key, outcome: bar.done(case_label((*key[:2], f"{key[2]:g} dt"), outcome)))
    pngs = write_reports(study, out, provenance())
    bad = failures(study)
    print(f"wrote {out / 'loop_closure.md'}, {out / 'loop_closure.json'}" + "".join(f", {p}" for p in pngs))
    runs = sum(len(s.rows) for s in study.scenes)
    print(f"loop-study: {len(study.scenes)} scenes, {runs} runs, {study.wall_s:.0f} s; ideal engines close every loop "
          f"below 1e-9 m and every run ends ok: {not bad}")
    for line in bad:
        print(f"  FAIL {line}")
    return EXIT_OK if not bad else EXIT_FAIL
