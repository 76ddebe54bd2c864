"""Known importer limitations: the table ``harness check`` matches the loaders' disagreements against.

The table is ``known_limitations.toml`` next to this module (one ``[[limitation]]`` per entry):

* ``id``: kebab-case, unique; ``loaders``: the importers that read the element this way (MuJoCo,
  Pinocchio, Drake, PyBullet); ``format``: ``MJCF`` or ``URDF``; ``versions``: per loader, the versions it
  was verified on, ``"4.1.0"`` or an inclusive range ``"3.4.0 - 4.1.0"``;
* ``element``: the file element that triggers it; ``behaviour``: what the importer does;
  ``quantities``: the compared quantities it changes (``harness.tools.check.comparing.QUANTITIES``,
  ``present``, ``gravity``); ``workaround``: what the user can write instead, one line;
  ``upstream``: the upstream issue or documentation ("" where none was found); ``seen_in``: the zoo
  models that show it;
* ``detect``: the name of a detector in ``DETECTORS``, ``detector(res, vote, entry) -> bool``: the
  element is in the file where the disagreement is (a detector reads the file and the readings,
  never the size of the difference alone). An MJCF attribute is read as MuJoCo resolves it
  (``effective``: the element's own, else its default class's, the class from ``class=`` or the
  nearest ``childclass`` of its bodies, then the classes it is nested in, then the top-level
  default). The quantity ``refusal`` matches a loader that does not load the file
  (``match_refusal``).

A disagreement matches an entry when the entry's loaders that read the file all agree with each
other against the others (the odd one out, or the two that agree against a right third: only
MuJoCo honours ``settotalmass``), at versions within ``versions``, the file's format is the entry's,
the quantity is among ``quantities`` and the detector finds the element. A disagreement that matches no entry is
*unexplained*: what a user should report upstream (``harness.tools.check.classifying``). A newer
loader version than an entry states does not match it: the limitation may be fixed, so the
disagreement is unexplained until the entry is checked on that version.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from harness.model.input_files import model_format
from harness.tools.check.defects import NEGLIGIBLE_LENGTH
from harness.tools.check.file_elements import elements

TABLE = Path(__file__).with_name("known_limitations.toml")
FIELDS = ("id", "loaders", "format", "versions", "element", "behaviour", "quantities", "detect", "workaround", "upstream",
          "seen_in")


@dataclass(frozen=True)
class Limitation:
    """One entry of the table (module docstring)."""

    id: str
    loaders: tuple[str, ...]
    format: str
    versions: dict
    element: str
    behaviour: str
    quantities: tuple[str, ...]
    detect: str
    workaround: str = ""
    upstream: str = ""
    seen_in: tuple[str, ...] = ()

    def covers(self, loader: str, version: str) -> bool:
        """Whether ``loader`` at ``version`` lies within ``versions`` (one version, or ``low - high`` inclusive)."""
        if loader not in self.versions:
            return False
        low, _, high = (x.strip() for x in self.versions[loader].partition(" - "))
        v = _version(version)
        return _version(low) <= v <= _version(high or low)

    @property
    def brief(self) -> str:
        """The behaviour's first clause (the terminal's line; the report has all of it)."""
        return _first_clause(self.behaviour)

    @property
    def brief_workaround(self) -> str:
        return _first_clause(self.workaround)


def _first_clause(text: str) -> str:
    return re.split(r"; | \(|: ", text, maxsplit=1)[0].rstrip(".")


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in re.findall(r"\d+", text)[:3])


@cache
def table() -> tuple[Limitation, ...]:
    """The entries of ``known_limitations.toml``, checked: every field present, known detector, unique ids."""
    raw = tomllib.loads(TABLE.read_text(encoding="utf-8"))
    out = []
    for item in raw.get("limitation", []):
        missing = [f for f in FIELDS if f not in item]
        if missing or set(item) - set(FIELDS):
            raise ValueError(f"{TABLE.name}: entry {item.get('id')!r}: missing {missing}, unknown "
                             f"{sorted(set(item) - set(FIELDS))}")
        if item["detect"] not in DETECTORS:
            raise ValueError(f"{TABLE.name}: entry {item['id']!r}: unknown detector {item['detect']!r}")
        out.append(Limitation(item["id"], tuple(item["loaders"]), item["format"], dict(item["versions"]), item["element"],
                              item["behaviour"], tuple(item["quantities"]), item["detect"], item["workaround"],
                              item["upstream"], tuple(item["seen_in"])))
    ids = [x.id for x in out]
    if len(set(ids)) != len(ids):
        raise ValueError(f"{TABLE.name}: repeated ids")
    return tuple(out)


def match(res, vote, groups: tuple[tuple[str, ...], ...]) -> Limitation | None:
    """The first entry that explains the disagreement ``vote`` whose loaders fall into ``groups``
    (those that agree with each other; module docstring): all of the entry's loaders (those that
    read the file) in one group and none in the others, the format, their versions and the
    quantity the entry's, and its detector finds the element."""
    for entry in table():
        if vote.quantity not in entry.quantities:
            continue
        sides = [g for g in groups if set(g) & set(entry.loaders)]
        if len(sides) != 1:
            continue
        readers = [res.readings[k] for k in sides[0] if k in entry.loaders]
        if any(model_format(r.source) != entry.format or not entry.covers(r.loader, r.version) for r in readers):
            continue
        if _detects(entry, res, vote):
            return entry
    return None


