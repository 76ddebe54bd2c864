"""Registry of engines: name -> engine object with ``simulate(scene, settings)``."""

from __future__ import annotations

import importlib

from harness.model.errors import InputError

ENGINE_MODULES = {
    "inhouse": "harness.engines.inhouse",
    "mujoco": "harness.engines.mujoco.engine",
    "pinocchio": "harness.engines.pinocchio.engine",
    "exudyn": "harness.engines.exudyn.engine",
    "drake": "harness.engines.drake.engine",
}
ENGINE_NAMES = tuple(ENGINE_MODULES)


def get_engine(name: str):
    """The engine registered under ``name``; InputError if there is none."""
    if name not in ENGINE_MODULES:
        raise InputError(f"unknown engine {name!r} (known: {', '.join(ENGINE_NAMES)})")
    return importlib.import_module(ENGINE_MODULES[name]).ENGINE


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
