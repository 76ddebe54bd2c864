"""The check's verdict line, its Markdown report (``render_report``, ``write_report``) and what the command
prints (``summary_lines``)."""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import mujoco
import numpy as np

from harness.io import atomic
from harness.judging.error_model import CONVERGES
from harness.tools import witnesses as wit
from harness.tools.check.classifying import (CONSISTENT, DEFECT, IMPORTER, NOT_COMPARED, loaders_loaded,
                                             witness_line)
from harness.tools.check.results import CheckResult, LOADERS, Reading, Vote
from harness.tools.check.comparing import QUANTITIES, _DETAIL_FIELD, _who, dynamics_odd, witness_odd
from harness.tools.check.reading import _few
from harness.tools.check.dynamics import _whole_trees


# --------------------------------------------------------------------------- report


def _v(x, digits=6) -> str:
    return "[" + ", ".join(f"{float(c):.{digits}g}" for c in np.ravel(x)) + "]"


def verdict(res: CheckResult) -> str:
    """The file's class and what makes it so, in one line (``harness.tools.check.classifying``):
    the defects (kind and element), the importer disagreements (the loader and the known limitation,
    or unexplained), what is not compared, and the loaders that do not load the file."""
    c = res.classes
    parts = []
    if c.defects:
        kinds: dict[str, list[str]] = {}
        for d in c.defects:
            kinds.setdefault(d.kind, []).append(d.element)
        parts.append(f"{DEFECT}: " + "; ".join(f"{k} ({_few(els, 3)})" for k, els in kinds.items()))
        if c.from_defects:
            parts.append(f"{len(c.from_defects)} loader disagreement(s) follow from them")
    for key, group in c.groups():
        parts.append(f"{IMPORTER}: {_group_text(group)}")
    if not parts:
        parts.append(f"{CONSISTENT}: {_who(loaders_loaded(res))} agree on {c.agreeing} compared quantities "
                     "and terms")
    if c.uncompared:
        parts.append(f"{NOT_COMPARED}: " + _few([u.what for u in c.uncompared], 3))
    if c.trap:
        parts.append(f"PyBullet's inertia trap: without URDF_USE_INERTIA_FROM_FILE, other inertias on {len(c.trap)} "
                     f"joint(s)" + (f" (known: {c.trap[0].limitation.id})" if c.trap[0].limitation else " (unexplained)"))
    return "; ".join(parts)


def _group_text(group) -> str:
    """One group of importer disagreements (``Classification.groups``) in a few words."""
    d = group[0]
    where = _few(dict.fromkeys(x.element.split(" (body")[0].removeprefix("joint ") for x in group), 3)
    if d.limitation is not None:
        return f"{' and '.join(d.limitation.loaders)} {d.limitation.brief} (known: {d.limitation.id}; {where})"
    return f"{' and '.join(d.loaders)} read(s) {d.quantity} differently, unexplained ({where})"


def _fix_text(group) -> str:
    d = group[0]
    if d.limitation is not None:
        return (f"workaround: {d.limitation.brief_workaround}"
                + (f" ({d.limitation.upstream})" if d.limitation.upstream else ""))
    return (f"report upstream to {' and '.join(d.loaders)}: {d.between}, {d.quantity} of {d.element} "
            "(the report has the figures)")


def top_findings(res: CheckResult, trap: bool = True) -> list[tuple[str, str]]:
    """(what, what to do) of every finding, in the order a user acts on them: the defects with
    their fix, then the importer disagreements (unexplained first: report upstream; then the known
    limitations with their workaround); ``trap=False``: without PyBullet's inertia trap (``trap_line``)."""
    c = res.classes
    return ([(d.short, f"fix: {d.fix}") for d in c.defects]
            + [(_group_text(g), _fix_text(g)) for _, g in c.groups()]
            + ([(_group_text(c.trap), _fix_text(c.trap))] if trap and c.trap else []))


