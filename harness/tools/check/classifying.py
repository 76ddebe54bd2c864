"""The verdict classes of ``harness check``: what a robotics engineer does about each finding.

* *defect in your file* (``DEFECT``): the file itself is wrong, whatever an importer makes of it
  (``harness.tools.check.defects``): fix the element named (file, line) as the fix line says; or,
  checked as a pair, the MJCF and the URDF state different values (``TWO_FILES``: each file's
  readers agree with each other against the other file's).
  A disagreement between the loaders on the mass properties of the body a defect ends up in
  follows from it and is listed under it, not as an importer's;
* *importer disagreement* (``IMPORTER``): the loaders read a valid element differently. Each is
  matched against the table of known limitations (``known_limitations``): *known* (the loader,
  the element, the upstream reference and a workaround) or *unexplained*, what a user should
  report upstream (with the file and the figures of the report);
* *consistent* (``CONSISTENT``): every compared quantity agrees (the loaders' joints, masses,
  inertias, placements, axes, settings and gravity; the dynamics terms at random states; the free
  motion, judged by how MuJoCo's and Pinocchio's difference converges);
* *not compared* (``NOT_COMPARED``): what the check holds but does not compare, named as the file
  names it, with why (a mimic joint, an equality constraint: weld, connect, joint coupling; a
  tendon; actuators; a loader that does not load the file).

The file's class is the first of defect, importer disagreement and consistent that applies;
*not compared* is listed beside it. The witnesses (the in-house engine and Exudyn, built from
MuJoCo's reading) never vote on the file: their free motion is judged by convergence and reported
apart (``witness_line``). ``harness check`` exits 1 when the file has a defect or an unexplained
disagreement, 0 otherwise (a known limitation is reported, with its workaround, and does not fail).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import SimpleNamespace

from harness.judging.error_model import CONVERGES, NOT_JUDGED
from harness.model.errors import InputError
from harness.model.input_files import model_format
from harness.tools.check.defects import Defect
from harness.tools.check.known_limitations import Limitation, elements, match, match_refusal
from harness.tools.check.results import LOADERS, TRAP_QUANTITY, CheckResult, _who

DEFECT = "defect in your file"
IMPORTER = "importer disagreement"
CONSISTENT = "consistent"
NOT_COMPARED = "not compared"
CLASSES = (DEFECT, IMPORTER, CONSISTENT, NOT_COMPARED)

FROM_DEFECT = "follows from a defect"
#: The kind of defect of an MJCF and a URDF of one robot that state different values.
TWO_FILES = "MJCF and URDF disagree"
KNOWN = "known limitation"
UNEXPLAINED = "unexplained"

#: The quantities a defect of a body's inertial changes, and those of a joint's axis.
MASS_QUANTITIES = ("mass", "centre of mass", "inertia about the centre of mass")
_DEFECT_QUANTITIES = {"zero-length axis": ("axis", "joint point")}


class DefectRefusal(InputError):
    """A defect of the file no loader can run (``Defect.fatal``): bad input, one line with where it
    is, what is wrong and the fix; ``defect``, and ``finding`` (the line without where)."""

    def __init__(self, defect: Defect):
        self.defect = defect
        self.finding = f"{defect.element}: {defect.what}; fix: {defect.fix}"
        where = f"{defect.file}:{defect.line}" if defect.line else str(defect.file)
        super().__init__(f"{where}: {DEFECT}: {self.finding}")


class KnownRefusal(InputError):
    """A loader every check needs refuses a valid file, as a known limitation explains: the
    loader's refusal ``err`` with ``limitation`` (its id, behaviour and workaround) and ``finding``."""

    def __init__(self, err: Exception, loader: str, limitation: Limitation):
        self.limitation = limitation
        self.finding = (f"{loader}'s importer, {limitation.id}: {limitation.brief}; workaround: "
                        f"{limitation.brief_workaround}")
        super().__init__(f"{err} (a known limitation of {self.finding})")


@dataclass(frozen=True)
class Disagreement:
    """The loaders read one element differently. ``element``: where (``joint 'x' (body 'y')``,
    ``model``, ``dynamics``, ``free motion``); ``quantity``; ``loaders``: those that read it
    differently (the odd one out; every loader where no two agree); ``between``: who against whom;
    ``text``: the values and by how much they differ; ``limitation`` / ``defect``: what explains it."""

    element: str
    quantity: str
    loaders: tuple[str, ...]
    between: str
    text: str
    limitation: Limitation | None = None
    defect: Defect | None = None

    @property
    def status(self) -> str:
        return FROM_DEFECT if self.defect is not None else KNOWN if self.limitation is not None else UNEXPLAINED