def _detects(entry: Limitation, res, vote) -> bool:
    """The entry's detector on the file; a file whose attributes it cannot read (a malformed
    number) shows no element of it, never an error (the loaders have judged the file already)."""
    try:
        return bool(DETECTORS[entry.detect](res, vote, entry))
    except (ValueError, IndexError, KeyError, TypeError):
        return False


# --------------------------------------------------------------------------- the file's elements


def match_refusal(res, loader: str) -> Limitation | None:
    """The first entry that explains why ``loader`` does not load the file (quantity ``refusal``)."""
    r = res.readings[loader]
    for entry in table():
        if ("refusal" in entry.quantities and loader in entry.loaders and model_format(r.source) == entry.format
                and entry.covers(loader, r.version) and _detects(entry, res, None)):
            return entry
    return None


def _mjcf(res) -> Path:
    return res.readings["MuJoCo"].source


def _defaults(path: Path) -> dict[str, int]:
    """MJCF default class name -> index of its ``<default>`` element (the top-level one is ``main``)."""
    els = elements(path)
    out = {}
    for i, e in enumerate(els):
        if e.tag == "default":
            top = e.parent < 0 or els[e.parent].tag != "default"
            out.setdefault("main" if top and "class" not in e.attrs else e.attrs.get("class", "main"), i)
    return out


def element_class(path: Path, i: int) -> str:
    """The default class of element ``i``: its own ``class``, else the nearest ``childclass`` of its bodies, else ``main``."""
    els = elements(path)
    if "class" in els[i].attrs:
        return els[i].attrs["class"]
    j = els[i].parent
    while j >= 0:
        if "childclass" in els[j].attrs:
            return els[j].attrs["childclass"]
        j = els[j].parent
    return "main"


def effective(path: Path, i: int, attr: str):
    """Attribute ``attr`` of MJCF element ``i`` as MuJoCo resolves it (module docstring); None when unset."""
    els = elements(path)
    e = els[i]
    if attr in e.attrs:
        return e.attrs[attr]
    defaults = _defaults(path)
    d = defaults.get(element_class(path, i))
    while d is not None and d >= 0 and els[d].tag == "default":
        own = next((c for c in els if c.parent == d and c.tag == e.tag), None)
        if own is not None and attr in own.attrs:
            return own.attrs[attr]
        d = els[d].parent
    return None


def _index(path: Path, tag: str, name: str) -> int | None:
    return next((i for i, e in enumerate(elements(path)) if e.tag == tag and e.attrs.get("name") == name), None)


def _body_geoms(path: Path, body: str) -> list[int]:
    """Indices of the ``<geom>`` elements directly in the MJCF body named ``body``."""
    b = _index(path, "body", body)
    return [] if b is None else [i for i, e in enumerate(elements(path)) if e.tag == "geom" and e.parent == b]


def _has_inertial(path: Path, body: str) -> bool:
    b = _index(path, "body", body)
    return b is not None and any(e.tag == "inertial" and e.parent == b for e in elements(path))


def _mass_bodies(res, vote) -> list[str]:
    """The joint's body and the fixed bodies merged into it, without an ``<inertial>`` of their own."""
    mj = next((x for x in res.readings["MuJoCo"].bodies if x.joint == vote.joint), None)
    names = [vote.body] + ([p.name for p in mj.parts] if mj is not None else [])
    return [n for n in dict.fromkeys(names) if not _has_inertial(_mjcf(res), n)]


