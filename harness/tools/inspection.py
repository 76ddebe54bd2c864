"""``harness inspect SCENE``: what each engine holds after loading a scene, against the scene.

Loads, each compared with the scene description (``harness.engines.loaded_models``):

* primary, scene parameters applied (what every run uses): MuJoCo from the MJCF by
  ``load_mjcf``, Pinocchio from the URDF by ``load_urdf``, against the scene at its current
  parameters (defaults plus ``--set``);
* primary, files AS WRITTEN (``read_spec().compile()``, ``read_urdf``): against the scene at the
  defaults of its ``scene.toml``, which the files must hold. ``load_urdf``/``load_mjcf`` overwrite
  mass properties, so an error in a file shows here only. A URDF cannot state gravity: the
  URDF-as-written model gets the scene's gravity for the dynamics check. The same comparison
  (``harness.engines.as_written``) is what ``harness validate`` checks at the start of every run (``model.*``);
* cross-loads, as written, against the defaults: the MJCF into Pinocchio
  (``buildModelFromMJCF``) and the URDF into MuJoCo (MuJoCo compiles URDF: first as MuJoCo
  imports it by default, then with the scene's root joint added as Pinocchio adds it). What a
  cross-parser drops or changes is reported as a finding; a cross-load that fails is a finding.

Then the dynamics check (``harness.tools.dynamics_terms``) on the applied loads, the as-written loads
and the cross-loads, each against the in-house ``Multibody``.

Exit status (``InspectResult.passed``): disagreements in the primary loads (applied or as
written, bodies, gravity or dynamics) fail; cross-load findings do not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
import pinocchio as pin

from harness.tools import dynamics_terms as dc
from harness.tools.check import load_mujoco, load_pinocchio
from harness.engines import integrator_of
from harness.engines.as_written import APPLIED_RTOL, AS_WRITTEN_RTOL, as_written, files_hold
from harness.engines.mujoco.model import load_mjcf, read_spec
from harness.engines.pinocchio.model import load_urdf
from harness.model.errors import InputError
from harness.model.joints import JOINTS, by_urdf_root
from harness.engines.loaded_models import (
    LoadedBody,
    compare_bodies,
    exudyn_bodies,
    exudyn_gravity,
    gravity_problem,
    mujoco_bodies,
    mujoco_force_discrepancies,
    mujoco_loop_discrepancies,
    pinocchio_bodies,
)
from harness.engines.mujoco.loops import loop_points
from harness.engines.mujoco.loops import settings_text as loop_settings
from harness.model.forces import elements
from harness.model.joints import keeps_axis
from harness.model.multibody import Multibody
from harness.model.scene import Scene


@dataclass
class Load:
    """One engine's load of one file and what it shows."""

    label: str
    primary: bool
    problems: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    details: list[str] = field(default_factory=list)


@dataclass
class DynamicsBlock:
    """One dynamics comparison (sources and their differences, or why it could not be made)."""

    label: str
    primary: bool
    diffs: list[dc.TermDiff] = field(default_factory=list)
    error: str = ""

    @property
    def passed(self) -> bool:
        return not self.error and all(d.passed for d in self.diffs)


@dataclass
class InspectResult:
    scene: Scene
    description: list[str]
    loads: list[Load]
    dynamics: list[DynamicsBlock]

    @property
    def passed(self) -> bool:
        return (all(not x.problems for x in self.loads if x.primary)
                and all(b.passed for b in self.dynamics if b.primary))


# --------------------------------------------------------------------------- text helpers


def _v(x) -> str:
    return "[" + ", ".join(f"{float(c):.6g}" for c in np.ravel(x)) + "]"