def trap_line(res: CheckResult) -> str:
    """PyBullet's inertia trap in one line of the summary ("" when PyBullet reads the file's inertias
    without ``URDF_USE_INERTIA_FROM_FILE`` too, or does not load the file)."""
    g = res.classes.trap
    if not g:
        return ""
    n = len(g)
    lim = g[0].limitation
    known = "known trap" if lim is not None else "unexplained at this version"
    return f"PyBullet without URDF_USE_INERTIA_FROM_FILE (its default) reads other inertias on {n} joint(s): {known}"


WIDTH = 120   # characters of a terminal line


def _wrapped(text: str, first: str, rest: str) -> list[str]:
    return textwrap.wrap(text, WIDTH, initial_indent=first, subsequent_indent=rest, break_on_hyphens=False) or [first]


def summary_lines(res: CheckResult, report: Path | str | None = None) -> list[str]:
    """What ``harness check`` prints: the file's class, the count per class, the top 3 findings with
    their fix (defects first, then unexplained and known importer disagreements), the witnesses (apart,
    never a vote) and where the details are; every line at most ``WIDTH`` characters."""
    c = res.classes
    lines = _wrapped(f"{res.name}: {c.file_class.upper()} ({res.mode}, {res.base} base)", "", "  ")
    lines += _wrapped(c.counts_line(), "  ", "    ")
    items = top_findings(res, trap=False)
    for k, (what, fix) in enumerate(items[:3], 1):
        lines += _wrapped(what, f"  {k}. ", "     ")
        lines += _wrapped(fix, "     ", "       ")
    if len(items) > 3:
        lines.append(f"  ... {len(items) - 3} more in the report")
    if c.from_defects:
        lines += _wrapped(f"{len(c.from_defects)} loader disagreement(s) follow from the defect(s) above", "  ", "    ")
    lines += _wrapped(trap_line(res), "  ", "    ") if trap_line(res) else []
    if c.uncompared:
        lines += _wrapped(f"{NOT_COMPARED}: " + _few([u.what for u in c.uncompared], 3), "  ", "    ")
    for refusal in res.refusals:
        lines += _wrapped(refusal, "  ", "    ")
    for line in warning_lines(res):
        lines += _wrapped(f"warnings {line[2:]}", "  ", "    ")
    lines += _wrapped(witness_line(res), "  ", "    ")
    if report is not None:
        lines += _wrapped(f"details: {report}", "  ", "    ")
    return lines


_CELL_QUANTITIES = tuple(QUANTITIES)


def _vote_cell(v: Vote | None, n_loaded: int = 3) -> str:
    if v is None:
        return ""
    if v.agree:
        return "=" if len(v.values) == n_loaded else "= (" + ", ".join(v.values) + ")"
    if v.odd is not None:
        return f"**{v.odd}**"
    return "**differ**"


