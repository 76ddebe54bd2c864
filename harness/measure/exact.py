"""Exact checks: runs judged by their system's closed forms (``references/<scene>.py``).

This module knows no scene. It finds the module ``harness.references.<name>`` by the scene's
name (or by the system its ``builder`` names, for a copy of another scene) and calls the exact
checks it defines; a system's closed forms and the checks that judge runs with
them live together in that one module. What a reference module provides:

* ``EXACT_NEEDS_RUNS`` (bool): True when ``exact_error`` makes runs of its own through ``run``
  (e.g. modal runs from rest at a small amplitude), False when it judges ``traj`` alone.
* ``exact_error(scene, traj, settings, run) -> (value, unit, detail)``: the error of ``traj`` (a
  run of ``scene`` made with ``settings``) against the closed form. ``run(scene, settings) ->
  Trajectory`` is the caller's way to make a run (``validate`` passes the engine's own
  ``simulate``); it is only called when ``EXACT_NEEDS_RUNS`` and may be None otherwise.
* ``exact_error_series(scene, traj) -> ndarray`` (optional, only where no extra run is needed):
  the error per saved sample, which the stress study follows in time; the first paragraph of
  its docstring says what it measures (``series_description``).
* ``exact_reaction(scene, traj) -> (value, detail) | None`` (optional): max over samples of
  |F(t) - F_exact(t)| (N) of the joint reaction force against the exact support force.
* ``published_state(scene, traj) -> dict | None`` (optional): for a system whose source publishes
  a reference state, the run's number of correct digits of it (``{"t": s, "positions": digits,
  "velocities": digits}``), None when it does not apply (other parameters, the time not
  sampled).

``extra_run`` makes one of those extra runs with the caller's ``run``. Generic measurements on
sampled signals (frequencies from zero crossings) are in ``harness.measure.signals``.
"""

from __future__ import annotations

import importlib
from dataclasses import replace
from types import ModuleType
from typing import TYPE_CHECKING, Callable, TypeVar

#: A run's settings, which this module hands on untouched but for their horizon and save
#: interval (``extra_run``): the engines' ``RunSettings`` (a frozen dataclass), a layer above.
Settings = TypeVar("Settings")

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory
    from harness.model.scene import Scene

    Run = Callable[[Scene, Settings], Trajectory]

REFERENCES_PACKAGE = "harness.references"


def _name(scene: "Scene | str") -> str:
    """The system's name: a scene's builder when it names one (a copy of another scene's
    system), else the scene's name; a string is taken as the name."""
    if isinstance(scene, str):
        return scene
    return getattr(scene, "builder", "") or scene.name


def reference_module(scene: "Scene | str") -> ModuleType | None:
    """The module ``harness.references.<scene name>``, or None when there is none (an import
    error inside an existing module propagates)."""
    name = _name(scene)
    if not name.isidentifier():
        return None
    module = f"{REFERENCES_PACKAGE}.{name}"
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name == module:
            return None
        raise


def has_exact_error(scene: "Scene | str") -> bool:
    """Whether the scene's reference module defines ``exact_error``."""
    return callable(getattr(reference_module(scene), "exact_error", None))


def has_error_series(scene: "Scene | str") -> bool:
    """Whether the scene's reference module gives its exact error per sample
    (``exact_error_series``; only checks that need no extra run do)."""
    return callable(getattr(reference_module(scene), "exact_error_series", None))


def declared_floor(scene: "Scene | str"):
    """The floor the scene's closed form declares for its ``exact`` check, where the closed form
    is itself an approximation (a small-oscillation theory, a measured frequency): the
    reference module's ``EXACT_FLOOR = (bound relative to the check's scale, why)``; None where
    it declares none."""
    module = reference_module(scene)
    found = getattr(module, "EXACT_FLOOR", None) if module is not None else None
    return None if found is None else (float(found[0]), str(found[1]))


def needs_runs(scene: "Scene | str") -> bool:
    """Whether the scene's ``exact_error`` makes runs of its own (``EXACT_NEEDS_RUNS``); False
    for a scene without an exact check.

    Raises:
        ValueError: the module defines ``exact_error`` but does not state ``EXACT_NEEDS_RUNS``.
    """
    module = reference_module(scene)
    if not callable(getattr(module, "exact_error", None)):
        return False
    if not hasattr(module, "EXACT_NEEDS_RUNS"):
        raise ValueError(f"{module.__name__} defines exact_error but does not state EXACT_NEEDS_RUNS")
    return bool(module.EXACT_NEEDS_RUNS)