def _joint_index(res, vote) -> int | None:
    return _index(_mjcf(res), "joint", vote.joint)


# --------------------------------------------------------------------------- detectors


def _default_geom_mass(res, vote, entry) -> bool:
    """A geom of the joint's body (or of a fixed body merged into it, without an ``<inertial>``) has
    no ``mass`` of its own but one from its default class."""
    path = _mjcf(res)
    return any("mass" not in elements(path)[g].attrs and effective(path, g, "mass") is not None
               for b in _mass_bodies(res, vote) for g in _body_geoms(path, b))


def _visual_geom_mass(res, vote, entry) -> bool:
    """A geom of the joint's body (no ``<inertial>``) with ``contype`` and ``conaffinity`` 0 (visual only)."""
    path = _mjcf(res)
    return any(effective(path, g, "contype") == "0" and effective(path, g, "conaffinity") == "0"
               for b in _mass_bodies(res, vote) for g in _body_geoms(path, b))


def _mesh_geom_mass(res, vote, entry) -> bool:
    """A colliding mesh geom in the joint's body (no ``<inertial>``)."""
    path = _mjcf(res)
    return any(effective(path, g, "type") == "mesh"
               and not (effective(path, g, "contype") == "0" and effective(path, g, "conaffinity") == "0")
               for b in _mass_bodies(res, vote) for g in _body_geoms(path, b))


def _first_body_only(res, vote, entry) -> bool:
    """The joint belongs to a kinematic tree after the first under ``<worldbody>`` (Pinocchio's
    reading lacks it: ``Reading.partial``)."""
    return any(vote.joint in r.partial for r in res.readings.values() if r.loaded)


def _range_in_degrees(res, vote, entry) -> bool:
    """A slide joint's range read as if it were in degrees (the values' ratio is pi / 180)."""
    return "degree" in vote.hint


def _unlimited_range(res, vote, entry) -> bool:
    """The joint states a ``range`` (its own or its class's) with ``limited="false"``."""
    j = _joint_index(res, vote)
    return j is not None and effective(_mjcf(res), j, "range") is not None \
        and effective(_mjcf(res), j, "limited") == "false"


def _range_with_ref(res, vote, entry) -> bool:
    """A limited joint with a non-zero ``ref``."""
    j = _joint_index(res, vote)
    ref = effective(_mjcf(res), j, "ref") if j is not None else None
    return ref is not None and float(ref) != 0.0 and effective(_mjcf(res), j, "range") is not None


def _default_joint_pos(res, vote, entry) -> bool:
    """A joint without ``pos`` of its own whose class gives it a non-zero one."""
    j = _joint_index(res, vote)
    if j is None or "pos" in elements(_mjcf(res))[j].attrs:
        return False
    pos = effective(_mjcf(res), j, "pos")
    return pos is not None and any(float(x) != 0.0 for x in pos.split())


def _springdamper(res, vote, entry) -> bool:
    """A joint whose damping MuJoCo computes from ``springdamper`` (time constant > 0)."""
    j = _joint_index(res, vote)
    sd = effective(_mjcf(res), j, "springdamper") if j is not None else None
    return sd is not None and float(sd.split()[0]) > 0.0


def _several_joints(res, vote, entry) -> bool:
    """The joint is one of several of its body, not the last."""
    path = _mjcf(res)
    j = _joint_index(res, vote)
    if j is None:
        return False
    els = elements(path)
    siblings = [i for i, e in enumerate(els) if e.tag == "joint" and e.parent == els[j].parent]
    return len(siblings) > 1 and j != siblings[-1]


def _default_class_gap(res, vote, entry) -> bool:
    """The joint's class (or one above it, below the class that sets the attribute) has no ``<joint>``
    default of its own, while a class above it sets the compared attribute."""
    path = _mjcf(res)
    j = _joint_index(res, vote)
    if j is None or vote.quantity in elements(path)[j].attrs:
        return False
    els, defaults = elements(path), _defaults(path)
    d = defaults.get(element_class(path, j))
    gap = False
    while d is not None and d >= 0 and els[d].tag == "default":
        own = next((c for c in els if c.parent == d and c.tag == "joint"), None)
        if own is None:
            gap = True
        elif vote.quantity in own.attrs:
            return gap
        d = els[d].parent
    return False