def body_lines(name: str, joint: str, axis: np.ndarray, p_PB_P: np.ndarray, mass: float,
               com: np.ndarray, inertia: np.ndarray) -> list[str]:
    """Readable mass properties of one body (body frame; kg, m, kg m^2)."""
    moments, axes = np.linalg.eigh(inertia)
    lines = [f"  body {name}: joint {joint}" + (f", axis {_v(axis)}" if joint in JOINTS and JOINTS[joint].axis else "")
             + f", frame origin in parent {_v(p_PB_P)} m",
             f"    mass {mass:.9g} kg, centre of mass {_v(com)} m (body frame)",
             "    inertia about the centre of mass (body frame, kg m^2): " + ", ".join(_v(r) for r in inertia),
             f"    principal moments {_v(moments)} kg m^2, principal axes (columns, body frame): "
             + ", ".join(_v(axes[:, i]) for i in range(3))]
    return lines


def _loaded_lines(bodies: list[LoadedBody]) -> list[str]:
    out = []
    for b in bodies:
        out += body_lines(b.name, b.joint, b.axis_B, b.p_PB_P, b.mass, b.p_BCm_B, b.I_Cm_B)
    return out


def describe_multibody(model: Multibody) -> list[str]:
    lines = [f"  gravity {_v(model.gravity_W)} m/s^2 (world)"]
    for b in model.bodies:
        lines += body_lines(b.name, b.joint, b.axis_B, b.p_PB_P, b.mass, b.p_BCm_B, b.I_Cm_B)
    for lp in model.loops:
        axes = f", axis {_v(lp.axis_A)} in {lp.body_a}, {_v(lp.axis_B)} in {lp.body_b or 'world'}" if keeps_axis(lp.kind) else ""
        lines.append(f"  loop joint {lp.name}: {lp.kind} closing the tree between {lp.body_a} at {_v(lp.p_A)} m "
                     f"and {lp.body_b or 'world'} at {_v(lp.p_B)} m (body frames){axes}")
    for ft, element in elements(model):  # force elements: each type's own fields (harness.model.forces)
        fields = ", ".join(f"{k} {_v(v) if isinstance(v, np.ndarray) else v}" for k, v in vars(element).items()
                           if not callable(v))
        lines.append(f"  {ft.label} ({ft.name}): {fields} (SI units, body frames; MJCF: {ft.mjcf})")
    return lines


def _mujoco_loop_lines(m: mujoco.MjModel) -> list[str]:
    """The site-based <connect> equalities of a compiled model and their soft-constraint settings."""
    lines = [f"  equality {name}: connect {ends[0][0]} at {_v(ends[0][1])} m to {ends[1][0]} at {_v(ends[1][1])} m"
             for name, ends in loop_points(m).items()]
    text = loop_settings(m)
    return lines + ([f"  {text}"] if text else [])


def _mujoco_options(m: mujoco.MjModel, scene: Scene) -> str:
    return (f"  timestep {m.opt.timestep:g} s, integrator {mujoco.mjtIntegrator(m.opt.integrator).name[6:]} "
            f"(runs use the scene's dt {scene.dt:g} s and {integrator_of(scene, 'mujoco')}), "
            f"gravity {_v(m.opt.gravity)} m/s^2")


# --------------------------------------------------------------------------- loads


