"""The one definition of each trajectory quantity and its tolerance, shared by ``harness validate``
(``harness.validate.run.check_run``) and ``harness debug`` (``harness.tools.debug``).

A trajectory quantity is a difference between two runs, maximised over bodies (and, for a check,
over the saved samples), in the world frame:

========================  ==============  =====================  ===============  ======================
quantity                  raw unit        scale (motion_scales)  judged as        tolerance key
========================  ==============  =====================  ===============  ======================
``position``              m               ``length`` (m)         rel              ``position``
``orientation``           rad             none                   rad (absolute)   ``orientation``
``velocity``              m/s             ``velocity`` (m/s)     rel              ``velocity``
``angular_velocity``      rad/s           ``angular_velocity``   rel              ``velocity``
========================  ==============  =====================  ===============  ======================

The scales are ``harness.measure.compare.motion_scales`` of the run that judges (in ``validate``
the in-house DOP853 reference). The tolerance is ``[checks.trajectory]`` of the scene: one number
for every engine or a table per engine (``tolerance``). The engine name ``reference`` takes the
in-house engine's tolerances (it is an in-house run).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

REFERENCE_LABEL = "reference"   # the in-house DOP853 run that judges trajectories
REFERENCE_ENGINE = "inhouse"    # the engine it runs on, whose tolerances it takes


@dataclass(frozen=True)
class Quantity:
    """One trajectory quantity (see the module's table).

    Attributes:
        name: ``position``, ``orientation``, ``velocity`` or ``angular_velocity``; the check is
            ``trajectory.<name>`` and ``compare.trajectory_error`` gives ``<name>_max``.
        unit: unit of the raw difference.
        scale: key of ``compare.motion_scales`` the difference is divided by, None for absolute.
        tolerance_key: key of the scene's ``[checks.trajectory]`` table.
        what: what is measured, for the report.
    """

    name: str
    unit: str
    scale: str | None
    tolerance_key: str
    what: str

    @property
    def check(self) -> str:
        """The check's name in validate's reports."""
        return f"trajectory.{self.name}"

    @property
    def judged_unit(self) -> str:
        """Unit of the judged value: ``rel`` when scaled, else the raw unit."""
        return "rel" if self.scale else self.unit

    def judged(self, raw: Any, scales: Mapping[str, float]) -> Any:
        """The judged value(s) of a raw difference (a number or an array): raw / scale, or raw."""
        return raw / scales[self.scale] if self.scale else raw

    def detail(self, raw_max: float, scales: Mapping[str, float]) -> str:
        """The note of a check with largest raw difference ``raw_max``."""
        if self.scale is None:
            return f"max over bodies and samples; {self.what}"
        s = scales[self.scale]
        return f"{raw_max:.2e} {self.unit} over {self.scale} scale {s:.3g} {self.unit}; {self.what}"


TRAJECTORY = (
    Quantity("position", "m", "length", "position", "centre of mass"),
    Quantity("orientation", "rad", None, "orientation", "geodesic angle on SO(3)"),
    Quantity("velocity", "m/s", "velocity", "velocity", "centre-of-mass velocity"),
    Quantity("angular_velocity", "rad/s", "angular_velocity", "velocity", "world frame"),
)
BY_NAME = {q.name: q for q in TRAJECTORY}


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