def _function(scene: "Scene | str", what: str) -> Callable:
    name = _name(scene)
    module = reference_module(name)
    if module is None:  # bad input: the scene asks for closed forms nobody wrote (e.g. a scene without code)
        from harness.model.errors import InputError
        from harness.model.scene import CHECKS_WITHOUT_CODE

        where = "" if isinstance(scene, str) else f"{scene.directory / 'scene.toml'}: [checks.exact]: "
        raise InputError(f"{where}no exact check for scene {name!r}: there is no module {REFERENCES_PACKAGE}.{name} "
                         f"(references/{name}.py) with its closed forms; without one a scene can ask for "
                         f"{', '.join(CHECKS_WITHOUT_CODE)}")
    fn = getattr(module, what, None)
    if not callable(fn):
        raise ValueError(f"no exact check for scene {name!r}: references/{name}.py defines no {what}")
    return fn


def exact_error(scene: "Scene", traj: "Trajectory", settings: Settings,
                run: "Run[Settings] | None" = None) -> tuple[float, str, str]:
    """Error of ``traj`` against the scene's closed form: ``(value, unit, detail)`` from the
    scene's reference module (module docstring). ``run`` is needed only where
    ``needs_runs(scene)``.

    Raises:
        InputError: the scene has no reference module (bad input: a ``[checks.exact]`` that
            nothing can judge).
        ValueError: its module has no ``exact_error``, or it needs runs and ``run`` is None.
    """
    fn = _function(scene, "exact_error")
    if run is None and needs_runs(scene):
        raise ValueError(f"the exact check of scene {scene.name!r} makes runs of its own: pass run(scene, settings)")
    return fn(scene, traj, settings, run)


def published_state(scene: "Scene", traj: "Trajectory") -> dict | None:
    """The run's correct digits of its system's published reference state (the reference
    module's optional ``published_state``), None where there is none or it does not apply."""
    fn = getattr(reference_module(scene), "published_state", None)
    return fn(scene, traj) if callable(fn) else None


def exact_error_series(scene: "Scene", traj: "Trajectory"):
    """Per-sample error of ``traj`` against the scene's closed form (an array over the saved
    samples; see ``series_description``).

    Raises:
        ValueError: the scene's reference module has no ``exact_error_series``.
    """
    return _function(scene, "exact_error_series")(scene, traj)


def prepare(scene: "Scene", traj: "Trajectory") -> None:
    """Compute the scene's closed form at the times of ``traj`` in this process (its
    ``exact_error_series``, whose reference modules keep their solutions with
    ``harness.measure.solution_cache``, keyed by the times), so that a run saved at the same
    times is judged without integrating the system again: in this process, in a worker forked
    afterwards, or in one that adopts what ``solution_cache.recording`` collected here (the
    Andrews squeezer's reference DAE: ~7 s a time). Nothing for a scene without a per-sample
    exact error; a failure is left to the checks, which report it."""
    if not has_error_series(scene):
        return
    try:
        exact_error_series(scene, traj)
    except Exception:  # the engines' own exact checks say what is wrong
        pass


def series_description(scene: "Scene | str") -> str:
    """What ``exact_error_series`` measures for the scene: the first paragraph of its docstring
    on one line, without its final full stop ("" when there is none)."""
    fn = getattr(reference_module(scene), "exact_error_series", None)
    doc = (getattr(fn, "__doc__", None) or "").strip()
    return " ".join(doc.split("\n\n")[0].split()).rstrip(".")


def exact_reaction(scene: "Scene", traj: "Trajectory") -> tuple[float, str] | None:
    """Max over samples of |F(t) - F_exact(t)| (N) of the joint reaction force against the
    scene's exact support force, and a detail line; None when the scene's reference module has
    no ``exact_reaction`` or the run carries no reactions."""
    fn = getattr(reference_module(scene), "exact_reaction", None)
    if not callable(fn) or not traj.reactions:
        return None
    return fn(scene, traj)


def extra_run(run: "Run[Settings]", scene: "Scene", settings: Settings, n_saves: int, save: float,
              what: str) -> "Trajectory":
    """An exact check's own run of ``scene``: ``n_saves`` intervals of ``save`` s, at the step,
    integrator and tolerances of ``settings``, made by the caller's ``run``.

    Raises:
        RuntimeError: the run did not reach its horizon (``what`` names it in the message).
    """
    out = run(scene, replace(settings, t_end=n_saves * save, save_every=save))
    if not out.ok:
        raise RuntimeError(f"{what} {out.status}: {out.message}")
    return out
