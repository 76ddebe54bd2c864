"""Defects in the user's file: what is wrong in the file itself, whatever an importer does with it.

Each ``Defect`` names the element (file, line, link/body/joint as the file names it), what is
wrong (figures in SI units: kg, m, kg m^2, kg/m^3) and a one-line fix. They are found on the file
as MuJoCo's parser reads it into a spec (``mujoco.MjSpec``: every body/link with the inertial the
file states, before any merging), before any loader compiles it (``find_defects``):

* ``negative mass``: a mass < 0 or not finite;
* ``zero mass with inertia``: ``mass 0`` with a non-zero rotational inertia (a massless body has
  none; the importers disagree on what it means: Drake gives such a link 1 kg, MuJoCo's
  ``fusestatic`` drops the inertia, Pinocchio keeps it);
* ``inertia not positive definite`` and ``triangle inequality``: the principal moments of a
  body of positive mass about its centre of mass must not be negative and each at most the sum
  of the other two, up to the larger of ``RELATIVE_SLACK`` of their sum (the file's rounding) and
  the moments of a body ``NEGLIGIBLE_LENGTH`` across (round-off of zero); a point mass, all moments
  0, is an idealisation, not a defect; MuJoCo refuses such a body, moving or fixed;
* ``zero-length axis``: a hinge or slide joint whose axis has length 0;
* ``implausible density``: the mass over the volume of the uniform box with the same principal
  moments lies outside ``DENSITY_RANGE`` (a thin aluminium shell to four times osmium; a placeholder
  inertia or a unit slip, g for kg or mm for m, lands outside), on a link that carries at least
  ``MASS_SHARE`` of the mass its joint moves;
* ``geom mass and inertial disagree``: an MJCF body whose ``<inertial>`` mass differs from the
  sum of the masses its geoms state explicitly (``mass=``), which MuJoCo then ignores;
* a URDF joint's ``<limit>`` that contradicts its type: ``limits missing`` (a revolute or prismatic
  joint without ``lower``/``upper``: 0 by the URDF's rule, a locked joint), ``locked range``
  (``lower == upper``), ``limits on a continuous joint``; each importer reads these its own way.

``fatal`` defects stop every loader (MuJoCo refuses the file: a non-physical body): ``check``
reports them as bad input, one line with the fix, exit 2. Line numbers come from MuJoCo's spec
for an MJCF (``info``: ``line N``) and from the file's own text for a URDF (``element_lines``).

``owner``: the body a defect ends up in, named as MuJoCo names the body its joint moves (the
nearest ancestor with a joint, itself if it has one): a disagreement between the loaders on that
body's mass properties is a consequence of the defect, not an importer's (``classifying``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from harness.model.input_files import model_format
from harness.model.joints import by_mujoco
from harness.tools.check.file_elements import elements

#: kg/m^3: the implied densities a rigid part can have. The uniform box with a body's principal
#: moments is about as large as the body for a solid (a solid sphere: 1.13 times its density), larger
#: for a hollow part: a thin shell of wall t on radius R implies 1.57 (t / R) times its material's
#: density, 8.5 kg/m^3 for aluminium at t / R = 0.002, about the thinnest structural wall; above,
#: 4.4 times osmium's 22600 kg/m^3, beyond any part whose mass is not concentrated in a point.
DENSITY_RANGE = (5.0, 1.0e5)
#: Principal moments whose triangle inequality fails by less than this fraction of their sum are
#: the file's rounding (a thin rod or a flat plate written to a few digits), not a defect.
RELATIVE_SLACK = 1e-6
#: An implausible density is a defect where the link carries at least this share of the mass of the
#: body its joint moves (itself and the fixed links merged into it): a frame or sensor link of a
#: gram on a kilogram link, whatever its placeholder inertia, changes nothing; a link welded to the
#: world changes nothing either.
MASS_SHARE = 0.01
#: m: a rotational inertia below mass x this^2 (a body a tenth of a millimetre across) is round-off of
#: zero, not a negative moment or a broken triangle inequality.
NEGLIGIBLE_LENGTH = 1e-4
#: Triangle-inequality margin below which a body is listed as near-degenerate (a rod over ~40
#: times longer than thick); listed, not a defect.
MARGIN_MIN = 1e-3

KINDS = ("negative mass", "zero mass with inertia", "inertia not positive definite", "triangle inequality",
         "zero-length axis", "implausible density", "geom mass and inertial disagree", "limits missing",
         "locked range", "limits on a continuous joint")


@dataclass(frozen=True)
class Defect:
    """One defect of the file (module docstring). ``file``: the file; ``line``: 1-based, None when
    unknown; ``element``: e.g. ``link 'FL_FOOT'``; ``what``: what is wrong, with figures;
    ``fix``: one line; ``owner``: MuJoCo's moving body it ends up in ("" for none)."""

    kind: str
    file: Path
    line: int | None
    element: str
    what: str
    fix: str
    owner: str = ""
    fatal: bool = False
    brief: str = ""
    joint: str = ""   # the joint a joint's defect is on ("" for a body's)

    @property
    def short(self) -> str:
        """One short line for the terminal: where, the element, the kind and the key figure."""
        return f"{self.where} {self.element}: {self.kind}" + (f" ({self.brief})" if self.brief else "")

    @property
    def where(self) -> str:
        return f"{self.file.name}:{self.line}" if self.line else self.file.name

    @property
    def text(self) -> str:
        """One line: where, the element, what is wrong."""
        return f"{self.where} {self.element}: {self.what}"