def _armature_without_actuator(res, vote, entry) -> bool:
    """A joint with an armature and no ``<motor>`` or ``<position>`` actuator on it."""
    path = _mjcf(res)
    j = _joint_index(res, vote)
    arm = effective(path, j, "armature") if j is not None else None
    if arm is None or float(arm) == 0.0:
        return False
    return not any(e.tag in ("motor", "position") and e.attrs.get("joint") == vote.joint for e in elements(path))


def _settotalmass(res, vote, entry) -> bool:
    """The MJCF's ``<compiler settotalmass>`` is set (only MuJoCo applies it)."""
    return any(e.tag == "compiler" and "settotalmass" in e.attrs and float(e.attrs["settotalmass"]) > 0
               for e in elements(_mjcf(res)))


def _option_gravity(res, vote, entry) -> bool:
    """The MJCF's ``<option gravity>`` differs from (0, 0, -9.81) m/s^2."""
    for e in elements(_mjcf(res)):
        if e.tag == "option" and "gravity" in e.attrs:
            g = [float(x) for x in e.attrs["gravity"].split()]
            return len(g) == 3 and not all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(g, (0.0, 0.0, -9.81)))
    return False


def _gravity_disabled(res, vote, entry) -> bool:
    """The MJCF disables gravity with ``<option><flag gravity="disable"/>``."""
    els = elements(_mjcf(res))
    return any(e.tag == "flag" and e.attrs.get("gravity") == "disable" and e.parent >= 0
               and els[e.parent].tag == "option" for e in els)


def _hfield(res, vote, entry) -> bool:
    """The MJCF has a height field."""
    return any(e.tag == "hfield" or (e.tag == "geom" and e.attrs.get("type") == "hfield") for e in elements(_mjcf(res)))


def _no_body(res, vote, entry) -> bool:
    """The MJCF's ``<worldbody>`` holds no ``<body>``."""
    els = elements(_mjcf(res))
    return not any(e.tag == "body" for e in els)


def _non_obj_mesh(res, vote, entry) -> bool:
    """The MJCF names a mesh file that is not ``.obj``."""
    return any(e.tag == "mesh" and "file" in e.attrs and not e.attrs["file"].lower().endswith(".obj")
               for e in elements(_mjcf(res)))


def _moving_link_inertials(path: Path):
    """``(link name, mass element or None, inertia element or None)`` of every URDF link a non-fixed
    joint moves, in the file's order (its ``<inertial>``'s ``<mass>`` and ``<inertia>``)."""
    els = elements(path)
    moved = {e.attrs.get("link") for e in els if e.tag == "child" and e.parent >= 0
             and els[e.parent].tag == "joint" and els[e.parent].attrs.get("type", "fixed") != "fixed"}
    for i, e in enumerate(els):
        if e.tag != "link" or e.attrs.get("name") not in moved:
            continue
        inertial = next((j for j, x in enumerate(els) if x.tag == "inertial" and x.parent == i), None)
        child = {x.tag: x for x in els if inertial is not None and x.parent == inertial}
        yield e.attrs["name"], child.get("mass"), child.get("inertia")


def _massless_moving_link(res, vote, entry) -> bool:
    """A URDF link that a non-fixed joint moves and that states no mass (no ``<inertial>``, or mass 0)."""
    return any(mass is None or float(mass.attrs.get("value", "0")) == 0.0
               for _, mass, _ in _moving_link_inertials(_mjcf(res)))