def inspect_scene(scene: Scene, *, n_states: int = dc.DEFAULT_STATES, seed: int = 0) -> InspectResult:
    """Every load of ``scene`` and every dynamics comparison (see module docstring)."""
    if n_states < 1:
        raise InputError(f"--states must be >= 1, got {n_states}")
    model = scene.multibody()
    model0 = files_hold(scene).multibody()
    loads: list[Load] = []
    blocks: list[DynamicsBlock] = []

    # Primary, scene parameters applied.
    m = load_mjcf(scene.mjcf, model)
    ld = Load(f"MuJoCo <- {scene.mjcf.name} with the scene's parameters (load_mjcf)", True)
    mb = mujoco_bodies(m, model)
    ld.details = [_mujoco_options(m, scene)] + _loaded_lines(mb) + _mujoco_loop_lines(m)
    ld.problems = (compare_bodies(mb, model, rtol=APPLIED_RTOL) + _gravity(m.opt.gravity, model)
                   + [d.message for d in mujoco_loop_discrepancies(m, model, rtol=APPLIED_RTOL) if not d.passed]
                   + [d.message for d in mujoco_force_discrepancies(m, model, rtol=APPLIED_RTOL) if not d.passed])
    loads.append(ld)
    pmodel, _ = load_urdf(scene.urdf, scene.urdf_root_joint, model)
    lp = Load(f"Pinocchio <- {scene.urdf.name} with the scene's parameters (load_urdf, root joint {scene.urdf_root_joint})", True)
    pb = pinocchio_bodies(pmodel, model)
    lp.details = [f"  gravity {_v(pmodel.gravity.linear)} m/s^2"] + _loaded_lines(pb)
    lp.problems = compare_bodies(pb, model, rtol=APPLIED_RTOL) + _gravity(pmodel.gravity.linear, model)
    loads.append(lp)
    blocks.append(_dynamics("scene parameters applied: MuJoCo, Pinocchio, in-house", True, model, m, pmodel,
                            n_states, seed))
    loads.append(_exudyn_load(scene, model))

    # Primary, files as written, against the defaults.
    mw = as_written(scene, "mujoco", model0)
    m_file = mw.model
    lw = Load(f"MuJoCo <- {scene.mjcf.name} as written (against the scene.toml defaults)", True)
    lw.details = [_mujoco_options(m_file, scene)]
    lw.problems = mw.problems
    loads.append(lw)
    pw = as_written(scene, "pinocchio", model0)
    p_file = pw.model
    lu = Load(f"Pinocchio <- {scene.urdf.name} as written (against the scene.toml defaults)", True)
    lu.problems = pw.problems
    lu.notes.append(f"a URDF cannot state gravity: Pinocchio's default {_v(p_file.gravity.linear)} m/s^2; "
                    "load_urdf and this dynamics check set the scene's")
    p_file.gravity = pin.Motion(np.concatenate([model0.gravity_W, np.zeros(3)]))
    loads.append(lu)
    blocks.append(_dynamics("files as written: MuJoCo <- MJCF, Pinocchio <- URDF, in-house (defaults)", True, model0,
                            m_file, p_file, n_states, seed))

    if "drake" not in scene.not_run:  # a third parser of the URDF as written (Drake's own)
        from harness.engines.drake.model import drake_bodies

        dw = as_written(scene, "drake", model0)
        ld = Load(f"Drake <- {scene.urdf.name} as written (against the scene.toml defaults; Drake's own URDF parser)", True)
        ld.details = _loaded_lines(drake_bodies(*dw.model, model0))
        ld.problems = dw.problems
        loads.append(ld)

    # Cross-loads, as written.
    loads.append(_mjcf_into_pinocchio(scene, model0, blocks, n_states, seed))
    loads += _urdf_into_mujoco(scene, model0, blocks, n_states, seed)
    return InspectResult(scene, describe_multibody(model), loads, blocks)


def _exudyn_load(scene: Scene, model: Multibody) -> Load:
    """What Exudyn holds when built from the description with the scene's parameters
    (``harness.engines.exudyn.model``; Exudyn reads no model file): its bodies, joint objects,
    rolling-disc joints and gravity, against the description."""
    from harness.engines.exudyn.integrators import NODE_TYPE
    from harness.engines.exudyn.model import build

    method = integrator_of(scene, "exudyn")
    node_type = NODE_TYPE[method]
    system = build(model, node_type)
    label = f"Exudyn <- the scene's description (no model file; {node_type} nodes for {method})"
    ld = Load(label, True)
    bodies = exudyn_bodies(system, model)
    gravity = exudyn_gravity(system)
    ld.details = [f"  gravity {_v(gravity)} m/s^2"] + _loaded_lines(bodies)
    for name, (joint, body, edge) in system.contacts.items():
        obj = system.mbs.GetObject(joint)
        marker = system.mbs.GetMarker(obj["markerNumbers"][1])
        ld.details.append(f"  {name}: {obj['objectType']} on {body}, disc radius {obj['discRadius']:.6g} m, "
                          f"centre at body {_v(marker['localPosition'])} m ({'the lower rim edge' if edge else 'the rolling circle'}), "
                          f"axis {_v(obj['discAxis'])}")
    ld.problems = compare_bodies(bodies, model, rtol=APPLIED_RTOL) + _gravity(gravity, model)
    return ld


