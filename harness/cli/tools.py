"""Model-debugging commands of the CLI: ``harness inspect | debug | check``.

``add_parsers(sub)`` adds their subparsers to ``harness.cli.main``'s subparsers object (whose
``parser_class`` turns argparse errors into ``InputError``); ``COMMANDS`` maps each name to its
handler, which takes the parsed arguments and returns the exit code: 0 agreement, 1 a
disagreement beyond tolerance, 2 bad input (raised as ``InputError``; the CLI prints one line).
Heavy modules are imported inside the handlers, as in ``harness.cli.main``.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from harness.cli.arg_types import float_arg as _float, int_arg as _int, csv_list as _csv_list

EXIT_OK, EXIT_FAIL = 0, 1


def _overrides(items: list[str] | None) -> dict[str, str]:
    from harness.model.scene import parse_set

    return dict(parse_set(item) for item in items or [])


def add_parsers(sub) -> None:
    """Add the ``inspect``, ``debug`` and ``check`` subparsers."""
    i = sub.add_parser("inspect", help="what each engine holds after loading a scene; dynamics at random states")
    i.add_argument("scene")
    i.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    i.add_argument("--models-dir", type=Path, help="folder of scene folders (default: the project's models/)")
    i.add_argument("--states", type=_int, default=4, help="random states for the dynamics check (default 4)")
    i.add_argument("--seed", type=_int, default=0, help="seed of the random states (default 0)")

    d = sub.add_parser("debug", help="where two engines' runs of a scene part, per quantity; plot of the errors")
    d.add_argument("scene")
    d.add_argument("--engines", type=_csv_list, required=True, help="two of inhouse, mujoco, pinocchio, reference")
    d.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    d.add_argument("--t-end", type=_float, help="horizon (s; default: the scene's)")
    d.add_argument("--out-dir", type=Path, default=Path("."), help="folder for debug_<scene>_<A>_<B>.png (default: .)")
    d.add_argument("--models-dir", type=Path, help="folder of scene folders (default: the project's models/)")

    c = sub.add_parser("check", help="compare a model (MJCF and/or URDF) between MuJoCo and Pinocchio, write a report")
    c.add_argument("--mjcf", type=Path, help="MJCF file (loaded into MuJoCo; into both when alone)")
    c.add_argument("--urdf", type=Path, help="URDF file (loaded into Pinocchio; into both when alone)")
    c.add_argument("--out-dir", type=Path, default=Path("reports"), help="folder for check_<model>.md (default: reports)")
    c.add_argument("--seed", type=_int, default=0, help="seed of the random states (default 0)")
    c.add_argument("--states", type=_int, default=4, help="random states for the dynamics terms (default 4)")
    c.add_argument("--free-runs", type=_int, default=3, help="free-motion runs from random states (default 3)")
    c.add_argument("--t-end", type=_float, default=0.5, help="free-motion horizon (s, default 0.5)")
    c.add_argument("--dt", type=_float, default=1e-3, help="free-motion step (s, default 0.001)")
    c.add_argument("--floating-base", action="store_true", help="add a free root joint in both engines (default: fixed base)")
    c.add_argument("--strip-geometry", action="store_true",
                   help="delete geoms and meshes from MuJoCo's copy (meshes need not be found; dynamics unchanged)")
    c.add_argument("--keep-static-links", action="store_true",
                   help="turn MuJoCo's fusestatic off (links on fixed joints stay separate bodies)")


def cmd_inspect(args) -> int:
    from harness.tools.inspection import inspect_scene, render
    from harness.model.scene import load_scene

    scene = load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir)
    result = inspect_scene(scene, n_states=args.states, seed=args.seed)
    print(render(result), end="")
    return EXIT_OK if result.passed else EXIT_FAIL


def cmd_debug(args) -> int:
    from harness.tools.debug import debug, parse_engines, summary, write_plot
    from harness.model.scene import load_scene

    engines = parse_engines(args.engines)
    scene = load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir)
    if args.t_end is not None and not (args.t_end > 0):
        from harness.model.errors import InputError

        raise InputError(f"horizon t_end must be positive and finite, got {args.t_end!r}")
    result = debug(scene, engines, args.t_end)
    print("\n".join(summary(result)))
    path = write_plot(result, args.out_dir)
    print(f"wrote {path}")
    return EXIT_OK if result.passed else EXIT_FAIL


def cmd_check(args) -> int:
    from harness.tools.check import run_check, summary_lines, write_report

    result = run_check(args.mjcf, args.urdf, seed=args.seed, n_states=args.states, n_free=args.free_runs,
                       t_end=args.t_end, dt=args.dt, floating_base=args.floating_base, strip=args.strip_geometry,
                       keep_static=args.keep_static_links)
    print("\n".join(summary_lines(result)))
    path = write_report(result, args.out_dir, _command_line(args))
    print(f"wrote {path}")
    return EXIT_OK if result.passed else EXIT_FAIL


def _command_line(args) -> str:
    parts = ["harness", "check"]
    for flag, value in (("--mjcf", args.mjcf), ("--urdf", args.urdf)):
        if value is not None:
            parts += [flag, str(value)]
    parts += ["--seed", str(args.seed), "--states", str(args.states), "--free-runs", str(args.free_runs),
              "--t-end", f"{args.t_end:g}", "--dt", f"{args.dt:g}"]
    parts += [flag for flag, on in (("--floating-base", args.floating_base), ("--strip-geometry", args.strip_geometry),
                                    ("--keep-static-links", args.keep_static_links)) if on]
    return shlex.join(parts)


COMMANDS = {"inspect": cmd_inspect, "debug": cmd_debug, "check": cmd_check}
