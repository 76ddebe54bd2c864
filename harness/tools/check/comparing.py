"""Which loaders agree (``vote``): per joint and quantity (``QUANTITIES``: type, mass kg, centre of mass m,
inertia kg m^2, placement m and rad, axis, joint point m, range, damping, friction loss, armature) and
gravity (m/s^2, world), the odd one out where two agree against the third."""

from __future__ import annotations


import numpy as np

from harness.tools import dynamics_terms as dc
from harness.tools import witnesses as wit
from harness.model.joints import JOINTS, TRANSLATIONAL
from harness.tools.loaded_models import (
    JointBody,
    JointDetails,
)
from harness.tools.check.results import LOADERS, Reading, Vote
from harness.tools.check.reading import file_format


# --------------------------------------------------------------------------- which loaders agree


def _length(x: JointBody, y: JointBody) -> float:
    """Length scale of a joint's body (m): its centre of mass and placement, at least 1 mm."""
    return max(np.linalg.norm(x.p_BCm_B), np.linalg.norm(x.p_PB_P), np.linalg.norm(y.p_BCm_B),
               np.linalg.norm(y.p_PB_P), 1e-3)


def _fmt(x, unit: str = "", digits: int = 6) -> str:
    if x is None:
        return "none"
    a = np.asarray(x, dtype=float)
    if a.ndim and np.all(np.isfinite(a)):  # round-off beside the largest entry shown as 0
        a = np.where(np.abs(a) < 1e-12 * max(float(np.abs(a).max()), 1e-300), 0.0, a)
    if a.ndim == 0:
        text = f"{float(a):.{digits}g}"
    elif a.ndim == 1:
        text = "[" + ", ".join(f"{float(c):.{digits}g}" for c in a) + "]"
    else:
        text = "[" + ", ".join("[" + ", ".join(f"{float(c):.{digits}g}" for c in row) + "]" for row in a) + "]"
    return f"{text} {unit}".strip()


def _rotvec(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def _point_gap(x: JointBody, y: JointBody, dx: JointDetails, dy: JointDetails) -> float:
    """Distance between two joint points (m): for a hinge, across the axis only (a point moved
    along the axis is the same hinge); for a ball, the full distance."""
    d = dx.point_B - dy.point_B
    if JOINTS[x.kind].axis is not None:
        d = d - (d @ x.axis_B) * x.axis_B
    return float(np.linalg.norm(d))


def _has_point(kind: str) -> bool:
    """A hinge or a ball: a joint whose point matters (not a slide, not free; an engine's own kind neither)."""
    jt = JOINTS.get(kind)
    return jt is not None and jt.constrained and jt.axis != TRANSLATIONAL


def _limits_close(a, b, rtol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return all(abs(p - q) <= rtol * max(1.0, abs(p), abs(q)) for p, q in zip(a, b))


def _range_text(lim, kind: str) -> str:
    if lim is None:
        return "unlimited"
    unit = "m" if JOINTS.get(kind) is not None and JOINTS[kind].axis == TRANSLATIONAL else "rad"
    return f"[{lim[0]:.6g}, {lim[1]:.6g}] {unit}"


def _degrees_hint(odd, majority) -> str:
    """A hint when the odd range is the majority's times pi/180 (read as degrees) or 180/pi."""
    if odd is None or majority is None or not any(majority):
        return ""
    for factor, text in ((np.pi / 180.0, "its range is the others' x pi/180: the file's numbers read as degrees"),
                         (180.0 / np.pi, "its range is the others' x 180/pi: the file's numbers read as radians")):
        if np.allclose(np.array(odd), factor * np.array(majority), rtol=1e-9, atol=0.0):
            return text
    return ""


# quantity -> (applies to the joint (body record), same (x, y, details x, details y, rtol), text)
QUANTITIES = {
    "type": (lambda x: True, lambda x, y, dx, dy, r: x.kind == y.kind, lambda x, d: x.kind),
    "mass": (lambda x: True, lambda x, y, dx, dy, r: bool(np.isclose(x.mass, y.mass, rtol=r, atol=1e-12)),
             lambda x, d: _fmt(x.mass, "kg")),
    "centre of mass": (lambda x: True,
                       lambda x, y, dx, dy, r: np.linalg.norm(x.p_BCm_B - y.p_BCm_B) <= r * _length(x, y),
                       lambda x, d: _fmt(x.p_BCm_B, "m")),
    "inertia about the centre of mass": (
        lambda x: True,
        lambda x, y, dx, dy, r: np.abs(x.I_Cm_B - y.I_Cm_B).max() <= r * max(np.abs(x.I_Cm_B).max(), np.abs(y.I_Cm_B).max(), 1e-300),
        lambda x, d: _fmt(x.I_Cm_B, "kg m^2")),
    "position in parent": (lambda x: JOINTS.get(x.kind) is None or JOINTS[x.kind].constrained,
                           lambda x, y, dx, dy, r: np.linalg.norm(x.p_PB_P - y.p_PB_P) <= r * _length(x, y),
                           lambda x, d: _fmt(x.p_PB_P, "m")),
    "orientation in parent": (lambda x: JOINTS.get(x.kind) is None or JOINTS[x.kind].constrained,
                              lambda x, y, dx, dy, r: np.abs(x.R_PB - y.R_PB).max() <= max(r, 1e-12),
                              lambda x, d: "rotation vector " + _fmt(_rotvec(x.R_PB), "rad")),
    "axis": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
             lambda x, y, dx, dy, r: np.linalg.norm(x.axis_B - y.axis_B) <= max(r, 1e-12),
             lambda x, d: _fmt(x.axis_B)),
    "joint point": (lambda x: _has_point(x.kind),
                    lambda x, y, dx, dy, r: _point_gap(x, y, dx, dy) <= r * _length(x, y),
                    lambda x, d: _fmt(d.point_B, "m")),
    "range": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
              lambda x, y, dx, dy, r: _limits_close(dx.limits, dy.limits, r),
              lambda x, d: _range_text(d.limits, x.kind)),
    "damping": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                lambda x, y, dx, dy, r: bool(np.isclose(dx.damping, dy.damping, rtol=r, atol=1e-12)),
                lambda x, d: _fmt(d.damping, _unit("damping", x.kind))),
    "friction loss": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                      lambda x, y, dx, dy, r: bool(np.isclose(dx.friction, dy.friction, rtol=r, atol=1e-12)),
                      lambda x, d: _fmt(d.friction, _unit("friction loss", x.kind))),
    "armature": (lambda x: JOINTS.get(x.kind) is not None and JOINTS[x.kind].axis is not None,
                 lambda x, y, dx, dy, r: bool(np.isclose(dx.armature, dy.armature, rtol=r, atol=1e-12)),
                 lambda x, d: _fmt(d.armature, _unit("armature", x.kind))),
}