def render_report(res: CheckResult, command: str) -> str:
    """The Markdown report of one check."""
    mjr = res.readings["MuJoCo"]
    loads = []
    for source in dict.fromkeys(r.source for r in res.readings.values()):
        readers = [r for r in res.readings.values() if r.source == source]
        ok = [f"{r.loader} {r.version}" for r in readers if r.loaded]
        if ok:
            loads.append(f"{', '.join(ok)} from `{source}`")
        loads += [f"{r.loader} {r.version} **does not load** `{source}`: {r.refusal}" for r in readers if not r.loaded]
    L = [f"# harness check: {res.name}", "", f"Verdict: {verdict(res)}", "",
         f"Command: `{command}`", ""]
    L += verdict_section(res)
    L += ["## Readings", "",
         f"- Loads: {res.mode}; " + "; ".join(loads),
         f"- Base: {res.base}; joints matched by name"
         + (f" ({res.mapped} URDF joint(s) through the joint map)" if res.mapped else "")
         + "; common coordinates of `harness.tools.dynamics_terms` (MuJoCo's: free joint linear velocity in world, "
         "angular in the body frame)",
         f"- Settings: {', '.join(f'{k} {v}' for k, v in res.settings.items())}"]
    if res.copies:
        L += ["- What the loaders read differs from the file(s) (each loader reads the file as written otherwise):"]
        L += [f"  - {c}" for c in res.copies]
    L += [""]
    L += ["## Models", "", "MuJoCo's reading, per joint: the rigid body it moves (fixed children merged), in the frame "
          "of its child body/link, at zero joint coordinates (every hinge and slide at 0, whatever its `ref`; free and "
          "ball joints as the file places them; Pinocchio at `neutral`). Units: kg, m, kg m^2. A body with several "
          "joints carries its mass at its last joint.", "",
          "| joint | body | type | mass (kg) | centre of mass (m) | principal moments (kg m^2) | axis | position in parent (m) |",
          "|---|---|---|---|---|---|---|---|"]
    for x in mjr.bodies:
        L.append(f"| {x.joint} | {x.body} | {x.kind} | {x.mass:.6g} | {_v(x.p_BCm_B)} | {_v(np.linalg.eigvalsh(x.I_Cm_B))} "
                 f"| {_v(x.axis_B, 3)} | {_v(x.p_PB_P)} |")
    loaded = [r.loader for r in res.readings.values() if r.loaded]
    L += ["", "### Which loaders agree", "",
          f"Per joint and quantity, among the loaders that read the file ({', '.join(loaded)}): `=` all agree (with the "
          "loaders in brackets when not all of them read it); a loader's name in bold: **the odd one out**, the one all the "
          "others agree against; **differ**: no majority; empty: the quantity does not apply (e.g. no axis on a free "
          f"joint). Tolerance: relative {res.settings.get('rtol_model')} (lengths against the body's size, at least "
          "1 mm). The odd one out reads the file differently from all the others: usually the importer that is wrong, "
          "but the file decides (e.g. only MuJoCo honours `<compiler settotalmass>`).", "",
          "| joint | body | present | " + " | ".join(_CELL_QUANTITIES) + " |",
          "|---|---|---|" + "---|" * len(_CELL_QUANTITIES)]
    by_joint: dict[str, dict[str, Vote]] = {}
    for v in res.votes:
        by_joint.setdefault(v.joint, {})[v.quantity] = v
    for joint, votes in by_joint.items():
        if not joint:
            continue
        body = next(iter(votes.values())).body
        L.append(f"| {joint} | {body} | {_vote_cell(votes.get('present'), len(loaded)) or '='} | "
                 + " | ".join(_vote_cell(votes.get(q), len(loaded)) for q in _CELL_QUANTITIES) + " |")
    g = by_joint.get("", {}).get("gravity")
    if g is not None:
        L += ["", "Gravity: " + ", ".join(f"{k} {val}" for k, val in g.values.items()) + f": {_vote_cell(g, len(loaded))}."]
    L += ["", "Disagreements between the loaders (the odd one out named where two agree against one):", ""]
    L += [f"- {p}" for p in res.model_problems] or ["- none"]
    if res.setting_differences:
        L += ["", ("Joint settings that differ between the MJCF and the URDF (listed, not counted: a URDF revolute joint "
                   "must state limits and cannot state an armature; only MuJoCo applies a friction loss):" if res.two_files
                   else "Joint settings that differ (listed, not counted: only MuJoCo applies a friction loss):"), ""]
        L += [f"- {p}" for p in res.setting_differences]
    if res.findings:
        L += ["", "What the differences come from (each cause checked against the readings: putting it back "
              "reconciles them within the tolerance, or, for an armature, the loaders' values show it):", ""]
        L += [f"- {f.text}" for f in res.findings]
    L += settings_table(res, by_joint)
    if res.not_compared:
        L += ["", "### Not compared", "",
              "MuJoCo's model holds these beyond the tree of joints and bodies; the check does not compare them between "
              "the loaders, and the dynamics terms and the free motion below leave them out (M, bias and gravity of the "
              "tree; MuJoCo's rigid run has constraints and actuators off):", ""]
        L += [f"- {line}" for line in res.not_compared]
    L += ["", "Importer differences (informational, not counted):", ""]
    L += [f"- {n}" for n in res.notes] or ["- none"]
    L += ["", "## Engine warnings", ""]
    L += warning_lines(res) or ["- none"]
    sources = sorted({s for d in res.dynamics + (res.witnesses.dynamics if res.witnesses else []) for s in (d.a, d.b)},
                     key=(LOADERS + wit.WITNESSES).index)
    L += ["", "## Dynamics terms at random states", "",
          f"{res.settings.get('states')} seeded random states (hinge angles within MuJoCo's limits where limited, rates "
          "~N(0, 1)); M(q), C(q,v)v and g(q) from MuJoCo `mj_fullM`/`qfrc_bias`, Pinocchio `crba`/`nonLinearEffects`/"
          "`computeGeneralizedGravity`, Drake `CalcMassMatrix`/`CalcBiasTerm`/`CalcGravityGeneralizedForces`, PyBullet `calculateMassMatrix`/"
          "`calculateInverseDynamics` (zero accelerations; zero velocities too for gravity), in "
          f"common coordinates; sources compared: {', '.join(sources) or 'none'}. Relative = max abs difference / "
          "largest entry.", ""]
    L += [f"- {r.loader} not compared: {r.dynamics}" for r in res.readings.values() if r.loaded and r.dynamics]
    L += [f"- {partial_line(res, r)}" for r in res.readings.values() if r.loaded and not r.dynamics and r.partial]
    L += [f"- {r.loader} not compared: it does not load the file" for r in res.readings.values() if not r.loaded]
    if any(not r.loaded or r.dynamics or r.partial for r in res.readings.values()):
        L.append("")
    L += ["| sources | term | max abs | max rel | tolerance | verdict |", "|---|---|---|---|---|---|"]
    w_dyn = res.witnesses.dynamics if res.witnesses is not None else []
    for d in res.dynamics + w_dyn:
        L.append(f"| {d.a} vs {d.b} | {d.term} | {d.max_abs:.3e} | {d.max_rel:.3e} | {d.rtol:.0e} | {'ok' if d.passed else 'DIFFERS'} |")
    odd_terms = dynamics_odd(res.dynamics)
    for loader in LOADERS:
        terms = [t for t, k in odd_terms.items() if k == loader]
        if terms:
            L += ["", f"{loader} is the odd one out in {', '.join(terms)} (the others agree)."]
    for label, terms in witness_odd(res.dynamics + w_dyn).items():
        L += ["", f"{label} is the odd one out in {', '.join(terms)} (MuJoCo, whose reading it was built from, agrees "
              "with another loader)."]
    L += witness_section(res)
    L += ["", "## Free motion under gravity", ""]
    if res.free_skipped:
        L += [f"Not run: {res.free_skipped}."]
        return "\n".join(L) + "\n"
    L += [f"{len(res.free)} random initial states, {res.settings.get('t_end')} s at dt {res.settings.get('dt')} s; MuJoCo RK4 with "
          "contacts, constraints (limits, equalities, friction loss), passive forces (damping, springs, gravity "
          "compensation, fluid forces) and actuators disabled; "
          "Pinocchio `aba` + `rkmk4_step` (Drake is compared by its dynamics terms above, not in free motion). Max over "
          f"saved samples (every {res.settings.get('save_every')} s) of the joint-coordinate difference (rad or m), "
          "joint-velocity difference and every moving body's world position (m) and orientation (geodesic, rad) "
          "difference. No tolerance: the pair runs again at 2 dt (or dt/2) and each difference is judged by how it "
          "converges (both methods are order 4): *converges* (falls at about order 4, or sits at the resolution, 1e-9 of "
          "the motion's scale: the two hold the same dynamics) or a floor that does not shrink with the step (they do "
          "not). Last column: how far MuJoCo's joints move when limits, equalities, damping and actuators are left on "
          "(contacts off), against the run without them.", "",
          "| state | joints | joint velocities | body position m | body orientation rad | worst body | class (order) "
          "| MuJoCo as the file says vs rigid |", "|---|---|---|---|---|---|---|---|"]
    for r in res.free:
        L.append(f"| {r.state} | {r.joint:.3e} | {r.velocity:.3e} | {r.position:.3e} | {r.orientation:.3e} | {r.worst_body} "
                 f"| {_models_cell(r.models)} | {r.constrained_joint:.3e} |")
    return "\n".join(L) + "\n"


