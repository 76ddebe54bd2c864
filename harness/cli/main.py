"""Command-line interface: ``harness scenes | simulate | validate``.

Exit codes: 0 success (for ``validate``: every check holds), 1 a check fails, 2 bad input or a
model that will not load (one line on stderr, no traceback, no report touched).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from harness.cli import rolling as cli_rolling
from harness.cli import stress as cli_stress
from harness.cli import tools as cli_tools
from harness.cli import workprecision as cli_workprecision
from harness.model.errors import InputError
from harness.cli.arg_types import float_arg as _float, csv_list as _csv_list

EXIT_OK, EXIT_FAIL, EXIT_INPUT = 0, 1, 2


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error and exit code 2."""

    def error(self, message: str):  # noqa: D401 - argparse API
        raise InputError(message)


def _overrides(items: list[str] | None) -> dict[str, str]:
    from harness.model.scene import parse_set

    return dict(parse_set(item) for item in items or [])


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="harness", description="Cross-check rigid-body dynamics: in-house, MuJoCo, Pinocchio.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    sub.add_parser("scenes", help="list the scenes with their parameters")

    s = sub.add_parser("simulate", help="run one scene on one engine, write the common trajectory as CSV")
    s.add_argument("scene")
    s.add_argument("--engine", required=True)
    s.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a scene parameter (repeatable)")
    s.add_argument("--t-end", type=_float)
    s.add_argument("--dt", type=_float)
    s.add_argument("--integrator")
    s.add_argument("--save-every", type=_float)
    s.add_argument("--rtol", type=_float, default=1e-10)
    s.add_argument("--atol", type=_float, default=1e-12)
    s.add_argument("--out", required=True, type=Path)
    s.add_argument("--models-dir", type=Path, help="folder of scene folders (default: the project's models/)")

    v = sub.add_parser("validate", help="run every scene on every engine, check, write reports/")
    v.add_argument("--scenes", type=_csv_list, help="comma-separated scene names (default: all)")
    v.add_argument("--engines", type=_csv_list, help="comma-separated engines (default: all)")
    v.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a parameter in every selected scene that has it")
    v.add_argument("--out-dir", type=Path, default=Path("reports"))
    v.add_argument("--models-dir", type=Path, help="folder of scene folders (default: the project's models/)")
    v.add_argument("--tolerances", type=Path, help="TOML file tightening or loosening checks per scene and quantity")
    v.add_argument("--jobs", type=int, default=0, help="worker processes (default: all cores)")
    v.add_argument("--timeout", type=_float, default=300.0, help="seconds allowed per scene x engine case")
    cli_tools.add_parsers(sub)  # inspect, debug, check
    cli_workprecision.add_parser(sub)
    cli_stress.add_parser(sub)
    cli_rolling.add_parser(sub)
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
    from harness.io import atomic
    from harness.engines import get_engine
    from harness.engines.base import RunSettings
    from harness.model.scene import load_scene
    from harness.io.trajectory_csv import to_frame

    scene = load_scene(args.scene, _overrides(args.set), models_dir=args.models_dir)
    engine = get_engine(args.engine)
    settings = RunSettings(
        t_end=args.t_end if args.t_end is not None else scene.t_end,
        dt=args.dt if args.dt is not None else scene.dt,
        save_every=args.save_every if args.save_every is not None else scene.save_every,
        integrator=args.integrator or scene.integrators[args.engine],
        rtol=args.rtol,
        atol=args.atol,
    )
    if args.engine not in scene.integrators:
        raise InputError(f"scene {scene.name!r} has no default integrator for {args.engine}")
    traj = engine.simulate(scene, settings)
    frame = to_frame(traj, scene.multibody())
    atomic.write_text(args.out, frame.to_csv(index=False))
    print(f"{args.out}: {len(frame)} samples, {traj.engine}/{traj.integrator}, status {traj.status}"
          + (f" ({traj.message})" if traj.message else ""))
    return EXIT_OK if traj.ok else EXIT_FAIL


def preflight(scene) -> None:
    """Reject non-physical parameters and models that do not load, before any run."""
    from harness.engines.mujoco.model import load_mjcf
    from harness.engines.pinocchio.model import load_urdf

    model = scene.multibody()
    load_mjcf(scene.mjcf, model)
    load_urdf(scene.urdf, scene.urdf_root_joint, model)


def cmd_validate(args) -> int:
    from harness.engines import ENGINE_NAMES, get_engine
    from harness.io.provenance import provenance
    from harness.validate.report import write_reports
    from harness.model.scene import available_scenes, load_scene
    from harness.validate.tolerances import apply_tolerances, check_scenes_known, read_tolerances
    from harness.validate.run import validate

    names = args.scenes or available_scenes(args.models_dir)
    engines = args.engines or list(ENGINE_NAMES)
    for e in engines:
        get_engine(e)
    overrides = _overrides(args.set)
    scenes = []
    for name in names:
        scene = load_scene(name, models_dir=args.models_dir)
        own = {k: v for k, v in overrides.items() if k in scene.parameters}
        scenes.append(scene.with_params(**own))
    unused = set(overrides) - {k for s in scenes for k in s.parameters}
    if unused:
        raise InputError(f"unknown parameter {sorted(unused)[0]!r} for the selected scenes")
    changes = {}
    if args.tolerances is not None:
        table = read_tolerances(args.tolerances)
        check_scenes_known(table, available_scenes(args.models_dir), args.tolerances)
        for i, scene in enumerate(scenes):
            scenes[i], changes[scene.name] = apply_tolerances(scene, table, args.tolerances)
    if not (args.timeout > 0):
        raise InputError(f"--timeout must be positive, got {args.timeout!r}")
    for scene in scenes:
        preflight(scene)
    results = validate(scenes, engines, jobs=args.jobs or None, timeout=args.timeout, tolerance_changes=changes)
    for result in results:
        bad = sum(not c.passed for c in result.checks)
        print(f"{result.scene}: {'PASS' if result.passed else 'FAIL'} ({len(result.checks) - bad}/{len(result.checks)} checks hold)")
        for c in result.checks:
            if not c.passed:
                print(f"  FAIL {c.engine} {c.check}: {c.value:.3e} > {c.tolerance:.1e} {c.unit} {c.detail}")
    paths = write_reports(results, provenance(), args.out_dir)
    print("wrote " + ", ".join(str(p) for p in paths))
    return EXIT_OK if all(r.passed for r in results) else EXIT_FAIL


COMMANDS = {"scenes": cmd_scenes, "simulate": cmd_simulate, "validate": cmd_validate}
COMMANDS.update(cli_tools.COMMANDS)
COMMANDS["workprecision"] = cli_workprecision.run
COMMANDS["stress"] = cli_stress.run
COMMANDS["rolling-study"] = cli_rolling.run


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return COMMANDS[args.command](args)
    except InputError as err:
        print(f"harness: error: {err}", file=sys.stderr)
        return EXIT_INPUT
    except KeyboardInterrupt:
        print("harness: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
