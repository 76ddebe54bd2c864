"""What ``harness check`` finds for one model: the loaders' readings, the votes on each quantity, the
causes found, and the whole result (``CheckResult``). Units: SI (kg, m, rad, s)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.judging.error_model import CONVERGES
from harness.tools import dynamics_terms as dc
from harness.tools import witnesses as wit
from harness.tools.loaded_models import (
    JointBody,
    JointDetails,
)



SAME_FILE_RTOL = 1e-9   # model comparison when both engines read the same file

TWO_FILES_RTOL = 1e-6   # when MJCF and URDF were written separately (decimals in the files)


# --------------------------------------------------------------------------- the check

LOADERS = ("MuJoCo", "Pinocchio", "Drake", "PyBullet")


#: The quantity of PyBullet's inertia trap (``InertiaTrap``), matched against the known limitations.
TRAP_QUANTITY = "inertia without URDF_USE_INERTIA_FROM_FILE"


@dataclass(frozen=True)
class InertiaTrap:
    """One joint's body as PyBullet reads it without ``URDF_USE_INERTIA_FROM_FILE`` (its default:
    inertia from the collision shapes) against its reading with the flag (the file's): inertia
    about the centre of mass in the joint's body frame (kg m^2), and the mass (kg, the file's in both)."""

    joint: str
    body: str
    mass: float
    file_inertia: np.ndarray
    default_inertia: np.ndarray

    @property
    def text(self) -> str:
        a, b = np.linalg.eigvalsh(self.file_inertia), np.linalg.eigvalsh(self.default_inertia)
        diff = float(np.abs(self.file_inertia - self.default_inertia).max())
        big = max(float(np.abs(self.file_inertia).max()), 1e-300)
        return (f"joint {self.joint!r} (body {self.body!r}): principal moments [{', '.join(f'{x:.4g}' for x in b)}] "
                f"kg m^2 without the flag, [{', '.join(f'{x:.4g}' for x in a)}] kg m^2 in the file; they differ by up "
                f"to {diff:.3g} kg m^2 in an entry ({100 * diff / big:.3g}% of the file's largest)")


@dataclass
class FreeMotion:
    """Largest differences of MuJoCo's and Pinocchio's free motion from one state at the check's step
    (joint: rad or m; velocity: rad/s or m/s; position: m; orientation: rad), the body where the pose
    differs most, and how each difference converges (``models``: quantity -> ``ErrorModel``,
    ``harness.tools.check.dynamics.free_motion``)."""

    state: int
    joint: float
    velocity: float
    position: float
    orientation: float
    worst_body: str
    constrained_joint: float = float("nan")   # MuJoCo with limits/equality/damping on vs off (rad or m)
    models: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Every difference converges (falls at the methods' order or sits at the resolution)."""
        return bool(self.models) and all(e.classification == CONVERGES for e in self.models.values())


@dataclass
class Reading:
    """One importer's reading of the model.

    Attributes:
        loader: ``MuJoCo``, ``Pinocchio``, ``Drake`` or ``PyBullet``; ``source``: the file it read; ``version``.
        refusal: why it does not load the file (one line), None when it does.
        bodies, details: per joint, the body it moves (with its merged parts) and the joint's
            point, range, damping, armature and friction loss (``harness.tools.loaded_models``:
            ``JointBody``, ``JointDetails``).
        gravity: m/s^2, world.
        model: what it holds (``MjModel``, ``pin.Model``, ``DrakeLoad``, ``PyBulletLoad``).
        slots: Pinocchio only: joint name -> ``PinocchioSlot`` (composite joints split).
        parser: what its parser said while loading (Drake's warnings, one line each).
        dynamics: why its dynamics terms are not compared with MuJoCo's ("" when they are).
        hints: quantity -> a known cause, shown when this loader is the odd one out in it.
        geom_masses: MuJoCo only: body name -> how MuJoCo got the mass of a body whose file gives
            no ``<inertial>`` (from its geoms: geom density or mass), shown where that body's
            joint differs in mass (``_geom_masses``).
        names: the joints this loader's file names otherwise, compared under the other file's names
            (``apply_joint_map``): name in its file -> name in the comparison.
        partial: MuJoCo's joints this loader lacks, whole kinematic trees of their own: its
            dynamics terms and free motion are compared on the other trees (``_joint_set_problem``).
        inertia_trap: PyBullet only: the joints whose inertia PyBullet reads otherwise without
            ``URDF_USE_INERTIA_FROM_FILE`` (``InertiaTrap``); ``trap``: what that second load read
            and what it found, one line ("" when not loaded).
        other_format: the loader does not read this format (PyBullet an MJCF): its refusal is shown with
            the loads, not as a refusal nor as "not compared".
    """

    loader: str
    source: Path
    version: str
    refusal: str | None = None
    bodies: list[JointBody] = field(default_factory=list)
    details: list[JointDetails] = field(default_factory=list)
    gravity: np.ndarray | None = None
    model: object = None
    slots: dict = field(default_factory=dict)
    parser: tuple[str, ...] = ()
    dynamics: str = ""
    hints: dict = field(default_factory=dict)
    geom_masses: dict = field(default_factory=dict)
    names: dict = field(default_factory=dict)
    partial: list = field(default_factory=list)
    inertia_trap: list = field(default_factory=list)
    trap: str = ""
    other_format: bool = False

    @property
    def loaded(self) -> bool:
        return self.refusal is None