def _gravity(g, model: Multibody, rtol: float = APPLIED_RTOL) -> list[str]:
    problem = gravity_problem(np.asarray(g, dtype=float), model.gravity_W, rtol)
    return [problem] if problem else []


def _dynamics(label: str, primary: bool, model: Multibody, m, pmodel, n_states: int, seed: int,
              names=("mujoco", "pinocchio", "inhouse")) -> DynamicsBlock:
    block = DynamicsBlock(label, primary)
    try:
        jmap = dc.scene_joint_map(model, m, pmodel)
    except dc.MappingError as err:
        block.error = f"not possible: {err}"
        return block
    sources = dc.scene_sources(model, m, pmodel, jmap, labels=names)
    results = dc.evaluate(sources, dc.random_states(jmap, n_states, seed))
    labels = list(results)
    pairs = [(a, b) for i, a in enumerate(labels) for b in labels[i + 1:]]
    block.diffs = dc.compare_terms(results, pairs)
    return block


def _mjcf_into_pinocchio(scene: Scene, model0: Multibody, blocks, n_states, seed) -> Load:
    ld = Load(f"Pinocchio <- {scene.mjcf.name} (cross-load: pinocchio.buildModelFromMJCF, as written)", False)
    try:
        pm = load_pinocchio(scene.mjcf)
    except InputError as err:
        ld.problems.append(f"does not load: {err}")
        return ld
    ld.problems = compare_bodies(pinocchio_bodies(pm, model0), model0, rtol=AS_WRITTEN_RTOL)
    g_file = np.asarray(read_spec(scene.mjcf).option.gravity, dtype=float)
    g_pin = np.array(pm.gravity.linear)
    if not np.allclose(g_pin, g_file, rtol=0, atol=1e-12):
        ld.problems.append(f"gravity {_v(g_pin)} m/s^2 where the MJCF's <option gravity> says {_v(g_file)}: "
                           "Pinocchio's MJCF parser ignores <option>")
    else:
        ld.notes.append(f"gravity {_v(g_pin)} m/s^2 equals the MJCF's <option gravity> here, but Pinocchio's MJCF parser "
                        "does not read <option> (this is its default)")
    ld.notes.append("dropped: <option> (timestep, integrator, gravity, flags), actuators, sites become frames")
    armature, damping = np.array(pm.armature), np.array(pm.damping)
    if np.any(armature) or np.any(damping):
        ld.notes.append(f"read from the joints: armature {_v(armature)}, damping {_v(damping)}")
    blocks.append(_dynamics(f"cross-load Pinocchio <- {scene.mjcf.name} vs in-house (defaults)", False, model0, None, pm,
                            n_states, seed, names=("", "pinocchio<-MJCF", "inhouse")))
    return ld