def _models_cell(models: dict) -> str:
    """The worst class of a run pair's error models, with its order or floor."""
    if not models:
        return "not judged"
    bad = [e for e in models.values() if e.classification != CONVERGES]
    e = bad[0] if bad else max(models.values(), key=lambda e: e.error / e.resolution if e.resolution > 0 else 0.0)
    if e.classification == CONVERGES:
        return ("converges (at the resolution)" if math.isnan(e.observed_order)
                else f"converges (order {e.observed_order:.2f})")
    return f"**{e.classification}**: {e.quantity}, {e.reason}"


def verdict_section(res: CheckResult) -> list[str]:
    """The report's first section: the class, the count per class, each defect with its fix, each
    importer disagreement with its known limitation or as unexplained, what is not compared, the witnesses."""
    c = res.classes
    L = ["## Verdict", "", f"**{c.file_class}**. " + c.counts_line() + ".", ""]
    L += [f"### {DEFECT.capitalize()}", ""]
    L += [f"- `{d.where}` {d.element}: **{d.kind}**: {d.what}. Fix: {d.fix}." for d in c.defects] or ["- none"]
    follow = c.from_defects
    if follow:
        L += ["", f"{len(follow)} disagreement(s) between the loaders follow from these defects (each on the body the "
              "defect is in):", ""]
        L += [f"- {d.text} (from {d.defect.element})" for d in follow]
    L += ["", f"### {IMPORTER.capitalize()}s", "",
          "The loaders read a valid element differently: *known* (the table `harness/tools/check/known_limitations.toml`: "
          "loader, versions, element, behaviour, workaround, upstream reference) or *unexplained* (worth reporting "
          "upstream, with this report).", ""]
    groups = c.groups()
    for _, group in groups:
        d = group[0]
        if d.limitation is not None:
            lim = d.limitation
            L.append(f"- known **{lim.id}** ({', '.join(f'{k} {v}' for k, v in lim.versions.items())}): {lim.element}: "
                     f"{' and '.join(lim.loaders)} {lim.behaviour}. Workaround: {lim.workaround}."
                     + (f" Upstream: {lim.upstream}." if lim.upstream else ""))
        else:
            L.append(f"- **unexplained**: {d.between}:")
        L += [f"  - {x.text}" for x in group]
    if not groups:
        L.append("- none")
    if c.trap:
        lim = c.trap[0].limitation
        L += ["", "PyBullet's inertia trap: the URDF loaded a second time in PyBullet without `URDF_USE_INERTIA_FROM_FILE` "
              "(`loadURDF`'s default), against its reading with the flag (the file's; that reading is the one compared "
              "above). Not a disagreement between the loaders: what a PyBullet user gets who does not pass the flag.", ""]
        L.append(f"- known **{lim.id}** (PyBullet {lim.versions.get('PyBullet', '')}): PyBullet {lim.behaviour}. "
                 f"Workaround: {lim.workaround}." + (f" Upstream: {lim.upstream}." if lim.upstream else "")
                 if lim is not None else "- **unexplained** at this PyBullet version (the table's entry "
                 "pybullet-urdf-inertia-from-collision-by-default names the versions it was verified on):")
        L += [f"  - {x.text}" for x in c.trap]
    L += ["", f"### {NOT_COMPARED.capitalize()}", ""]
    L += [f"- {u.what}: {u.why}" for u in c.uncompared] or ["- nothing"]
    L += ["", "### Witnesses", "", "The in-house engine and Exudyn, built from MuJoCo's reading, never vote on the file: "
          + witness_line(res).split(": ", 1)[1] + ".", ""]
    return L