def _singular_moving_inertia(res, vote, entry) -> bool:
    """A URDF link that a non-fixed joint moves, of positive mass, with a principal moment of inertia
    below that of a body a tenth of a millimetre across (``defects.NEGLIGIBLE_LENGTH``): zero but for round-off."""
    for _, mass, tensor in _moving_link_inertials(_mjcf(res)):
        if mass is None or tensor is None or float(mass.attrs.get("value", "0")) <= 0:
            continue
        t = {k: float(tensor.attrs.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        moments = np.linalg.eigvalsh(np.array([[t["ixx"], t["ixy"], t["ixz"]], [t["ixy"], t["iyy"], t["iyz"]],
                                               [t["ixz"], t["iyz"], t["izz"]]]))
        if moments[0] <= float(mass.attrs["value"]) * NEGLIGIBLE_LENGTH**2:
            return True
    return False


def explain_refusal(path: Path, loader: str, version: str) -> Limitation | None:
    """The entry that explains why ``loader`` refuses the file ``path`` (quantity ``refusal``), when
    no reading of it exists (MuJoCo's refusal stops the check)."""
    from types import SimpleNamespace

    reading = SimpleNamespace(source=Path(path), loader=loader, version=version, loaded=False)
    res = SimpleNamespace(readings={"MuJoCo": reading, loader: reading})
    return match_refusal(res, loader)


def _pybullet_inertia_default(res, vote, entry) -> bool:
    """PyBullet, loaded a second time without ``URDF_USE_INERTIA_FROM_FILE``, reads another inertia for
    the vote's joint than with the flag (``Reading.inertia_trap``), and the URDF states an ``<inertia>``."""
    r = res.readings.get("PyBullet")
    if r is None or not any(t.joint == vote.joint for t in r.inertia_trap):
        return False
    return any(e.tag == "inertia" for e in elements(r.source))


def _pybullet_parts_without_inertial(res, vote) -> list[str]:
    """The URDF links merged into the vote's joint body in PyBullet's reading that state no ``<inertial>``."""
    r = res.readings.get("PyBullet")
    body = next((x for x in r.bodies if x.joint == vote.joint), None) if r is not None and r.loaded else None
    if body is None:
        return []
    names = {p.name for p in body.parts} | {vote.body}
    els = elements(r.source)
    with_inertial = {els[e.parent].attrs.get("name") for e in els if e.tag == "inertial" and e.parent >= 0}
    return [e.attrs["name"] for e in els if e.tag == "link" and e.attrs.get("name") in names
            and e.attrs["name"] not in with_inertial]


def _pybullet_missing_inertial(res, vote, entry) -> bool:
    """A URDF link merged into the vote's joint body that states no ``<inertial>`` (PyBullet gives it 1 kg)."""
    return bool(_pybullet_parts_without_inertial(res, vote))


def _pybullet_products_of_inertia(res, vote, entry) -> bool:
    """A link merged into the vote's joint body in PyBullet's reading whose URDF ``<inertia>`` states a
    non-zero product of inertia (PyBullet diagonalizes it)."""
    r = res.readings.get("PyBullet")
    body = next((x for x in r.bodies if x.joint == vote.joint), None) if r is not None and r.loaded else None
    if body is None:
        return False
    names = {p.name for p in body.parts}
    if _pybullet_parts_without_inertial(res, vote):   # PyBullet's 1 kg default explains it, not the rounding
        return False
    els = elements(r.source)
    for i, e in enumerate(els):
        if e.tag != "link" or e.attrs.get("name") not in names:
            continue
        for t in els:
            if (t.tag == "inertia" and t.parent >= 0 and els[t.parent].tag == "inertial" and els[t.parent].parent == i
                    and any(float(t.attrs.get(k, "0")) != 0.0 for k in ("ixy", "ixz", "iyz"))):
                return True
    return False


def _dynamics_armature(res, vote, entry) -> bool:
    """M differs by exactly an armature on its diagonal (a ``dynamics armature`` finding, ``harness.tools.check.causes``)."""
    return any(f.kind == "dynamics armature" for f in res.findings)


DETECTORS = {
    "pybullet_missing_inertial": _pybullet_missing_inertial,
    "singular_moving_inertia": _singular_moving_inertia,
    "dynamics_armature": _dynamics_armature,
    "pybullet_inertia_default": _pybullet_inertia_default,
    "pybullet_products_of_inertia": _pybullet_products_of_inertia,
    "massless_moving_link": _massless_moving_link,
    "default_geom_mass": _default_geom_mass,
    "visual_geom_mass": _visual_geom_mass,
    "mesh_geom_mass": _mesh_geom_mass,
    "first_body_only": _first_body_only,
    "range_in_degrees": _range_in_degrees,
    "unlimited_range": _unlimited_range,
    "range_with_ref": _range_with_ref,
    "default_joint_pos": _default_joint_pos,
    "springdamper": _springdamper,
    "several_joints": _several_joints,
    "default_class_gap": _default_class_gap,
    "armature_without_actuator": _armature_without_actuator,
    "settotalmass": _settotalmass,
    "option_gravity": _option_gravity,
    "gravity_disabled": _gravity_disabled,
    "hfield": _hfield,
    "no_body": _no_body,
    "non_obj_mesh": _non_obj_mesh,
}
