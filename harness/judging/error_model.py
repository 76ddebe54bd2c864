"""The error model of one run's quantity: how its error changes with the step.

A discrepancy ``e`` (a check's value: an error against the reference or the exact solution, a
drift, a violation; in the quantity's unit) measured at the scene's step ``h``, at the coarser
``2 h`` and, where those two leave the class undecided, at the finer ``h / 2`` (a coarse level may
be pre-asymptotic: refinement is the reliable direction), is modelled as

    e(h) = C h^p + F

the part ``C h^p`` that vanishes with the step at the method's order ``p``, and the floor ``F``
that does not (a model difference: soft constraints, soft contact; or a defect). From the levels:

* the observed order of the finest two levels ``p_obs = log(e(rho h) / e(h)) / log(rho)``;
* where it is low, the vanishing part at the finest level ``V = (e(rho h) - e(h)) / (rho^p - 1)``
  (Richardson extrapolation with the order of the three finest levels' differences,
  ``log((e(4h) - e(2h)) / (e(2h) - e(h))) / log(2)``, where that is about the method's, else
  with the method's order), and the floor ``F = e(h) - V``;
* the resolution: below it a discrepancy is not resolved at all, the larger of the round-off
  floor ``N eps`` (N steps, relative to the quantity's scale), the accuracy of what the run is
  judged against (the reference's, measured the same way) and ``JUDGING_RESOLUTION`` (the
  accuracy to which the references themselves are computed).

An error-controlled run's levels are its tolerance and a looser one (``LOOSER``): its error
follows the tolerance (order ``q`` in the tolerance, about 1 for a method whose global error the
controller keeps at its tolerance; ``TOL_ORDER_MIN`` at least), or it sits at a floor.

Classification (``classify``): ``converges`` (the error falls at about the method's order, or
sits at the resolution: the engine agrees with the physics), ``model difference`` (a floor
above the resolution that does not shrink with the step), ``defect`` (non-finite values, an
order far below the method's, an error that grows with refinement), ``unresolved`` (an error of
the motion's own size at the scene's step: the run has lost the motion, nothing to fit).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The accuracy to which the judging runs, closed forms and measurements are computed, relative
#: to each quantity's scale: the in-house reference is integrated at rtol = atol = 1e-12
#: (``harness.validate.run.REFERENCE_TOL``), the integrated closed forms at 1e-12 over up to
#: thousands of their steps, periods from interpolated zero crossings; the reference's own
#: exact errors are 1.0e-10 (cart_pendulum), 2.3e-10 (spring_pendulum) and 6.3e-10 rad
#: (slider_crank), the same at rtol 1e-12 and 1e-10. A difference below this is not resolved.
JUDGING_RESOLUTION = 1e-9

#: Double precision's unit round-off.
EPS = 2.220446049250313e-16

#: An observed order this far below the method's still converges (pre-asymptotic, or a
#: derived quantity one order lower, such as an index-3 DAE's multipliers); further below it
#: is a defect.
ORDER_SLACK = 1.0

#: How far below the formal order the finest pair's order may be before a finer level is run.
ORDER_DOUBT = 0.5

#: The least order in the tolerance of an error-controlled run that follows its tolerance.
TOL_ORDER_MIN = 0.5

#: Errors at the finer levels below this many times the resolution are noise about it: no
#: order or trend is read from them.
NOISE = 10.0

#: The least order of the three finest levels' differences that the vanishing part is taken to
#: fall at (below it the differences are too nearly equal to extrapolate from: the method's order
#: is taken). A vanishing part at a low order (a dropped stage: C h^2 for RK4) then leaves no floor.
VANISHING_ORDER_MIN = 0.5

#: The second level of an error-controlled run: its tolerance times this.
LOOSER = 100.0

#: A floor counts only where it is at least this fraction of the error at the scene's step (the
#: extrapolation's own accuracy: below it the floor is the difference of two nearly equal numbers).
FLOOR_FRACTION = 0.1

#: An error at the scene's step of at least this fraction of the quantity's scale is not an
#: error model's to fit: the run does not resolve the motion at that step (it has lost it: a
#: chaotic motion past its predictability horizon, or a step too large for the motion's rates).
UNRESOLVED = 0.1

CONVERGES = "converges"
MODEL_DIFFERENCE = "model difference"
DEFECT = "defect"
UNRESOLVED_CLASS = "unresolved"
NOT_JUDGED = "not judged"
CLASSES = (CONVERGES, MODEL_DIFFERENCE, DEFECT, UNRESOLVED_CLASS, NOT_JUDGED)


@dataclass(frozen=True)
class Level:
    """One run of the error model: its step (s) or, error-controlled, its tolerance, and the
    quantity's value there (in the quantity's unit; NaN when the run failed)."""

    step: float
    error: float


@dataclass(frozen=True)
class ErrorModel:
    """How one quantity's error behaves under refinement.

    Attributes:
        quantity: the check's name (``trajectory.position``, ``exact``, ...).
        unit: the unit of ``levels``' errors, ``vanishing``, ``floor`` and ``resolution``.
        scale: the quantity's scale in that unit (1 for a relative quantity): floors are
            compared with a scene's declared bounds as ``floor / scale``.
        kind: ``fixed`` (levels are steps, s) or ``adaptive`` (levels are tolerances).
        formal_order: the method's order (in the step; in the tolerance for ``adaptive``: 1).
        levels: the scene's level first, then the others.
        observed_order: from the levels (NaN where not measured: at resolution, one level).
        vanishing: the part of the error at the scene's level that vanishes with refinement.
        floor: the part that does not (0 where none is resolved).
        resolution: below this the error is not resolved (round-off, the judge's accuracy).
        classification: one of ``CLASSES``.
        reason: one line: why.
    """

    quantity: str
    unit: str
    scale: float
    kind: str
    formal_order: float
    levels: tuple[Level, ...]
    observed_order: float
    vanishing: float
    floor: float
    resolution: float
    classification: str
    reason: str

    @property
    def error(self) -> float:
        """The error at the scene's level (its unit)."""
        return self.levels[0].error if self.levels else float("nan")

    @property
    def relative_floor(self) -> float:
        """The floor over the quantity's scale (dimensionless)."""
        return self.floor / self.scale if self.scale > 0 else float("inf")


def roundoff(steps: float, scale: float = 1.0) -> float:
    """The round-off floor of a quantity of ``scale`` accumulated over ``steps`` steps: ``N eps``
    times the scale (each step's error of a few ulps, summed; a bound, not an estimate)."""
    return max(float(steps), 1.0) * EPS * scale


def needs_finer_level(levels: list[Level], formal_order: float, resolution: float) -> bool:
    """Whether fixed-step levels (the scene's first) leave the class undecided: the finest two are
    neither at the resolution nor falling at about the method's order, nor non-finite; a finer
    level then decides (a coarse level may be pre-asymptotic)."""
    ordered = sorted((lv for lv in levels if math.isfinite(lv.error)), key=lambda lv: lv.step)
    if len(ordered) < 2 or not math.isfinite(levels[0].error) or levels[0].error <= resolution:
        return False
    fine, mid = ordered[0], ordered[1]
    if max(fine.error, mid.error) <= NOISE * resolution:
        return False
    return not _order(fine.error, mid.error, mid.step / fine.step) >= formal_order - ORDER_DOUBT


def _order(fine: float, coarse: float, rho: float) -> float:
    if fine <= 0 or coarse <= 0 or rho <= 0 or rho == 1:
        return float("nan")
    return math.log(coarse / fine) / math.log(rho)


def not_judged(quantity: str, unit: str, kind: str, formal_order: float, reason: str, levels=(),
               resolution: float = float("nan"), scale: float = 1.0) -> ErrorModel:
    """The model of a quantity that has nothing to fit (no run ended at the scene's level, or none
    at all): class ``not judged``, ``reason`` saying why."""
    nan = float("nan")
    return ErrorModel(quantity, unit, scale, kind, formal_order, tuple(levels), nan, nan, nan, resolution, NOT_JUDGED,
                      reason)


def fit(quantity: str, unit: str, scale: float, kind: str, formal_order: float, levels: list[Level],
        resolution: float) -> ErrorModel:
    """The error model of ``levels`` (the scene's level first; for ``fixed``, steps of ratio 2
    or 4 to it, coarser or finer; for ``adaptive``, tolerances) and its classification."""
    levels = list(levels)
    base = levels[0]

    def model(order, vanishing, floor, cls, reason):
        return ErrorModel(quantity, unit, scale, kind, formal_order, tuple(levels), order, vanishing, floor,
                          resolution, cls, reason)

    if not math.isfinite(base.error):
        return model(float("nan"), float("nan"), float("nan"), DEFECT, "non-finite at the scene's step")
    if scale > 0 and base.error >= UNRESOLVED * scale:
        return model(float("nan"), float("nan"), float("nan"), UNRESOLVED_CLASS,
                     f"an error of {base.error / scale:.2g} of the quantity's scale: the step does not resolve the motion "
                     "(a chaotic or fast motion beyond its predictability at this step)")
    if base.error <= resolution:
        return model(float("nan"), 0.0, 0.0, CONVERGES, f"at the resolution ({resolution:.1e} {unit})")
    others = [lv for lv in levels[1:] if math.isfinite(lv.error)]
    if not others:
        return model(float("nan"), float("nan"), float("nan"), NOT_JUDGED,
                     "no other level ran to the end: order unknown")
    if kind == "adaptive":
        return _fit_adaptive(base, others[0], model, resolution, unit)
    # fixed step: the order of the two finest levels (refinement is the reliable direction: a
    # coarse level may be pre-asymptotic), a floor from Richardson extrapolation of the finest
    ordered = sorted([base] + others, key=lambda lv: lv.step)
    fine, mid = ordered[0], ordered[1]
    rho = mid.step / fine.step
    order = _order(fine.error, mid.error, rho)
    if max(fine.error, mid.error) <= NOISE * resolution:  # noise about the resolution: no order to read
        return model(float("nan"), base.error, 0.0, CONVERGES, f"within {NOISE:g}x the resolution ({resolution:.1e} {unit})")
    if mid.error < fine.error and fine.error > 2.0 * mid.error:
        return model(order, float("nan"), float("nan"), DEFECT,
                     f"grows with refinement: {mid.error:.2e} at {mid.step:g} s, {fine.error:.2e} at {fine.step:g} s")
    if order >= formal_order - ORDER_DOUBT:
        return model(order, base.error, 0.0, CONVERGES, f"order {order:.2f} (method's {formal_order:g})")
    # a low order at the finest pair: a floor under a vanishing part, or a defect. The vanishing
    # part falls at the order of the three finest levels' differences (the three-level fit of
    # C h^p + F: a pure low-order error C h^2 of a fourth-order method has no floor, a defect),
    # where that is at least VANISHING_ORDER_MIN, else at the method's order.
    p_vanishing = formal_order
    if len(ordered) >= 3:
        d1, d2 = mid.error - fine.error, ordered[2].error - mid.error
        if d1 > 0 and d2 > 0:
            p3 = _order(d1, d2, ordered[2].step / mid.step)
            if p3 >= VANISHING_ORDER_MIN:
                p_vanishing = p3
    v_fine = (mid.error - fine.error) / (rho ** p_vanishing - 1.0) if mid.error > fine.error else 0.0
    floor = max(fine.error - v_fine, 0.0)
    vanishing = max(base.error - floor, 0.0)
    if floor > resolution and floor >= FLOOR_FRACTION * base.error:
        return model(order, vanishing, floor, MODEL_DIFFERENCE,
                     f"a floor of {floor:.2e} {unit} that does not shrink with the step "
                     f"({fine.error:.2e} at {fine.step:g} s, {mid.error:.2e} at {mid.step:g} s)")
    if order < formal_order - ORDER_SLACK:
        return model(order, vanishing, 0.0, DEFECT, f"order {order:.2f} where the method's is {formal_order:g}")
    return model(order, vanishing, 0.0, CONVERGES, f"order {order:.2f} (method's {formal_order:g}; pre-asymptotic)")


def _fit_adaptive(base: Level, loose: Level, model, resolution: float, unit: str) -> ErrorModel:
    """An error-controlled run at its tolerance ``base.step`` and a looser one."""
    ratio = loose.step / base.step
    q = _order(base.error, loose.error, ratio)
    v = (loose.error - base.error) / (ratio - 1.0) if loose.error > base.error else 0.0
    floor = max(base.error - v, 0.0)
    if math.isfinite(q) and q >= TOL_ORDER_MIN:
        return model(q, base.error, 0.0, CONVERGES, f"follows its tolerance (order {q:.2f} in the tolerance)")
    if floor > NOISE * resolution and floor >= FLOOR_FRACTION * base.error:
        return model(q, base.error - floor, floor, MODEL_DIFFERENCE,
                     f"a floor of {floor:.2e} {unit} that does not follow the tolerance "
                     f"({base.error:.2e} at {base.step:g}, {loose.error:.2e} at {loose.step:g})")
    return model(float("nan"), base.error, 0.0, CONVERGES,
                 f"no floor resolved: within {NOISE:g}x the resolution ({resolution:.1e} {unit}), flat in the tolerance")




def judge_refinement(measure, steps: tuple[float, ...], formal_order: float, scales: dict[str, tuple[str, float]],
                     n_steps: float) -> dict[str, ErrorModel]:
    """The error models of discrepancies measured by a fixed-step run pair at several steps.

    ``measure(step)`` -> {quantity: discrepancy} (in the quantity's unit) of the runs at ``step`` (s);
    ``steps``: the base step first, then the others (e.g. ``(h, 2 h)``); ``scales``: quantity ->
    (unit, scale in that unit); ``n_steps``: steps of the base run (its round-off). The resolution
    of each quantity is the larger of the round-off ``N eps scale`` and ``JUDGING_RESOLUTION scale``.
    Where the levels leave a quantity's class undecided (``needs_finer_level``), or a coarser level
    diverged where the base one did not, the runs are made once more at half the finest step and
    every quantity's fit uses that level too."""
    measured = {h: measure(h) for h in steps}
    resolution = {q: max(roundoff(n_steps, scale), JUDGING_RESOLUTION * scale) for q, (_, scale) in scales.items()}

    def levels(q: str) -> list[Level]:
        return [Level(h, float(errors[q])) for h, errors in measured.items()]

    base = measured[steps[0]]
    coarse_lost = any(math.isfinite(base[q]) and not math.isfinite(errors[q])
                      for h, errors in measured.items() if h != steps[0] for q in scales)
    if coarse_lost or any(needs_finer_level(levels(q), formal_order, resolution[q]) for q in scales):
        finest = min(measured) / 2.0   # a coarse level that diverged, or one that leaves the class open
        measured[finest] = measure(finest)
    return {q: fit(q, unit, scale, "fixed", formal_order, levels(q), resolution[q]) for q, (unit, scale) in scales.items()}