def _urdf_into_mujoco(scene: Scene, model0: Multibody, blocks, n_states, seed) -> list[Load]:
    plain = Load(f"MuJoCo <- {scene.urdf.name} (cross-load: MuJoCo's own URDF import, defaults)", False)
    try:
        m, _ = load_mujoco(scene.urdf)
    except InputError as err:
        plain.problems.append(f"does not load: {err}")
        return [plain]
    names = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)}
    for body in model0.bodies:
        if body.name not in names:
            plain.problems.append(f"body {body.name!r} is missing: the URDF gives the root link no joint, and MuJoCo "
                                  "fuses a link without joint into its parent (fusestatic, the default for URDF), here "
                                  "the world: its mass is gone from the dynamics")
    lim = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt) if m.jnt_limited[j]]
    if lim:
        plain.notes.append(f"URDF <limit> becomes an enforced joint range in MuJoCo for {', '.join(lim)} "
                           f"({', '.join(_v(m.jnt_range[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in lim)})")
    plain.notes.append(f"options are MuJoCo's defaults, URDF has none: timestep {m.opt.timestep:g} s, integrator "
                       f"{mujoco.mjtIntegrator(m.opt.integrator).name[6:]}, gravity {_v(m.opt.gravity)} m/s^2, "
                       f"contact on; visual geometry discarded (discardvisual), {m.ngeom} geom(s) left")
    grav = _gravity(m.opt.gravity, model0)
    plain.problems += [f"{g} (MuJoCo's default: a URDF cannot state gravity)" for g in grav]
    out = [plain]
    root_type = by_urdf_root(scene.urdf_root_joint)  # the joint kind Pinocchio adds as the URDF's root
    root = root_type.name if root_type is not None else "none"
    if root == "none":
        out[0].problems += compare_bodies(mujoco_bodies(m, model0), model0, rtol=AS_WRITTEN_RTOL)
        blocks.append(_dynamics(f"cross-load MuJoCo <- {scene.urdf.name} vs in-house (defaults)", False, model0, m, None,
                                n_states, seed, names=("mujoco<-URDF", "", "inhouse")))
        return out
    rooted = Load(f"MuJoCo <- {scene.urdf.name} with a {root} root joint added (as Pinocchio adds {scene.urdf_root_joint})", False)
    try:
        m2, _ = load_mujoco(scene.urdf, root_joint=root)
    except InputError as err:
        rooted.problems.append(f"does not load: {err}")
        return out + [rooted]
    rooted.problems = compare_bodies(mujoco_bodies(m2, model0), model0, rtol=AS_WRITTEN_RTOL)
    rooted.problems += [f"{g} (MuJoCo's default: a URDF cannot state gravity)" for g in _gravity(m2.opt.gravity, model0)]
    blocks.append(_dynamics(f"cross-load MuJoCo <- {scene.urdf.name} + {root} root vs in-house (defaults)", False, model0,
                            m2, None, n_states, seed, names=("mujoco<-URDF", "", "inhouse")))
    return out + [rooted]


# --------------------------------------------------------------------------- output


def render(res: InspectResult) -> str:
    """The readable text ``harness inspect`` prints."""
    scene = res.scene
    params = ", ".join(f"{k}={_v(v) if isinstance(v, tuple) else f'{v:g}'}" for k, v in scene.params.items())
    L = [f"inspect {scene.name}: {scene.title}", f"parameters: {params}", "",
         "== scene description (the in-house engine runs this Multibody) =="] + res.description
    for ld in res.loads:
        kind = "primary" if ld.primary else "cross-load"
        L += ["", f"== {ld.label} [{kind}] =="] + ld.details
        if ld.problems:
            L += [f"  {'DISAGREES' if ld.primary else 'FINDING'}: {p}" for p in ld.problems]
        else:
            L.append("  agrees with the scene description")
        L += [f"  note: {n}" for n in ld.notes]
    L += ["", "== dynamics at random states (common coordinates; M kg..kg m^2, C v and g N or N m; "
              "relative to the term's largest entry) =="]
    for b in res.dynamics:
        L.append(f"-- {b.label} [{'primary' if b.primary else 'cross-load'}]")
        L += [f"  {b.error}"] if b.error else dc.format_diffs(b.diffs)
    bad = [ld.label for ld in res.loads if ld.primary and ld.problems]
    bad += [b.label for b in res.dynamics if b.primary and not b.passed]
    L += ["", "RESULT: " + ("primary loads agree with the scene description" if res.passed
                            else "DISAGREEMENT in " + "; ".join(bad))]
    return "\n".join(L) + "\n"
