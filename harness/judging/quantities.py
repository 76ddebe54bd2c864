"""The one definition of each trajectory quantity: name, unit, relative or absolute, its scale, and
how it is computed. Shared by ``harness validate`` (its ``trajectory.*`` checks,
``harness.judging.checks.check_run``), ``harness debug`` (``harness.tools.debug``), the stress study
(its ``position`` ... ``angular_velocity`` bands, ``harness.studies.stress.run``) and the
work-precision study (its state error, ``harness.studies.workprecision.run``). No tolerance is
here: validate and debug judge each quantity by how its error converges (``harness.judging``), the
stress study by its catalogue's bands.

A trajectory quantity is a difference between a run and the run that judges it, at each saved
sample both reached, maximised over bodies (world frame):

========================  ==========  =====================  ===============
quantity                  raw unit    scale (motion_scales)  judged as
========================  ==========  =====================  ===============
``position``              m           ``length`` (m)         rel
``orientation``           rad         none                   rad (absolute)
``velocity``              m/s         ``velocity`` (m/s)     rel
``angular_velocity``      rad/s       ``angular_velocity``   rel
========================  ==========  =====================  ===============

``position``: |p_WCm_W(a) - p_WCm_W(b)| of each body's centre of mass; ``orientation``: the
geodesic angle on SO(3) between the two body->world orientations; ``velocity``: the difference of
the centre-of-mass velocities; ``angular_velocity``: the difference of the world-frame angular
velocities. The scales are ``harness.measure.compare.motion_scales`` of the judging run (validate,
debug with ``reference``, both studies: the in-house DOP853 reference).

The *state error* (``state_error``) is the largest judged trajectory quantity: the work-precision
study's ``state_*`` error and the stress study's error of kind ``trajectory``.

Energy is deliberately not one shared quantity: each tool asks a different question and says
which in its own docstring (validate: drift |E(t) - E(0)| over ``compare.energy_scale``; stress:
drift over an initial-state scale, a stability bound; work-precision and debug: the difference
|E_a - E_b| to the other run over ``compare.energy_scale``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from harness.model import rotations

if TYPE_CHECKING:  # pragma: no cover
    from harness.measure.trajectory import Trajectory


@dataclass(frozen=True)
class Quantity:
    """One trajectory quantity (see the module's table).

    Attributes:
        name: ``position``, ``orientation``, ``velocity`` or ``angular_velocity``; validate's check
            is ``trajectory.<name>``, ``compare.trajectory_error`` gives ``<name>_max``, the
            stress catalogue's band and the work-precision study use the same name.
        unit: unit of the raw difference.
        scale: key of ``compare.motion_scales`` the difference is divided by, None for absolute.
        what: what is measured, for the report.
    """

    name: str
    unit: str
    scale: str | None
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
    Quantity("position", "m", "length", "centre of mass"),
    Quantity("orientation", "rad", None, "geodesic angle on SO(3)"),
    Quantity("velocity", "m/s", "velocity", "centre-of-mass velocity"),
    Quantity("angular_velocity", "rad/s", "angular_velocity", "world frame"),
)
BY_NAME = {q.name: q for q in TRAJECTORY}
NAMES = tuple(q.name for q in TRAJECTORY)


def raw_series(a: Trajectory, b: Trajectory, n: int | None = None) -> dict[str, np.ndarray]:
    """The raw difference of each trajectory quantity at each of the first ``n`` samples (default:
    all both have), maximised over bodies: ``{name: (n,) array}`` in the raw units (m, rad, m/s,
    rad/s; world frame). The samples are taken index by index: ``a`` and ``b`` must be saved at
    the same times (``compare.trajectory_error`` checks that; a caller subsampling a finer run
    passes the subsampled one)."""
    n = min(len(a.t), len(b.t)) if n is None else int(n)
    with np.errstate(invalid="ignore", over="ignore"):
        return {
            "position": np.linalg.norm(a.p_WCm_W[:n] - b.p_WCm_W[:n], axis=-1).max(axis=1, initial=0.0),
            "orientation": rotations.geodesic_angle(a.quat_WB[:n], b.quat_WB[:n]).max(axis=1, initial=0.0),
            "velocity": np.linalg.norm(a.v_WCm_W[:n] - b.v_WCm_W[:n], axis=-1).max(axis=1, initial=0.0),
            "angular_velocity": np.linalg.norm(a.w_WB_W[:n] - b.w_WB_W[:n], axis=-1).max(axis=1, initial=0.0),
        }


def judged_series(a: Trajectory, b: Trajectory, scales: Mapping[str, float],
                  n: int | None = None) -> dict[str, np.ndarray]:
    """``raw_series`` judged (``Quantity.judged``: over ``scales``, or absolute): ``{name: (n,)}``
    in each quantity's ``judged_unit``."""
    raw = raw_series(a, b, n)
    return {q.name: q.judged(raw[q.name], scales) for q in TRAJECTORY}


def judged_max(trajectory_error: Mapping[str, float], scales: Mapping[str, float]) -> dict[str, float]:
    """The largest judged value of each quantity from ``compare.trajectory_error``'s
    ``<name>_max`` (the max over samples and bodies of the raw difference): ``{name: value}``,
    as validate's ``trajectory.*`` checks report it."""
    return {q.name: float(q.judged(trajectory_error[f"{q.name}_max"], scales)) for q in TRAJECTORY}


def state_error(judged: Mapping[str, Any]) -> Any:
    """The state error: the largest of the judged trajectory quantities (numbers, or arrays
    elementwise for a series), dimensionless (the orientation in rad counts as is)."""
    values = [judged[q.name] for q in TRAJECTORY]
    if all(np.ndim(v) == 0 for v in values):
        return max(float(v) for v in values)
    return np.max(np.stack(values), axis=0)