# a quantity a loader does not hold for a joint (None in its JointDetails) is not voted on
_DETAIL_FIELD = {"joint point": "point_B", "range": None, "damping": "damping", "friction loss": "friction",
                 "armature": "armature"}

# joint settings: counted when every loader reads one file, listed only between an MJCF and a URDF
SETTINGS = ("range", "damping", "friction loss", "armature")

# never counted: only MuJoCo applies a friction loss (Pinocchio stores it, Drake's parsers do not read it)
NOT_COUNTED = ("friction loss",)

# per joint setting, hinge unit and slide unit
_SETTING_UNITS = {"damping": ("N m s/rad", "N s/m"), "friction loss": ("N m", "N"), "armature": ("kg m^2", "kg"),
                  "range": ("rad", "m")}


def _unit(quantity: str, kind: str) -> str:
    """The unit of a joint setting (``_SETTING_UNITS``) for a joint of kind ``kind``: the slide's
    for a translational joint, else the hinge's."""
    hinge, slide = _SETTING_UNITS[quantity]
    jt = JOINTS.get(kind)
    return slide if jt is not None and jt.axis == TRANSLATIONAL else hinge


def _principal_rotation(Ia: np.ndarray, Ib: np.ndarray) -> float:
    """The smallest rotation angle (rad) taking the principal axes of inertia ``Ia`` onto those of
    ``Ib`` (each axis up to its sign); NaN when two principal moments coincide (axes not unique)."""
    ea, Va = np.linalg.eigh(Ia)
    eb, Vb = np.linalg.eigh(Ib)
    top = max(float(np.abs(ea).max()), 1e-300)
    if min(np.diff(ea).min(), np.diff(eb).min()) <= 1e-6 * top:
        return float("nan")
    best = np.pi
    for signs in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
        R = Vb @ np.diag(signs) @ Va.T
        if np.linalg.det(R) < 0:
            R = Vb @ np.diag([-s for s in signs]) @ Va.T
        best = min(best, float(np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))
    return best