_NUMBERS = {3: "three", 4: "four"}


def _who(loaders) -> str:
    """``A``, ``A and B``, ``A, B and C``."""
    loaders = list(loaders)
    return " and ".join(loaders) if len(loaders) <= 2 else ", ".join(loaders[:-1]) + " and " + loaders[-1]


@dataclass(frozen=True)
class Vote:
    """One quantity of one joint (or, with ``joint == ""``, gravity) across the loaders that read it.

    Attributes:
        joint, body: names (MuJoCo's body name where MuJoCo has the joint).
        quantity: what is compared (``QUANTITIES``, ``present``, ``gravity``).
        values: loader -> its value as text, with the unit.
        groups: the loaders that agree with each other (within the check's tolerance), largest
            group first; one group: all agree.
        hint: a known cause, when the values show it (e.g. a range read as degrees).
        counted: whether a disagreement fails the check (``SETTINGS`` are not counted when
            the loaders read an MJCF and a URDF: a URDF revolute joint must state limits and
            cannot state an armature; ``NOT_COUNTED`` never are).
        detail: by how much the values differ, with the unit (``_difference``: the odd one out
            against the majority, or the two values when two loaders read it); "" when they agree.
    """

    joint: str
    body: str
    quantity: str
    values: dict[str, str]
    groups: tuple[tuple[str, ...], ...]
    hint: str = ""
    counted: bool = True
    detail: str = ""

    @property
    def agree(self) -> bool:
        return len(self.groups) <= 1

    @property
    def odd(self) -> str | None:
        """The loader all the others agree against (three or four loaders read it: 2 vs 1, 3 vs 1),
        else None (no majority: 2 vs 2, or no two agree)."""
        if len(self.groups) == 2 and len(self.groups[0]) >= 2 and len(self.groups[1]) == 1:
            return self.groups[1][0]
        return None

    @property
    def message(self) -> str:
        who = f"joint {self.joint!r} (body {self.body!r})" if self.joint else "model"
        hint = f" ({self.hint})" if self.hint else ""
        odd = self.odd
        if self.quantity == "present":
            have = [k for k, v in self.values.items() if v == "present"]
            lack = [k for k, v in self.values.items() if v != "present"]
            if odd is not None:
                others = _who(k for k in self.values if k != odd)
                text = (f"{odd} is the odd one out: it has no such joint; {others} have it" if odd in lack
                        else f"{odd} is the odd one out: only it has this joint, {others} do not")
            else:
                text = f"only in {_who(have)}, not in {_who(lack)}"
            return f"{who}: {text}{hint}"
        detail = f"; {self.detail}" if self.detail else ""
        if odd is not None:
            a = self.groups[0][0]
            return (f"{who}: {self.quantity}: {odd} is the odd one out: {self.values[odd]} where {_who(self.groups[0])} "
                    f"read {self.values[a]}{detail}{hint}")
        parts = ", ".join(f"{v} in {k}" for k, v in self.values.items())
        lead = (f"all {_NUMBERS.get(len(self.groups), len(self.groups))} differ: "
                if len(self.groups) == len(self.values) and len(self.groups) >= 3 else "")
        return f"{who}: {self.quantity}: {lead}{parts}{detail}{hint}"