@dataclass(frozen=True)
class BodyPlausibility:
    """A body's inertia judged on its own. ``mass`` kg; ``moments``: principal moments about the
    centre of mass (kg m^2, ascending); ``margin``: triangle-inequality margin, min over
    permutations of (I_a + I_b - I_c) / max I (NaN for a point mass); ``density``: implied density,
    kg/m^3 (NaN when the equivalent box has no real side); ``flags``: why it is suspicious."""

    body: str
    mass: float
    moments: tuple[float, float, float]
    margin: float
    density: float
    flags: tuple[str, ...]

    @property
    def suspicious(self) -> bool:
        return bool(self.flags)

    @property
    def implausible(self) -> bool:
        """Whether the implied density lies outside ``DENSITY_RANGE`` (a defect, not only a flag)."""
        return math.isfinite(self.density) and not DENSITY_RANGE[0] <= self.density <= DENSITY_RANGE[1]

    def line(self) -> str:
        verdict = "suspicious: " + "; ".join(self.flags) if self.flags else "plausible"
        return (f"{self.body}: mass {self.mass:.6g} kg, principal moments [{', '.join(f'{i:.6g}' for i in self.moments)}]"
                f" kg m^2, triangle margin {_g(self.margin)}, implied density {_g(self.density)} kg/m^3: {verdict}")


def _g(x: float, digits: int = 3) -> str:
    return "undefined" if not np.isfinite(x) else f"{x:.{digits}g}"


def plausibility(body: str, mass: float, moments) -> BodyPlausibility:
    """Triangle-inequality margin and implied density of one body: the uniform box with the same
    mass and principal moments has sides s_a = sqrt(6 (I_b + I_c - I_a) / m)."""
    inertia = np.sort(np.asarray(moments, dtype=float))
    top = float(inertia.max())
    margin = min(inertia[a] + inertia[b] - inertia[c] for a, b, c in itertools.permutations(range(3))) / top \
        if top > 0 else float("nan")
    sides_sq = 6.0 * (inertia.sum() - 2.0 * inertia) / mass
    density = float(mass / math.sqrt(float(np.prod(sides_sq)))) if np.all(sides_sq > 0) else float("nan")
    flags = []
    if not margin >= MARGIN_MIN:
        flags.append("point mass (no rotational inertia)" if not np.isfinite(margin)
                     else f"triangle margin {margin:.3g} < {MARGIN_MIN:g}")
    if np.isfinite(density) and not DENSITY_RANGE[0] <= density <= DENSITY_RANGE[1]:  # undefined: margin <= 0
        flags.append(f"implied density {_g(density)} kg/m^3 outside [{DENSITY_RANGE[0]:g}, {DENSITY_RANGE[1]:g}]")
    return BodyPlausibility(body, float(mass), tuple(float(i) for i in inertia), float(margin), density, tuple(flags))


def mujoco_plausibility(m: mujoco.MjModel) -> list[BodyPlausibility]:
    """Every body of positive mass as MuJoCo holds it (``body_mass``, ``body_inertia``)."""
    return [plausibility(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}", float(m.body_mass[b]),
                         m.body_inertia[b]) for b in range(1, m.nbody) if m.body_mass[b] > 0]


def spec_inertia(body) -> np.ndarray:
    """The inertia about the centre of mass a spec body states (kg m^2): its full tensor, else the
    principal moments (in the frame ``iquat``: validity does not depend on the frame)."""
    full = np.asarray(body.fullinertia, dtype=float)
    if np.all(np.isfinite(full)):
        xx, yy, zz, xy, xz, yz = full
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return np.diag(np.asarray(body.inertia, dtype=float))


def spec_plausibility(spec: mujoco.MjSpec) -> list[BodyPlausibility]:
    """Every body with an explicit inertial of positive mass, as the file writes it."""
    return [plausibility(b.name, float(b.mass), np.linalg.eigvalsh(spec_inertia(b))) for b in spec.bodies
            if b.name != "world" and b.explicitinertial and b.mass > 0 and np.all(np.isfinite(spec_inertia(b)))]