def witness_section(res: CheckResult) -> list[str]:
    """The report's section on the in-house engine and Exudyn (``harness.tools.witnesses``)."""
    w = res.witnesses
    if w is None:
        return []
    L = ["", "## The in-house engine and Exudyn (witnesses of dynamics)", "",
         "Built from MuJoCo's reading of the file (its compiled model as the harness's description, fixed children "
         "merged), not from the file: they test the dynamics, not a parser, and never vote on how the file is read. "
         "The in-house M, bias and gravity (Newton-Euler in maximal coordinates, accelerations for unit generalized "
         "forces) are in the table above as `in-house`; Exudyn holds no joint-space terms and is compared in free "
         "motion."]
    if w.refusal:
        return L + ["", f"- in-house: not run: {w.refusal}", f"- Exudyn: not run: {w.refusal}"]
    bad = [r for r in w.rows if not r.ok]
    L += ["", f"Model terms as each holds them against the description ({len(w.rows)} values: mass, centre of mass, "
          "inertia, axis, position in parent per body; mass and principal moments also against MuJoCo's reading): "
          + ("all agree" if not bad else f"{len(bad)} differ") + f" (relative tolerance {res.settings.get('rtol_model')})."]
    L += [f"- {p}" for p in w.problems]
    if w.free:
        L += ["", "Free motion from the same random states as below, against MuJoCo's rigid run: every moving body's "
              f"centre of mass and frame (in-house `{wit.INHOUSE_METHOD}` at dt, order 4; Exudyn `{wit.EXUDYN_METHOD}` at "
              "dt, order 2). No tolerance: each pair runs again at 2 dt (or dt/2) and each difference is judged by how it "
              "converges, at the lower of the two methods' orders.", "",
              "| engine | method | state | body position m | body orientation rad | body velocity m/s, rad/s | worst body "
              "| class |", "|---|---|---|---|---|---|---|---|"]
        for f in w.free:
            cls = _models_cell(f.models) if f.status == "ok" else f"not run: {f.status}"
            L.append(f"| {f.witness} | {f.method} | {f.state} | {f.position:.3e} | {f.orientation:.3e} | {f.velocity:.3e} "
                     f"| {f.worst_body} | {cls} |")
    L += ["", f"Wall time of the witnesses: {w.wall_s:.2f} s."]
    return L