def _difference(quantity: str, x: JointBody, y: JointBody, dx: JointDetails, dy: JointDetails, rtol: float) -> str:
    """By how much loader reading ``x`` differs from ``y`` in ``quantity``, in words with the unit
    ("" where there is no figure to give: type, presence)."""
    if quantity == "mass":
        dm, big = abs(x.mass - y.mass), max(x.mass, y.mass)
        return f"they differ by {dm:.6g} kg ({100 * dm / big:.3g}% of {big:.6g} kg)" if big > 0 else ""
    if quantity == "centre of mass":
        return f"they differ by {np.linalg.norm(x.p_BCm_B - y.p_BCm_B):.3g} m"
    if quantity == "inertia about the centre of mass":
        diff = float(np.abs(x.I_Cm_B - y.I_Cm_B).max())
        big = max(float(np.abs(x.I_Cm_B).max()), float(np.abs(y.I_Cm_B).max()), 1e-300)
        text = f"they differ by up to {diff:.3g} kg m^2 in an entry ({100 * diff / big:.3g}% of the largest entry)"
        ex, ey = np.linalg.eigvalsh(x.I_Cm_B), np.linalg.eigvalsh(y.I_Cm_B)
        if np.abs(ex - ey).max() <= rtol * max(float(np.abs(ey).max()), 1e-300):
            angle = _principal_rotation(x.I_Cm_B, y.I_Cm_B)
            text += ("; same principal moments: the same inertia in a rotated frame"
                     + (f" (principal axes turned by {angle:.3g} rad)" if np.isfinite(angle) else ""))
        else:
            text += f"; principal moments {_fmt(ex)} and {_fmt(ey)} kg m^2"
        return text
    if quantity == "position in parent":
        return f"they differ by {np.linalg.norm(x.p_PB_P - y.p_PB_P):.3g} m"
    if quantity == "orientation in parent":
        return f"they differ by a rotation of {np.linalg.norm(_rotvec(x.R_PB.T @ y.R_PB)):.3g} rad"
    if quantity == "axis":
        return f"the axes are {float(np.arccos(np.clip(x.axis_B @ y.axis_B, -1.0, 1.0))):.3g} rad apart"
    if quantity == "joint point":
        return f"the points are {_point_gap(x, y, dx, dy):.3g} m apart (across the axis)"
    if quantity == "range" and dx.limits is not None and dy.limits is not None:
        unit = _unit("range", x.kind)
        return (f"the lower bounds differ by {abs(dx.limits[0] - dy.limits[0]):.6g} {unit}, the upper by "
                f"{abs(dx.limits[1] - dy.limits[1]):.6g} {unit}")
    field_name = {"damping": "damping", "friction loss": "friction", "armature": "armature"}.get(quantity)
    if field_name is not None:
        return f"they differ by {abs(getattr(dx, field_name) - getattr(dy, field_name)):.6g} {_unit(quantity, x.kind)}"
    return ""


def _groups(labels: list[str], same) -> tuple[tuple[str, ...], ...]:
    """Loaders that agree, as connected groups of ``same``, largest first (ties in loader order)."""
    groups: list[list[str]] = []
    for a in labels:
        joined = [g for g in groups if any(same(a, b) for b in g)]
        merged = [a] + [b for g in joined for b in g]
        groups = [g for g in groups if g not in joined] + [sorted(merged, key=labels.index)]
    groups.sort(key=lambda g: (-len(g), labels.index(g[0])))
    return tuple(tuple(g) for g in groups)