@dataclass(frozen=True)
class Uncompared:
    """Something the check holds but does not compare: ``what`` (named as the file names it), ``why``."""

    what: str
    why: str


@dataclass
class Classification:
    """The classes of one check (module docstring)."""

    defects: list[Defect] = field(default_factory=list)
    disagreements: list[Disagreement] = field(default_factory=list)
    uncompared: list[Uncompared] = field(default_factory=list)
    agreeing: int = 0   # compared quantities and terms on which the loaders agree
    #: PyBullet's inertia trap (``inertia_trap``): its default load against the file, one per joint; named
    #: apart (the summary's line, the report's importer section), never a disagreement between the loaders
    trap: list = field(default_factory=list)

    @property
    def importer(self) -> list[Disagreement]:
        return [d for d in self.disagreements if d.status != FROM_DEFECT]

    @property
    def from_defects(self) -> list[Disagreement]:
        """The loaders' disagreements that follow from a defect of the file."""
        return [d for d in self.disagreements if d.status == FROM_DEFECT]

    @property
    def known(self) -> list[Disagreement]:
        return [d for d in self.disagreements if d.status == KNOWN]

    @property
    def unexplained(self) -> list[Disagreement]:
        return [d for d in self.disagreements if d.status == UNEXPLAINED]

    @property
    def file_class(self) -> str:
        return DEFECT if self.defects else IMPORTER if self.importer else CONSISTENT

    @property
    def passed(self) -> bool:
        """No defect in the file and no unexplained disagreement (a known limitation does not fail)."""
        return not self.defects and not self.unexplained

    @property
    def counts(self) -> dict[str, int]:
        return {DEFECT: len(self.defects), IMPORTER: len(self.importer), CONSISTENT: self.agreeing,
                NOT_COMPARED: len(self.uncompared)}

    def counts_line(self) -> str:
        """``defect in your file 2 | importer disagreement 3 (known 2, unexplained 1) | consistent 140 | not compared 1``."""
        c = self.counts
        return (f"{DEFECT} {c[DEFECT]} | {IMPORTER} {c[IMPORTER]} (known {len(self.known)}, unexplained "
                f"{len(self.unexplained)}) | {CONSISTENT} {c[CONSISTENT]} | {NOT_COMPARED} {c[NOT_COMPARED]}")

    def groups(self) -> list[tuple[str, list[Disagreement]]]:
        """The importer disagreements grouped by what explains them (a limitation's id, else each on
        its own), unexplained first."""
        out: dict[str, list[Disagreement]] = {}
        for d in sorted(self.importer, key=lambda d: d.status != UNEXPLAINED):
            key = d.limitation.id if d.limitation is not None else f"{d.element}|{d.quantity}|{d.between}"
            out.setdefault(key, []).append(d)
        return list(out.items())


def _involved(v) -> tuple[str, ...]:
    if v.odd is not None:
        return (v.odd,)
    return tuple(k for g in v.groups for k in g)


def _between(v) -> str:
    if v.odd is not None:
        return f"{v.odd} against {_who(v.groups[0])}"
    return " vs ".join("/".join(g) for g in v.groups)


def _files_split(res: CheckResult, v) -> Defect | None:
    """A disagreement between the readers of an MJCF and those of a URDF (each file's readers agree
    with each other): the two files state different values, a defect of the pair (``TWO_FILES``)."""
    if not res.two_files or len(v.groups) != 2:
        return None
    sources = [{res.readings[k].source for k in g} for g in v.groups]
    if any(len(s) != 1 for s in sources) or sources[0] == sources[1]:
        return None
    urdf = next(iter(s for s in sources if model_format(next(iter(s))) == "URDF"), sources[1])
    element = f"joint {v.joint!r} (body {v.body!r})" if v.joint else "gravity"
    return Defect(TWO_FILES, next(iter(urdf)), None, element, v.message,
                  f"make the MJCF and the URDF state the same {v.quantity} for {element}", v.body,
                  brief=v.quantity)


def _pairs_with_model_differences(res: CheckResult) -> set[frozenset]:
    pairs = set()
    for v in res.votes:
        if v.agree or not v.counted:
            continue
        for a in v.groups[0]:
            for g in v.groups[1:]:
                for b in g:
                    pairs.add(frozenset((a, b)))
    return pairs