_TABLE_SETTINGS = ("damping", "friction loss", "range", "armature")


def _setting_cell(res: CheckResult, votes: dict, joint: str, quantity: str) -> str:
    """One joint setting across the loaders: ``same: <value>``, ``differs (<by how much>): <values>``
    or ``only <loader> reads it: <value>``, naming the loaders that do not read it."""
    loaded = [r for r in res.readings.values() if r.loaded]
    v = votes.get(quantity)
    field_name = _DETAIL_FIELD.get(quantity)
    held = {}
    for r in loaded:
        x = next((b for b in r.bodies if b.joint == joint), None)
        d = next((b for b in r.details if b.joint == joint), None)
        if x is None or d is None or not QUANTITIES[quantity][0](x):
            continue
        if field_name is None or getattr(d, field_name) is not None:
            held[r.loader] = QUANTITIES[quantity][2](x, d)
    if not held:
        return ""
    absent = [r.loader for r in loaded if r.loader not in held]
    note = f" ({_who(absent)} {'does' if len(absent) == 1 else 'do'} not read it)" if absent else ""
    if v is None:
        if len(held) != 1:
            return ""
        (k, value), = held.items()
        return f"only {k} reads it: {value}{note}"
    if v.agree:
        return f"same: {next(iter(v.values.values()))}{note}"
    if quantity == "armature":
        f = next((f for f in res.findings if f.kind == "armature" and f.joint == joint), None)
        if f is not None and "the URDF has no armature" in f.text:
            nonzero = [k for k, val in v.values.items() if not val.startswith("0 ")]
            return (f"only {_who(nonzero)} {'reads' if len(nonzero) == 1 else 'read'} it: {v.values[nonzero[0]]} "
                    "(the URDF has no armature)")
    by = f" ({v.detail})" if v.detail else ""
    return f"differs{by}: " + ", ".join(f"{k} {val}" for k, val in v.values.items()) + note