# --------------------------------------------------------------------------- lines in the file


def element_lines(path: Path) -> dict[tuple[str, str], int]:
    """(tag, name) -> 1-based line of every named element of an XML file, and (tag of a child,
    name of its nearest named ancestor) -> line for the unnamed children (``inertial``, ``mass``,
    ``inertia``, ``axis``, ``mimic``): the first of each (``file_elements.elements``)."""
    els = elements(path)
    lines: dict[tuple[str, str], int] = {}
    for e in els:
        name, i = e.attrs.get("name"), e.parent
        while name is None and i >= 0:
            name, i = els[i].attrs.get("name"), els[i].parent
        if name is not None:
            lines.setdefault((e.tag, name), e.line)
    return lines


def _spec_line(element) -> int | None:
    info = str(getattr(element, "info", "") or "")
    return int(info.split()[1]) if info.startswith("line ") and info.split()[1].isdigit() else None


def _owner(body) -> str:
    """The nearest ancestor-or-self of a spec body that a joint moves ("" for none: welded to the world)."""
    b = body
    while b is not None and b.name != "world":
        if b.first_joint() is not None:
            return b.name
        b = b.parent
    return ""


def _num(x: float) -> str:
    return f"{x:.6g}"


def _moments_text(moments) -> str:
    return "[" + ", ".join(_num(i) for i in moments) + "] kg m^2"


def find_defects(path: Path, spec: mujoco.MjSpec) -> list[Defect]:
    """The defects of the file ``path`` as MuJoCo's parser read it into ``spec`` (not compiled),
    in the file's order (module docstring)."""
    path = Path(path)
    urdf = model_format(path) == "URDF"
    word = "link" if urdf else "body"
    lines = element_lines(path) if urdf else {}

    def line_of(element, tag: str, child: str | None = None) -> int | None:
        if not urdf:
            return _spec_line(element)
        return lines.get((child, element.name)) if child and (child, element.name) in lines \
            else lines.get((tag, element.name))

    out: list[Defect] = []
    owner_mass: dict[str, float] = {}
    for b in spec.bodies:
        if b.name != "world" and b.explicitinertial and math.isfinite(float(b.mass)) and b.mass > 0:
            owner_mass[_owner(b)] = owner_mass.get(_owner(b), 0.0) + float(b.mass)
    for body in spec.bodies:
        if body.name == "world":
            continue
        owner = _owner(body)
        el = f"{word} {body.name!r}"
        if not body.explicitinertial:
            continue
        mass = float(body.mass)
        inertia = spec_inertia(body)
        at = line_of(body, "link", "mass") if urdf else line_of(body, "body")
        if not math.isfinite(mass) or mass < 0.0:
            out.append(Defect("negative mass", path, at, el, f"mass {mass:g} kg", "a mass is positive: state the "
                              f"{word}'s mass in kg", owner, fatal=True))
            continue
        if not np.all(np.isfinite(inertia)):
            continue
        moments = np.linalg.eigvalsh(inertia)
        if mass == 0.0:
            if np.any(inertia != 0.0):
                out.append(Defect("zero mass with inertia", path, at, el,
                                  f"mass 0 kg with the rotational inertia {_moments_text(moments)} (principal): a "
                                  "massless body has none, and the importers read it differently",
                                  f"give {word} {body.name!r} its mass, or set its inertia to zero", owner,
                                  brief=f"moments {_moments_text(moments)}"))
            continue
        at_inertia = line_of(body, "link", "inertia") if urdf else at
        fatal = True   # MuJoCo refuses any body no rigid body can be, moving or merged into its parent
        share = mass / owner_mass.get(owner, math.inf) if owner else 0.0
        slack = max(RELATIVE_SLACK * float(np.abs(moments).sum()), mass * NEGLIGIBLE_LENGTH**2)
        if moments[0] < -slack:
            out.append(Defect("inertia not positive definite", path, at_inertia, el,
                              f"principal moments {_moments_text(moments)}: a rigid body of mass {_num(mass)} kg has "
                              "positive ones", f"recompute {word} {body.name!r}'s inertia about its centre of mass from "
                              "its shape", owner, fatal, brief=f"principal moments {_moments_text(moments)}"))
            continue
        if moments[2] > moments[0] + moments[1] + slack:
            out.append(Defect("triangle inequality", path, at_inertia, el,
                              f"principal moments {_moments_text(moments)} break the triangle inequality: "
                              f"I1 + I2 = {_num(moments[0] + moments[1])} < I3 = {_num(moments[2])} kg m^2",
                              f"recompute {word} {body.name!r}'s inertia about its centre of mass (every rigid body has "
                              "I1 + I2 >= I3)", owner, fatal,
                              brief=f"I1 + I2 = {_num(moments[0] + moments[1])} < I3 = {_num(moments[2])} kg m^2"))
            continue
        p = plausibility(body.name, mass, moments)
        if p.implausible and share >= MASS_SHARE:
            out.append(Defect("implausible density", path, at, el,
                              f"mass {_num(mass)} kg with principal moments {_moments_text(moments)}: the uniform box "
                              f"with them has a density of {_g(p.density)} kg/m^3, outside [{DENSITY_RANGE[0]:g}, "
                              f"{DENSITY_RANGE[1]:g}]", f"check {word} {body.name!r}'s mass and inertia (a placeholder "
                              "inertia, or g for kg, mm for m?)", owner, brief=f"{_g(p.density)} kg/m^3"))
        if not urdf:
            stated = [float(g.mass) for g in body.geoms if math.isfinite(float(g.mass))]
            if stated and sum(stated) > 0 and len(stated) == len(body.geoms) and abs(sum(stated) - mass) > 1e-6 * max(mass, sum(stated)):
                out.append(Defect("geom mass and inertial disagree", path, at, el,
                                  f"<inertial mass> {_num(mass)} kg where its geoms state {_num(sum(stated))} kg in all; "
                                  "MuJoCo takes the inertial, a reader deriving masses from geoms the geoms'",
                                  f"make {word} {body.name!r}'s <inertial> mass and its geoms' masses agree (or drop one)",
                                  owner, brief=f"{_num(mass)} kg against {_num(sum(stated))} kg"))
    for joint in spec.joints:
        kind = by_mujoco(mujoco.mjtJoint(joint.type).name)
        if kind is not None and kind.axis is not None:
            if float(np.linalg.norm(np.asarray(joint.axis, dtype=float))) == 0.0:
                at = (lines.get(("axis", joint.name)) or lines.get(("joint", joint.name))) if urdf else _spec_line(joint)
                out.append(Defect("zero-length axis", path, at, f"joint {joint.name!r}", "axis of length 0",
                                  f"give joint {joint.name!r} a non-zero axis (e.g. <axis xyz=\"0 0 1\"/>)",
                                  _owner(joint.parent) if joint.parent is not None else "", fatal=True))
    if urdf:
        out += _urdf_limit_defects(path)
    return out


