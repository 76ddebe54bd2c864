"""The verdict on one check of one run, from its error model and what its scene declares.

A scene states only what is the same for every engine:

* its **requirements** (``[requirements]`` of ``scene.toml``, and a project's own file given
  with ``--requirements``): a bound on a check's value at the scene's step that every engine
  must meet, in the check's unit (``closure.position = 1e-6`` m). A scene needs none: most
  judge by convergence alone.
* its **model differences** (``[model_differences.<engine>]``): an engine whose model is not the
  ideal one the scene describes (MuJoCo's soft loop constraints and soft contact), with what
  differs (``model``) and a bound on the size of the difference (``bound``: on each check's
  error at the scene's step, relative to the quantity's scale: the motion's length for m, its
  speed for m/s, 1 for rad and rel).
  A closed form that is itself an approximation (a small-oscillation theory) declares its
  floor in its reference module (``EXACT_FLOOR``: a bound and why).

The verdict (``judge``):

* ``converges``: passes (the engine agrees with the physics; its error at the scene's step is
  reported in units, and bounded only by a requirement if the scene states one);
* ``model difference``: passes where it is declared (for the engine, or for the closed form on
  ``exact``) and its error at the scene's step is within the declared bound (relative to the
  quantity's scale); fails where it is not declared, or beyond its bound;
* ``defect`` (an order far below the method's, an error growing with refinement, non-finite):
  fails, except where the engine's model difference is declared: a soft constraint's stiffness
  follows the step (MuJoCo's ``solref`` time constant is at least two steps), so its error's
  order is not the integrator's, and its whole error at the scene's step is the model
  difference's footprint there; that error is held to the declared bound;
* ``unresolved`` (an error of the motion's own size at the scene's step: a chaotic motion past
  its predictability, a step too large for its rates): fails, naming that cause;
* ``not judged`` (no other level ran to the end): fails, with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from harness.judging.error_model import CONVERGES, DEFECT, MODEL_DIFFERENCE, NOT_JUDGED, UNRESOLVED_CLASS, ErrorModel


@dataclass(frozen=True)
class ModelDifference:
    """A declared model difference: ``model`` says what differs from the scene's ideal model,
    ``bound`` bounds its size, each check's error at the scene's step relative to its quantity's
    scale (dimensionless)."""

    model: str
    bound: float


@dataclass(frozen=True)
class Verdict:
    """``passed``; ``label``: the class as the report shows it (``model difference (declared)``);
    ``detail``: one line, why."""

    passed: bool
    label: str
    detail: str


def judge(model: ErrorModel, declared: ModelDifference | None = None, requirement: float = math.inf) -> Verdict:
    """The verdict on one check (module docstring). ``requirement``: the bound on the error at
    the scene's level (the check's unit), ``inf`` where the scene states none."""
    verdict = _by_class(model, declared)
    if verdict.passed and math.isfinite(requirement) and not model.error <= requirement:
        return Verdict(False, verdict.label, f"{model.error:.2e} {model.unit} beyond the requirement "
                                             f"{requirement:.2e} {model.unit}; {verdict.detail}")
    return verdict


def _by_class(model: ErrorModel, declared: ModelDifference | None) -> Verdict:
    cls = model.classification
    if cls == CONVERGES:
        return Verdict(True, CONVERGES, model.reason)
    if cls in (NOT_JUDGED, UNRESOLVED_CLASS):
        return Verdict(False, cls, model.reason)
    if declared is None:
        return Verdict(False, cls, model.reason + ("" if cls == DEFECT else "; not declared by the scene"))
    # the whole error at the scene's step is the declared model's footprint there: a soft model
    # follows the step (MuJoCo's solref time constant is two steps), so the part of its error that
    # vanishes with refinement vanishes only as the model itself stiffens
    size = model.error / model.scale if model.scale > 0 else math.inf
    what = "error"
    label = f"{MODEL_DIFFERENCE} (declared)"
    if size <= declared.bound:
        return Verdict(True, label, f"{declared.model}: {what} {size:.1e} of scale within its bound {declared.bound:.0e}; "
                                    f"{model.reason}")
    return Verdict(False, label, f"{declared.model}: {what} {size:.1e} of scale beyond its bound {declared.bound:.0e}; "
                                 f"{model.reason}")


def requirement(scene, check: str) -> float:
    """The scene's requirement on ``check`` (``Scene.requirements``: the check's own name, else its
    table's, ``closure`` for ``closure.position``; ``energy_balance`` takes ``energy_drift``'s),
    ``inf`` where it states none."""
    reqs = getattr(scene, "requirements", None) or {}
    if check in reqs:
        return float(reqs[check])
    head = check.split(".", 1)[0]
    head = "energy_drift" if head == "energy_balance" else head
    return float(reqs.get(head, math.inf))