def _gear_cell(res: CheckResult, joint: str) -> str:
    """The actuators on a joint with their gear (MuJoCo's ``gear``, Drake's gear ratio): listed, not compared."""
    items = []
    m = res.readings["MuJoCo"].model
    jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)
    for a in range(m.nu):
        if jid >= 0 and m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_trnid[a, 0] == jid:
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator{a}"
            items.append(f"MuJoCo {float(m.actuator_gear[a, 0]):g} ({name})")
    drr = res.readings.get("Drake")
    if drr is not None and drr.loaded:
        plant = drr.model.plant
        for a in plant.GetJointActuatorIndices():
            act = plant.get_joint_actuator(a)
            if drr.names.get(act.joint().name(), act.joint().name()) == joint:   # through the joint map, if any
                items.append(f"Drake {act.default_gear_ratio():g} ({act.name()})")
    return ", ".join(items) + ": not compared" if items else ""


def settings_table(res: CheckResult, by_joint: dict[str, dict[str, Vote]]) -> list[str]:
    """The report's per-joint table of damping, friction loss, range, armature (with units) and the
    actuators' gear, each as ``same`` / ``differs (by how much)`` / ``only <loader> reads it``."""
    rows = []
    for joint, votes in by_joint.items():
        if not joint:
            continue
        cells = [_setting_cell(res, votes, joint, q) for q in _TABLE_SETTINGS] + [_gear_cell(res, joint)]
        if any(cells):
            rows.append(f"| {joint} | " + " | ".join(cells) + " |")
    if not rows:
        return []
    return ["", "### Joint settings", "",
            "Per hinge or slide joint: what each loader reads (units: damping N m s/rad or N s/m, friction loss N m or N, "
            "range rad or m, armature kg m^2 or kg). Gear: the actuators on the joint (MuJoCo's `gear`, Drake's gear ratio "
            "from a URDF transmission), listed, not compared (Pinocchio reads no actuators).", "",
            "| joint | damping | friction loss | range | armature | actuator gear |", "|---|---|---|---|---|---|"] + rows


def partial_line(res: CheckResult, r: Reading) -> str:
    """How a loader that lacks whole kinematic trees is compared (``Reading.partial``)."""
    roots = _whole_trees(res.readings["MuJoCo"], r.partial)
    return (f"{r.loader} compared on the kinematic trees it reads: it lacks {len(roots)} whole tree(s) of MuJoCo's "
            f"(rooted at {_few(roots, 6)}; joints {_few(r.partial, 6)}), which the dynamics terms and the free motion "
            "leave out for every loader")


def warning_lines(res: CheckResult) -> list[str]:
    """MuJoCo's captured warnings as report lines (none when it gave none)."""
    count = int(res.warnings.get("count", 0) or 0)
    if not count:
        return []
    return [(f"- MuJoCo: {count} warning{'s' if count != 1 else ''} during the dynamics terms and free motions; "
             f"first: {res.warnings.get('first', '')}")]


def write_report(res: CheckResult, out_dir: Path, command: str) -> Path:
    path = Path(out_dir) / f"check_{res.name}.md"
    atomic.write_text(path, render_report(res, command))
    return path