def _urdf_limit_defects(path: Path) -> list[Defect]:
    """A URDF joint's ``<limit>`` that contradicts its type: a revolute or prismatic joint without
    ``lower`` or ``upper`` (the URDF makes a missing bound 0: locked at [0, 0]), one with ``lower ==
    upper`` (locked), a continuous joint with bounds (it has none)."""
    els = elements(path)
    out = []
    for i, e in enumerate(els):
        if e.tag != "joint" or e.parent < 0 or els[e.parent].tag != "robot":
            continue
        kind, name = e.attrs.get("type", ""), e.attrs.get("name", "?")
        limit = next((c for c in els if c.tag == "limit" and c.parent == i), None)
        if limit is None:
            continue
        el, a = f"joint {name!r}", limit.attrs
        if kind in ("revolute", "prismatic") and ("lower" not in a or "upper" not in a):
            missing = " and ".join(k for k in ("lower", "upper") if k not in a)
            out.append(Defect("limits missing", path, limit.line, el,
                              f"a {kind} joint's <limit> without {missing}: the URDF makes a missing bound 0, a joint "
                              "locked at [0, 0] (MuJoCo and Drake read it unlimited, Pinocchio [0, 0])",
                              f"state lower and upper of joint {name!r}, or make it continuous", joint=name,
                              brief=f"no {missing}"))
        elif kind in ("revolute", "prismatic") and float(a["lower"]) == float(a["upper"]):
            out.append(Defect("locked range", path, limit.line, el,
                              f"a {kind} joint with lower = upper = {a['lower']}: locked (MuJoCo reads it unlimited, "
                              "Pinocchio and Drake locked)",
                              f"make joint {name!r} fixed if it does not move, or state lower < upper (continuous if "
                              "unlimited)", joint=name, brief=f"lower = upper = {a['lower']}"))
        elif kind == "continuous" and ("lower" in a or "upper" in a):
            out.append(Defect("limits on a continuous joint", path, limit.line, el,
                              "a continuous joint has no position limits, yet its <limit> states bounds (Drake applies "
                              "them, MuJoCo and Pinocchio do not)",
                              f"drop lower/upper from joint {name!r}, or make it revolute if the bounds are meant",
                              joint=name, brief=f"lower {a.get('lower', '-')}, upper {a.get('upper', '-')}"))
    return out