@dataclass(frozen=True)
class Finding:
    """A cause that accounts for a disagreement, checked against the readings (``diagnose``).

    Attributes:
        kind: ``inertial rotation`` (a URDF ``<inertial><origin rpy>`` that one reading lacks),
            ``fixed child`` (a fixed child's mass properties missing or different in one reading
            of the body they are merged into), ``armature`` (a joint's armature that only some
            loaders read), ``dynamics armature`` (M differing by exactly the armature on its
            diagonal), ``several joints`` (the first of a body's joints at its parent's origin in
            one reading).
        joint, body: where ("" for the dynamics).
        short: a few words for the verdict; ``text``: the whole finding, with figures and units.
        group: findings with the same group are one item of the verdict when there are several
            (``causes_line``: e.g. an armature only one loader reads, on many joints).
    """

    kind: str
    joint: str
    body: str
    short: str
    text: str
    group: str = ""


def causes_line(findings: list[Finding]) -> str:
    """The findings' ``short`` texts for the verdict, one item per group of several (with the
    number of joints and the first three), in order."""
    groups: dict[str, list[Finding]] = {}
    for f in findings:
        if f.group:
            groups.setdefault(f.group, []).append(f)
    items, done = [], set()
    for f in findings:
        if not f.group or len(groups[f.group]) == 1:
            items.append(f.short)
        elif f.group not in done:
            done.add(f.group)
            joints = [g.joint for g in groups[f.group]]
            items.append(f"{f.group} on {len(joints)} joints ({', '.join(joints[:3])}{', ...' if len(joints) > 3 else ''})")
    return "; ".join(items)


@dataclass
class CheckResult:
    """Everything ``harness check`` found for one model."""

    name: str
    mode: str
    base: str
    readings: dict[str, Reading] = field(default_factory=dict)
    votes: list[Vote] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    dynamics: list[dc.TermDiff] = field(default_factory=list)
    free: list[FreeMotion] = field(default_factory=list)
    free_skipped: str = ""   # why the free motion was not run ("" when it was)
    settings: dict = field(default_factory=dict)
    warnings: dict = field(default_factory=dict)  # MuJoCo's warnings during the comparison: {"count", "first"}
    findings: list[Finding] = field(default_factory=list)  # what the differences come from (``diagnose``)
    not_compared: list[str] = field(default_factory=list)  # what MuJoCo holds beyond the tree (``not_compared``)
    copies: list[str] = field(default_factory=list)  # how what the loaders read differs from the files
    mapped: int = 0   # joints compared under another name (``apply_joint_map``)
    witnesses: wit.Witnesses | None = None   # the in-house engine and Exudyn (``harness.tools.witnesses``)
    defects: list = field(default_factory=list)   # the file's defects (``harness.tools.check.defects.Defect``)
    classes: object = None   # ``harness.tools.check.classifying.Classification``, once the check has run

    @property
    def model_problems(self) -> list[str]:
        """The disagreements between the loaders that fail the check, one message each."""
        return [v.message for v in self.votes if not v.agree and v.counted]

    @property
    def setting_differences(self) -> list[str]:
        """Disagreements in joint settings that do not fail the check (listed, not counted): between an
        MJCF and a URDF (``SETTINGS``), and friction loss always (``NOT_COUNTED``)."""
        return [v.message for v in self.votes if not v.agree and not v.counted]

    @property
    def two_files(self) -> bool:
        """Whether the loaders read two files (an MJCF and a URDF)."""
        return len({r.source for r in self.readings.values() if r.loaded}) > 1

    @property
    def refusals(self) -> list[str]:
        """``"<loader>: does not load: <reason>"`` for each loader that refused the file."""
        return [f"{r.loader}: does not load: {r.refusal}" for r in self.readings.values()
                if not r.loaded and not r.other_format]

    @property
    def free_passed(self) -> bool:
        return all(r.passed for r in self.free)

    @property
    def passed(self) -> bool:
        """No defect in the file and no unexplained disagreement between the loaders that read it
        (``harness.tools.check.classifying``: a known importer limitation and the witnesses do not
        fail the check; a refusal is reported, not judged)."""
        return self.classes.passed

    @property
    def witnesses_passed(self) -> bool:
        """The witnesses hold the description they were built from and move as MuJoCo does (not run: not judged)."""
        w = self.witnesses
        return w is None or bool(w.refusal) or (not w.problems and all(f.passed for f in w.free)
                                                and all(d.passed for d in w.dynamics))