def classify(res: CheckResult) -> Classification:
    """The classes of a finished check (module docstring)."""
    from harness.tools.check.comparing import dynamics_odd

    out = Classification(defects=list(res.defects))
    owners: dict[str, list[Defect]] = {}
    for d in res.defects:
        if d.owner:
            owners.setdefault(d.owner, []).append(d)
    for v in res.votes:
        if not v.counted:
            continue
        if v.agree:
            out.agreeing += 1
            continue
        involved = _involved(v)
        files_split = _files_split(res, v)
        if files_split is not None:   # the MJCF and the URDF state different values: the files disagree
            out.defects.append(files_split)
            out.disagreements.append(Disagreement(f"joint {v.joint!r} (body {v.body!r})" if v.joint else "model",
                                                  v.quantity, involved, _between(v), v.message, None, files_split))
            continue
        cause = next((d for d in owners.get(v.body, []) if v.quantity in _DEFECT_QUANTITIES.get(d.kind, MASS_QUANTITIES)),
                     None) or next((d for d in res.defects if d.joint and d.joint == v.joint and v.quantity == "range"),
                                   None)
        limitation = None if cause is not None else match(res, v, v.groups)
        element = f"joint {v.joint!r} (body {v.body!r})" if v.joint else "model"
        out.disagreements.append(Disagreement(element, v.quantity, involved, _between(v), v.message, limitation, cause))
    out.trap = inertia_trap(res)
    # the dynamics terms: a pair whose models differ differs in its terms as a consequence
    model_pairs = _pairs_with_model_differences(res)
    odd = dynamics_odd(res.dynamics)
    seen = set()
    for d in res.dynamics:
        if d.passed:
            out.agreeing += 1
            continue
        if frozenset((d.a, d.b)) in model_pairs or (d.term, odd.get(d.term)) in seen:
            continue
        loaders = (odd[d.term],) if d.term in odd else (d.a, d.b)
        seen.add((d.term, odd.get(d.term)))
        probe = SimpleNamespace(joint="", body="", quantity=f"dynamics {d.term}", hint="", odd=None, groups=())
        limitation = match(res, probe, ((d.a,), (d.b,)) if d.term not in odd else
                           (tuple(k for k in (d.a, d.b) if k != odd[d.term]), (odd[d.term],)))
        between = (f"{loaders[0]} against the others" if len(loaders) == 1 else f"{d.a} vs {d.b}")
        out.disagreements.append(Disagreement("dynamics", d.term, loaders, between,
                                              f"dynamics {d.term}: max abs {d.max_abs:.3g}, max relative "
                                              f"{d.max_rel:.2g} ({d.a} vs {d.b})", limitation))
    # the free motion: differences that converge agree; a floor where the models and terms agree is unexplained
    loader_pair = frozenset(("MuJoCo", "Pinocchio"))
    bad = [f for f in res.free if not f.passed]
    if res.free and not bad:
        out.agreeing += 1
    elif bad and all(m.classification == NOT_JUDGED for f in bad for m in f.models.values()):
        pass   # nothing to fit (no other level ran to the end): listed under not compared (``uncompared``)
    elif bad and loader_pair not in model_pairs and not any(x.element == "dynamics" for x in out.disagreements):
        f = bad[0]
        e = next(m for m in f.models.values() if m.classification != CONVERGES) if f.models else None
        why = f"{e.quantity}: {e.classification} ({e.reason})" if e is not None else "no run"
        out.disagreements.append(Disagreement("free motion", "free motion", ("MuJoCo", "Pinocchio"), "MuJoCo vs Pinocchio",
                                              f"free motion from state {f.state}: {why}"))
    out.uncompared = uncompared(res)
    return out


def inertia_trap(res: CheckResult) -> list[Disagreement]:
    """PyBullet's inertia trap: per joint whose inertia PyBullet reads otherwise without
    ``URDF_USE_INERTIA_FROM_FILE`` (its default; ``Reading.inertia_trap``), an importer disagreement of
    PyBullet's default against the file, matched against the known limitations (known where the entry
    covers the version: it does not fail the check)."""
    r = res.readings.get("PyBullet")
    if r is None or not r.loaded:
        return []
    others = tuple(k for k in LOADERS if k != r.loader and k in res.readings and res.readings[k].loaded)
    out = []
    for t in r.inertia_trap:
        probe = SimpleNamespace(joint=t.joint, body=t.body, quantity=TRAP_QUANTITY, hint="", odd=r.loader,
                                groups=(others, (r.loader,)))
        out.append(Disagreement(f"joint {t.joint!r} (body {t.body!r})", TRAP_QUANTITY, (r.loader,),
                                f"{r.loader} without URDF_USE_INERTIA_FROM_FILE against the file", t.text,
                                match(res, probe, probe.groups)))
    return out