def vote(readings: dict[str, Reading], rtol: float) -> list[Vote]:
    """Per joint (MuJoCo's order, then joints only other loaders have) and per quantity
    (``QUANTITIES``, in order), which of the loaders that read the file agree; then gravity.
    ``SETTINGS`` votes are not counted when the loaders read different files."""
    loaded = [r for r in readings.values() if r.loaded]
    one_file = len({r.source for r in loaded}) == 1
    labels = [r.loader for r in loaded]
    bodies = {r.loader: {x.joint: x for x in r.bodies} for r in loaded}
    details = {r.loader: {x.joint: x for x in r.details} for r in loaded}
    names: list[str] = []
    for r in loaded:
        names += [x.joint for x in r.bodies if x.joint not in names]
    out = []
    for name in names:
        have = [k for k in labels if name in bodies[k]]
        body = bodies[have[0]][name].body
        if len(have) < len(labels):
            values = {k: "present" if k in have else "absent" for k in labels}
            out.append(Vote(name, body, "present", values, _groups(labels, lambda a, b, vals=values: vals[a] == vals[b])))
        for quantity, (applies, same, text) in QUANTITIES.items():
            who = [k for k in have if applies(bodies[k][name])]
            if quantity in _DETAIL_FIELD:  # a loader without the detail (None) does not vote on it
                field_name = _DETAIL_FIELD[quantity]
                who = [k for k in who if name in details[k]
                       and (field_name is None or getattr(details[k][name], field_name) is not None)]
            if len(who) < 2:
                continue
            x = {k: bodies[k][name] for k in who}
            d = {k: details[k].get(name) for k in who}
            groups = _groups(who, lambda a, b, x=x, d=d, same=same: bool(same(x[a], x[b], d[a], d[b], rtol)))
            values = {k: text(x[k], d[k]) for k in who}
            counted = (one_file or quantity not in SETTINGS) and quantity not in NOT_COUNTED
            v = Vote(name, body, quantity, values, groups, counted=counted)
            detail, hint = "", ""
            if not v.agree and (v.odd is not None or len(who) == 2):
                a, b = (v.odd, groups[0][0]) if v.odd is not None else (who[0], who[1])
                detail = _difference(quantity, x[a], x[b], d[a], d[b], rtol)
            if v.odd is not None:
                hint = readings[v.odd].hints.get(quantity, "")
                if quantity == "range":
                    hint = _degrees_hint(d[v.odd].limits, d[groups[0][0]].limits) or hint
            if not v.agree and quantity == "mass":
                hint = hint or _geom_mass_hint(readings, x, [k for g in groups[1:] for k in g] + list(groups[0]))
            out.append(Vote(name, body, quantity, values, groups, hint, counted, detail))
    g = {r.loader: r.gravity for r in loaded if r.gravity is not None}
    if len(g) >= 2:
        groups = _groups(list(g), lambda a, b: np.linalg.norm(g[a] - g[b]) <= rtol * max(np.linalg.norm(g[a]), 1.0))
        v = Vote("", "", "gravity", {k: _fmt(val, "m/s^2") for k, val in g.items()}, groups)
        hint = readings[v.odd].hints.get("gravity", "") if v.odd is not None else ""
        if v.odd == "Pinocchio" and file_format(readings["Pinocchio"].source) == "MJCF":
            hint = "Pinocchio's MJCF parser ignores <option gravity>"
        elif not hint and not v.agree and file_format(readings["Pinocchio"].source) == "URDF":
            hint = "a URDF cannot state gravity: each loader's default"
        out.append(Vote("", "", "gravity", v.values, groups, hint))
    return out


def dynamics_odd(diffs: list[dc.TermDiff]) -> dict[str, str]:
    """Term -> the loader all the others agree against (three or four loaders compared pair by pair:
    every pair without it agrees, every pair with it differs). Only the loaders vote here; the
    witnesses are judged by ``witness_odd``."""
    out = {}
    for term in dc.TERMS:
        rows = [d for d in diffs if d.term == term and d.a in LOADERS and d.b in LOADERS]
        sources = {s for d in rows for s in (d.a, d.b)}
        n = len(sources)
        if n < 3 or len(rows) != n * (n - 1) // 2:
            continue
        for odd in sources:
            if all(d.passed != (odd in (d.a, d.b)) for d in rows):
                out[term] = odd
    return out


def witness_odd(diffs: list[dc.TermDiff]) -> dict[str, list[str]]:
    """Witness -> the terms in which it is the odd one out: it differs from MuJoCo (whose reading it
    was built from) while another loader agrees with MuJoCo in that term. A witness never makes a
    loader the odd one out (it is a witness of dynamics, built from MuJoCo's reading)."""
    out: dict[str, list[str]] = {}
    for term in dc.TERMS:
        rows = [d for d in diffs if d.term == term]
        confirmed = any(d.passed and "MuJoCo" in (d.a, d.b) and {d.a, d.b} <= set(LOADERS) for d in rows)
        for d in rows:
            other = d.b if d.a == "MuJoCo" else d.a if d.b == "MuJoCo" else None
            if other in wit.WITNESSES and not d.passed and confirmed:
                out.setdefault(other, []).append(term)
    return out


def _geom_mass_hint(readings: dict[str, Reading], x: dict[str, JointBody], who: list[str]) -> str:
    """The ``geom_masses`` text of MuJoCo's parts of a joint's body, when MuJoCo reads it."""
    mjr = readings.get("MuJoCo")
    if mjr is None or "MuJoCo" not in who or "MuJoCo" not in x or not mjr.geom_masses:
        return ""
    texts = [mjr.geom_masses[p.name] for p in x["MuJoCo"].parts if p.name in mjr.geom_masses]
    return "; ".join(texts)


def _who(loaders) -> str:
    loaders = list(loaders)
    return " and ".join(loaders) if len(loaders) <= 2 else ", ".join(loaders[:-1]) + " and " + loaders[-1]


def _reading(readings: dict[str, Reading], loaders) -> str:
    """``MuJoCo's reading (of the MJCF)``: the loaders' reading and the file they read."""
    loaders = list(loaders)
    formats = {file_format(readings[k].source) for k in loaders}
    return f"{_who(k + chr(39) + 's' for k in loaders)} reading" + (f" (of the {formats.pop()})" if len(formats) == 1 else "")

