"""Registry of engines: the one place that names them.

``DECLARATIONS`` holds what each engine declares (``Declaration``): its name, how reports write
it, where its ``ENGINE`` lives, the library whose version the provenance records, the model files
it reads, what it can hold (loops, rolling contact), its role (the reference engine, compiled
twins) and its work-precision curves. Everything outside ``harness/engines/`` asks this module
(``get_engine``, ``declaration``, ``display``, the capability lists) instead of naming an engine;
``tests/engines/test_engine_names.py`` fails on an engine name in code elsewhere. An engine's
``ENGINE`` object holds its integrators (``integrators``, ``Integrator`` records of
``harness.engines.base``) and ``simulate``, and optionally the hooks the functions here call:
``preload()``, ``load_model_file(scene, model)``, ``fast_method(method, model)``,
``prepare(runs)``, ``accelerations(scene, model, q, v, t)``.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from harness.model.errors import InputError

MJCF, URDF = "mjcf", "urdf"  # the model file formats (a scene's ``mjcf`` and ``urdf`` files)
IDEAL, SOFT = "ideal", "soft"  # how an engine holds a loop or a rolling contact


@dataclass(frozen=True)
class SweepCurve:
    """One work-precision curve an engine declares (``harness workprecision``): an integrator
    of its ``integrators``, a variant (what the point's time covers; "" for the engine's
    ``simulate``) and how the plot draws it."""

    integrator: str
    variant: str = ""
    colour: str = "black"
    dashed: bool = False


@dataclass(frozen=True)
class Declaration:
    """What one engine declares: all the harness needs to know about it without running it.

    Attributes:
        name: the registered name: ``--engine``, the keys of a scene's per-engine tables
            (``[integrators]``, ``[not_run]``, ``[model_differences.<engine>]``), the reports' keys.
        display: how reports and help texts write it ("MuJoCo", "in-house").
        module: the module whose ``ENGINE`` is the engine (imported on first use).
        library: the Python module whose version the provenance records ("" for none: the
            engine is this repository's code).
        distribution: the installed distribution whose version counts where ``library`` has no
            ``__version__`` ("" for ``library``).
        reads: the model file formats it reads, its own first (``MJCF``, ``URDF``): a loader of
            model files; empty for an engine that builds the system from the scene's description.
            A scene that names one file only is read in the other format (``reads_other_format``).
        preflight: whether ``harness validate`` loads the file in its own format before any run
            (``load_model_file``); False where its runs load it anyway and loading costs (Drake).
        loops: how it closes a kinematic loop (``Multibody.loops``): ``IDEAL`` (constraint rows),
            ``SOFT`` (soft constraints with settings), "" (it does not: loop scenes do not run it,
            with ``without_loops``).
        loops_how: one phrase on how it states a loop's cut joints (the loop study's report).
        rolling: how it holds a rolling contact: ``IDEAL`` (the rolling constraint), ``SOFT``
            (frictional soft contact), "" (it does not).
        without_loops, without_rolling: why it does not run a scene with a loop (``loops`` "")
            or a rolling contact (``rolling`` ""): the scene's not-run reason (``why_not``), so
            that no scene names the engine for it.
        default_integrator: the integrator a scene runs it with where the scene's
            ``[integrators]`` names none.
        free_integrator: the default for a scene of free bodies only (no constrained joint, loop
            or contact) where it differs ("" for ``default_integrator``).
        reference: the engine whose high-accuracy run judges every other (one engine).
        compiled: it has compiled twins of its methods (``fast_method``, ``prepare``;
            ``--fast``, ``--per-state``).
        cost_per_step: a rough wall time per step (s), to start the longest runs first.
        colour: its colour in validate's figures.
        linestyle: how the stress study's figures draw its lines (matplotlib's ``ls``).
        curves: its work-precision curves.
        accelerations: it gives the bodies' accelerations at a given joint state (its
            ``accelerations`` hook: ``harness.engines.accelerations``, which
            ``harness.engines.linearization`` differentiates).
    """

    name: str
    display: str
    module: str
    library: str = ""
    distribution: str = ""
    reads: tuple[str, ...] = ()
    preflight: bool = True
    loops: str = ""
    loops_how: str = ""
    rolling: str = ""
    without_loops: str = ""
    without_rolling: str = ""
    default_integrator: str = ""
    free_integrator: str = ""
    reference: bool = False
    compiled: bool = False
    cost_per_step: float = 1e-4
    colour: str = ""
    linestyle: str = "-"
    curves: tuple[SweepCurve, ...] = ()
    accelerations: bool = False

    def why_not(self, model) -> str:
        """Why the engine does not run a scene whose system is ``model`` (a ``Multibody``): a
        loop or a rolling contact it cannot hold (``without_loops``, ``without_rolling``); ""
        when it runs it."""
        if getattr(model, "loops", ()) and not self.loops:
            return self.without_loops
        if getattr(model, "contacts", ()) and not self.rolling:
            return self.without_rolling
        return ""

    def integrator_for(self, model) -> str:
        """Its default integrator on ``model`` (``default_integrator``; ``free_integrator`` for a
        system of free bodies only)."""
        from harness.model.joints import JOINTS

        free = not (getattr(model, "loops", ()) or getattr(model, "contacts", ())
                    or any(JOINTS[b.joint].constrained for b in model.bodies))
        return (self.free_integrator if free and self.free_integrator else "") or self.default_integrator


_NO_LOOP_CONSTRAINT = ("{engine}'s {what} has no loop-closing constraint and a URDF cannot state a loop: a loop scene "
                       "would run a different model")
_NO_ROLLING_CONSTRAINT = ("{engine} has no ideal rolling constraint: its contact is {what}, so it would run a different "
                          "model, as MuJoCo's soft contact does")


def _curves(variants: tuple[str, ...], colours: dict[str, str], dashed: tuple[str, ...] = ()) -> tuple[SweepCurve, ...]:
    """One curve per integrator of ``colours`` and variant of ``variants`` (dashed: the variants
    in ``dashed``, or every curve with ``dashed = ("",)``)."""
    return tuple(SweepCurve(m, v, c, v in dashed or "" in dashed) for m, c in colours.items() for v in variants)


_REFERENCE_CURVES = (  # the per-state oracle and the compiled twins
    SweepCurve("rk4", "per-state", "salmon", True), SweepCurve("euler", "per-state", "rosybrown", True),
    SweepCurve("RK45", "per-state", "tab:pink", True), SweepCurve("DOP853", "per-state", "tab:orange", True),
    SweepCurve("rk4_compiled", "compiled", "magenta"), SweepCurve("rkmk4_compiled", "compiled", "darkred"),
    SweepCurve("dop853_compiled", "compiled", "tab:brown"),
)

DECLARATIONS: tuple[Declaration, ...] = (
    Declaration("inhouse", "in-house", "harness.engines.inhouse", loops=IDEAL,
                loops_how="the cut joint's rows in the KKT system and a projection after each step", rolling=IDEAL,
                default_integrator="rk4", reference=True,
                compiled=True, cost_per_step=4e-4, colour="#1f77b4", curves=_REFERENCE_CURVES, accelerations=True),
    Declaration("mujoco", "MuJoCo", "harness.engines.mujoco.engine", library="mujoco", reads=(MJCF, URDF),
                loops=SOFT, loops_how="`<connect>` equalities, soft constraints", rolling=SOFT, default_integrator="RK4",
                cost_per_step=1e-5, colour="#d62728",
                linestyle="--",
                curves=_curves(("rollout", "loop"), {"Euler": "tab:cyan", "implicit": "tab:purple",
                                                     "implicitfast": "tab:olive", "RK4": "tab:blue"}, ("loop",))),
    Declaration("pinocchio", "Pinocchio", "harness.engines.pinocchio.engine", library="pinocchio", reads=(URDF, MJCF),
                loops=IDEAL, loops_how="`constraintDynamics` and a projection", rolling=IDEAL, default_integrator="rkmk4",
                cost_per_step=2e-4, colour="#2ca02c",
                curves=_curves(("",), {"rkmk4": "tab:green", "euler": "yellowgreen"}, ("",)), accelerations=True),
    Declaration("exudyn", "Exudyn", "harness.engines.exudyn.engine", library="exudyn", loops=IDEAL,
                loops_how="the index-3 DAE with generalized-α", rolling=IDEAL,
                default_integrator="GeneralizedAlpha",  # index-3 DAE, order 2
                free_integrator="RK44",  # explicit, Lie-group rotation-vector nodes: free bodies need no constraint
                colour="#ff7f0e",
                curves=_curves(("",), {"GeneralizedAlpha": "teal", "TrapezoidalIndex2": "darkslateblue",
                                       "RK44": "steelblue", "RK67": "navy"})),
    Declaration("drake", "Drake", "harness.engines.drake.engine", library="pydrake", distribution="drake",
                reads=(URDF, MJCF), preflight=False,
                without_loops=_NO_LOOP_CONSTRAINT.format(engine="Drake", what="continuous-time MultibodyPlant (its ball, "
                                                         "distance and weld constraints need a discrete SAP plant)"),
                without_rolling=_NO_ROLLING_CONSTRAINT.format(engine="Drake", what="compliant (hydroelastic or point "
                                                              "contact with regularised friction)"),
                default_integrator="RK5",  # Dormand-Prince 5(4), error-controlled at base.ERROR_CONTROL_TOL
                colour="#9467bd",
                curves=_curves(("",), {"RK3": "dimgray", "RK5": "black", "Radau3": "darkgoldenrod",
                                       "RK3_fixed": "silver", "RK2": "tan"})),
    Declaration("pybullet", "PyBullet", "harness.engines.pybullet.engine", library="pybullet", distribution="pybullet",
                reads=(URDF,),
                without_loops=_NO_LOOP_CONSTRAINT.format(engine="PyBullet", what="btMultiBody (a tree in reduced "
                                                         "coordinates; its point-to-point constraints are soft, solved "
                                                         "by its iterative constraint solver)"),
                without_rolling=_NO_ROLLING_CONSTRAINT.format(engine="PyBullet", what="a frictional contact solved by "
                                                              "impulses (with penetration correction)"),
                default_integrator="semi_implicit_euler_16",  # stepSimulation at dt/16: semi-implicit Euler, order 1
                colour="#8c564b", linestyle=":",
                curves=_curves(("",), {"semi_implicit_euler": "sienna"})),
)
ENGINES = {d.name: d for d in DECLARATIONS}
ENGINE_MODULES = {d.name: d.module for d in DECLARATIONS}
ENGINE_NAMES = tuple(ENGINES)
#: The engine whose high-accuracy run judges every other (``harness.judging.checks``).
REFERENCE_ENGINE = next(d.name for d in DECLARATIONS if d.reference)
#: The engines that read model files (MJCF, URDF): the loaders ``check`` and ``inspect`` compare.
LOADERS = tuple(d.name for d in DECLARATIONS if d.reads)
#: The engines with compiled twins of their methods (``--fast``, ``--per-state``).
COMPILED_ENGINES = tuple(d.name for d in DECLARATIONS if d.compiled)


def declaration(name: str) -> Declaration:
    """What engine ``name`` declares; InputError if there is none."""
    if name not in ENGINES:
        raise InputError(f"unknown engine {name!r} (known: {', '.join(ENGINE_NAMES)})")
    return ENGINES[name]


def display(name: str) -> str:
    """How reports write engine ``name`` ("MuJoCo", "in-house"); a name the registry does not
    know (``reference``, a study's variant) as it is."""
    return ENGINES[name].display if name in ENGINES else name


def with_loops(kind: str) -> tuple[str, ...]:
    """The engines holding a kinematic loop as ``kind`` (``IDEAL`` or ``SOFT``), in registry order."""
    return tuple(d.name for d in DECLARATIONS if d.loops == kind)


def with_rolling(kind: str) -> tuple[str, ...]:
    """The engines holding a rolling contact as ``kind`` (``IDEAL`` or ``SOFT``), in registry order."""
    return tuple(d.name for d in DECLARATIONS if d.rolling == kind)


def get_engine(name: str):
    """The engine registered under ``name``; InputError if there is none."""
    return importlib.import_module(declaration(name).module).ENGINE


def engine_module(name: str, part: str):
    """Module ``part`` of engine ``name``'s package (``harness.engines.<name>.<part>``): for a
    study that is about one engine's own settings and names it in one constant (the rolling
    study's contact settings, the loop study's soft loop settings, the work-precision study's
    baseline) or about the reference engine's compiled form."""
    declaration(name)
    return importlib.import_module(f"{__name__}.{name}.{part}" if part else f"{__name__}.{name}")


def integrator(engine: str, method: str):
    """The ``Integrator`` record of ``method`` on ``engine``; InputError if either is unknown."""
    table = get_engine(engine).integrators
    if method not in table:
        raise InputError(f"unknown integrator {method!r} for engine {engine} (known: {', '.join(table)})")
    return table[method]


def preload(engines) -> None:
    """Import, in a parent about to fork one worker per run, what each of ``engines`` would
    import at its first run (an engine's optional ``preload()``: Drake's pydrake modules), so
    that the forked workers start with it. An engine that is not installed is left to its runs
    to report (its ImportError here is ignored)."""
    for name in engines:
        hook = getattr(get_engine(name), "preload", None)
        if hook is not None:
            try:
                hook()
            except ImportError:
                pass


def fast_method(engine: str, method: str, model) -> str:
    """The method a fast run of ``engine``'s ``method`` takes on ``model`` (a ``Multibody``): its
    compiled twin where the engine has one that models ``model`` (the engine's ``fast_method``),
    else ``method``."""
    hook = getattr(get_engine(engine), "fast_method", None) if declaration(engine).compiled else None
    return method if hook is None else hook(method, model)


def run_method(engine: str, method: str | None, scene, fast: bool = True) -> str | None:
    """The method a run of ``engine`` takes for ``method`` on ``scene``: with ``fast``, its
    compiled twin where the engine has one that models the scene (``fast_method``), as validate,
    the stress map and the loop study run it; otherwise ``method`` itself (None, a scene that
    names no method, stays None). The scene's model is built only for an engine with compiled
    twins."""
    if method is None or not fast or not declaration(engine).compiled:
        return method
    return fast_method(engine, method, scene.multibody())


def prepare(engine: str, runs) -> None:
    """Before forking workers that make ``engine``'s ``runs`` (``(method, Multibody)`` pairs):
    what its runs would each load at their start, loaded once here (the compiled kernels of an
    engine with compiled twins, announced when Numba's cache does not hold them; the engine's
    ``prepare``). Nothing for an engine without compiled twins."""
    if declaration(engine).compiled:
        hook = getattr(get_engine(engine), "prepare", None)
        if hook is not None:
            hook(list(runs))


def accelerations(engine: str, scene, model, q, v, t: float = 0.0) -> tuple[dict, dict]:
    """Each body's centre-of-mass acceleration (m/s^2) and angular acceleration (rad/s^2), world
    frame, per body name, as ``engine``'s dynamics give them at joint coordinates ``q, v`` (per
    body name, ``harness.model.joints``; on the constraints) and time ``t`` (s) of ``scene``'s
    system ``model`` (its ``Multibody``): the engine's ``accelerations`` hook, a run's
    right-hand side at that state (``harness.engines.linearization`` differentiates it).
    NotImplementedError for an engine without the hook, or a system it does not cover there."""
    if not declaration(engine).accelerations:
        raise NotImplementedError(f"{display(engine)} gives no accelerations at a given state (it only runs scenes)")
    return get_engine(engine).accelerations(scene, model, q, v, t)


def with_accelerations() -> tuple[str, ...]:
    """The engines that give their accelerations at a given state (``Declaration.accelerations``),
    in registry order."""
    return tuple(d.name for d in DECLARATIONS if d.accelerations)


def reads_other_format(scene, engine: str) -> bool:
    """Whether ``engine`` reads ``scene``'s one model file in the format it does not usually
    read (a loader of MJCF given only a URDF, or the reverse: ``Declaration.reads``). Such an
    engine that cannot read the file is not run (``harness.cli.main.preflight``)."""
    reads = declaration(engine).reads
    return bool(reads) and reads[0] not in scene.model_files


def model_file(scene, engine: str):
    """The file of ``scene`` that ``engine`` reads (``scene.mjcf`` or ``scene.urdf``: the scene's
    one file where it names one only), or its ``scene.toml`` for an engine that reads none."""
    reads = declaration(engine).reads
    if not reads:
        return scene.directory / "scene.toml"
    return scene.mjcf if reads[0] == MJCF else scene.urdf


def load_model_file(scene, engine: str, model) -> None:
    """Load ``scene``'s file as ``engine``'s runs do, with ``model`` (its ``Multibody``): InputError
    or NotImplementedError where the engine cannot read it (the engine's ``load_model_file``)."""
    get_engine(engine).load_model_file(scene, model)


def check_scene(scene):
    """``scene`` (returned) completed from the engines' declarations: an engine that cannot hold
    its system (``Declaration.why_not``: a loop, a rolling contact) marked not run with its
    declared reason, and every other engine given its default integrator
    (``Declaration.integrator_for``) where the scene's ``[integrators]`` names none. InputError
    naming the ``scene.toml`` when its per-engine tables name an unregistered engine
    (``harness.model.scene.check_engine_tables``)."""
    from harness.model.scene import check_engine_tables

    model = scene.multibody()
    for d in DECLARATIONS:
        why = "" if d.name in scene.not_run else d.why_not(model)
        if why:
            scene.mark_not_run(d.name, why)
    scene.default_integrators({d.name: d.integrator_for(model) for d in DECLARATIONS if d.name not in scene.not_run})
    check_engine_tables(scene, ENGINE_NAMES)
    against = [c for c in AGAINST_REFERENCE_RUN if c in scene.checks]
    if REFERENCE_ENGINE in scene.not_run and against:
        raise InputError(f"{scene.directory / 'scene.toml'}: [checks.{against[0]}] is judged against the reference run, "
                         f"and [not_run] says its engine ({REFERENCE_ENGINE}) does not run this scene: judge it by its "
                         "closed form ([checks.exact]) instead")
    return scene


def integrator_of(scene, engine: str) -> str:
    """The integrator ``engine`` runs ``scene`` with: the scene's ``[integrators]`` entry, else the
    engine's declared default on its system (also for an engine the scene does not run, for
    tools that read what it would hold: ``harness inspect``)."""
    return scene.integrators.get(engine) or declaration(engine).integrator_for(scene.multibody())


#: The checks judged against the reference run (``harness.judging.checks``): a scene whose
#: ``[not_run]`` names the reference engine gets no reference run and may declare none of them.
AGAINST_REFERENCE_RUN = ("trajectory", "contact_force")


def load_scene(name: str, overrides=None, *, models_dir=None):
    """Scene ``name`` as the engines run it: ``harness.model.scene.load_scene`` (the parameter
    ``overrides``, the ``models_dir``) completed by ``check_scene``."""
    from harness.model.scene import load_scene as load

    return check_scene(load(name, overrides, models_dir=models_dir))


def version(name: str) -> str:
    """The installed version of engine ``name``'s library (its ``__version__``, else its
    distribution's; "?" where neither tells); "" for an engine without one."""
    d = declaration(name)
    if not d.library:
        return ""
    if d.distribution:   # the distribution's own record: no import (PyBullet's prints a banner; pydrake has no __version__)
        from importlib.metadata import PackageNotFoundError, version as dist_version

        try:
            return dist_version(d.distribution)
        except PackageNotFoundError:
            pass
    value = getattr(importlib.import_module(d.library), "__version__", None)
    if value:
        return str(value)
    from importlib.metadata import PackageNotFoundError, version as dist_version

    try:
        return dist_version(d.distribution or d.library)
    except PackageNotFoundError:
        return "?"


def versions() -> dict[str, str]:
    """``{engine: version}`` of every engine with a library, in registry order."""
    return {d.name: version(d.name) for d in DECLARATIONS if d.library}


def provenance() -> dict[str, str]:
    """``harness.io.provenance.provenance`` with the engines' versions (``versions``)."""
    from harness.io.provenance import provenance as base

    return base(versions())


def made_with(prov: dict[str, str]) -> str:
    """``harness.io.provenance.made_with`` naming the engines as the reports write them."""
    from harness.io.provenance import made_with as base

    return base(prov, {d.name: d.display for d in DECLARATIONS if d.library})
