"""The tolerance of each trajectory quantity, shared by ``harness validate``
(``harness.validate.run.check_run``) and ``harness debug`` (``harness.tools.debug``).

The quantities themselves (name, unit, relative or absolute, scale, how computed) are defined
once in ``harness.measure.quantities`` (``Quantity``, ``TRAJECTORY``, ``BY_NAME``, re-exported
here), where the stress and work-precision studies take them too.

Each quantity's tolerance is the entry ``Quantity.tolerance_key`` of the scene's
``[checks.trajectory]`` table: ``position``, ``orientation``, ``velocity``, and ``velocity`` again
for ``angular_velocity``; it bounds the judged value (rel, or rad for the orientation).

The scales are ``harness.measure.compare.motion_scales`` of the run that judges (in ``validate``
the in-house DOP853 reference). The table's entries are one number for every engine or a table
per engine (``tolerance``). The engine name ``reference`` takes the
in-house engine's tolerances (it is an in-house run).
"""

from __future__ import annotations

from typing import Any, Mapping

from harness.measure.quantities import BY_NAME, TRAJECTORY, Quantity

__all__ = ["BY_NAME", "REFERENCE_ENGINE", "REFERENCE_LABEL", "TRAJECTORY", "Quantity", "check_table", "per_engine",
           "regression_only", "tolerance", "tolerance_engine"]

REFERENCE_LABEL = "reference"   # the in-house DOP853 run that judges trajectories
REFERENCE_ENGINE = "inhouse"    # the engine it runs on, whose tolerances it takes


def tolerance_engine(engine: str) -> str:
    """The engine whose tolerances a run takes (``reference`` -> the in-house engine)."""
    return REFERENCE_ENGINE if engine == REFERENCE_LABEL else engine


def per_engine(tol: Any, engine: str) -> float | None:
    """A tolerance given for all engines (a number) or per engine (a table of numbers); None
    when the table has no entry for the engine."""
    if isinstance(tol, Mapping):
        value = tol.get(tolerance_engine(engine))
        return None if value is None else float(value)
    return None if tol is None else float(tol)


def tolerance(checks: Mapping[str, Any], quantity: Quantity, engine: str) -> float | None:
    """The tolerance of ``quantity`` for ``engine``'s run against the reference, from the scene's
    ``checks`` (``Scene.checks``); None when the scene sets none."""
    table = checks.get("trajectory")
    if not table:
        return None
    return per_engine(table.get(quantity.tolerance_key), engine)


def check_table(check: str) -> str:
    """The ``[checks.<table>]`` of the scene that holds a check's tolerance (``trajectory.position``
    -> ``trajectory``, ``energy_balance`` -> ``energy_drift``)."""
    head = check.split(".", 1)[0]
    return "energy_drift" if head == "energy_balance" else head


def regression_only(scene: str, checks: Mapping[str, Any], check: str, engine: str) -> bool:
    """Whether ``check``'s tolerance for ``engine`` in ``scene`` is a regression bound (what the
    engine reaches, with a margin, not what the physics demands, e.g. MuJoCo's soft contact on the
    rolling disk): the scene's ``[checks.<table>]`` lists the engine in ``regression_only``, e.g.
    ``regression_only = ["mujoco"]``. Checks without a table of the scene (``engine_energy``,
    ``model.*``, ``run``) never are. ``scene`` names the scene for messages only."""
    table = checks.get(check_table(check))
    if not isinstance(table, Mapping):
        return False
    engine = tolerance_engine(engine)
    listed = table.get("regression_only", ())
    if isinstance(listed, str):
        listed = (listed,)
    return isinstance(listed, (list, tuple)) and engine in listed