# --------------------------------------------------------------------------- not compared


def urdf_mimics(res: CheckResult) -> list[tuple[str, str, str, str]]:
    """(joint, followed joint, multiplier, offset) of every URDF ``<mimic>`` among the files the loaders read."""
    out = []
    for source in dict.fromkeys(r.source for r in res.readings.values()):
        if model_format(source) != "URDF":
            continue
        els = elements(source)
        for e in els:
            if e.tag == "mimic" and e.parent >= 0 and els[e.parent].tag == "joint":
                out.append((els[e.parent].attrs.get("name", "?"), e.attrs.get("joint", "?"),
                            e.attrs.get("multiplier", "1"), e.attrs.get("offset", "0")))
    return list(dict.fromkeys(out))


def uncompared(res: CheckResult) -> list[Uncompared]:
    """What the check holds but does not compare, named as the file names it (module docstring)."""
    out = []
    mimics = urdf_mimics(res)
    for joint, leader, k, offset in mimics:
        out.append(Uncompared(f"mimic joint {joint!r} (follows {leader!r} x {k} + {offset})",
                              "each loader holds it its own way (MuJoCo an equality constraint, Pinocchio and Drake an "
                              "independent joint): compared as an independent joint, the coupling is not"))
    for line in res.not_compared:
        if mimics and "equality constraint" in line:
            continue   # MuJoCo's equalities of the mimic joints, named above
        kind = ("equality constraints couple what the tree leaves free (a closed loop, a weld, a joint coupling): the "
                "loaders' trees are compared, the constraints are not" if "equality" in line else
                "only MuJoCo reads tendons" if "tendon" in line else
                "Pinocchio reads no actuators; MuJoCo's and Drake's gears are listed in the report, not compared")
        out.append(Uncompared(line, kind))
    for r in res.readings.values():
        if not r.loaded and not r.other_format:
            known = match_refusal(res, r.loader)
            out.append(Uncompared(f"{r.loader}'s reading", f"it does not load the file: {r.refusal}"
                                  + (f" (known: {known.id}; workaround: {known.workaround})" if known else "")))
        elif r.dynamics:
            out.append(Uncompared(f"{r.loader}'s dynamics terms", r.dynamics))
    if res.free_skipped:
        out.append(Uncompared("free motion", res.free_skipped))
    unjudged = [f for f in res.free if f.models and all(m.classification == NOT_JUDGED for m in f.models.values())]
    if unjudged:
        out.append(Uncompared(f"free motion from state {unjudged[0].state}",
                              next(iter(unjudged[0].models.values())).reason))
    return out


# --------------------------------------------------------------------------- the witnesses


def witness_line(res: CheckResult) -> str:
    """One line on the witnesses (never a vote on the file): how their free motion converges."""
    w = res.witnesses
    if w is None:
        return "witnesses: not asked for (--no-witnesses)"
    if w.refusal:
        return f"witnesses (in-house, Exudyn): not run: {w.refusal}"
    parts = []
    held = sorted({r.witness for r in w.rows if not r.ok})
    for label in ("in-house", "Exudyn"):
        runs = [f for f in w.free if f.witness == label]
        if label in held:
            parts.append(f"{label} holds another model than MuJoCo's reading")
        elif not runs:
            parts.append(f"{label}: no free motion")
        elif all(f.passed for f in runs):
            orders = [m.observed_order for f in runs for m in f.models.values() if not math.isnan(m.observed_order)]
            parts.append(f"{label} converges" + (f" (order {min(orders):.1f})" if orders else " (at the resolution)"))
        else:
            bad = next(f for f in runs if not f.passed)
            parts.append(f"{label} {bad.summary} (state {bad.state})")
    w_dyn = [d for d in w.dynamics if not d.passed and d.a == "MuJoCo"]
    if w_dyn:
        parts.append(f"in-house dynamics {', '.join(d.term for d in w_dyn)} differ from MuJoCo's")
    return "witnesses (never vote): " + "; ".join(parts)


def loaders_loaded(res: CheckResult) -> list[str]:
    return [k for k in LOADERS if k in res.readings and res.readings[k].loaded]
