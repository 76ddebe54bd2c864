"""Model files written from a ``Multibody``: the MJCF and URDF of a generated scene.

A scene whose builder generates its system (N copies of a unit: ``four_bar_chain``'s windows)
says ``generated = true`` in its ``scene.toml``; it keeps no model file in its folder. Its MJCF
and URDF are written from the multibody its builder makes for the scene's current parameters
(``generated_files``), into a folder of the user's cache named after their content, and the
``Scene`` points at them (``harness.model.scene``): every engine then reads them as it reads a
scene's own files, and ``validate`` checks what each engine loads from them against the
description (``harness.engines.as_written``), as for any scene.

What the files hold (SI units, the harness's frames, ``harness.model.multibody``):

* the MJCF: every body nested under its parent at ``p_PB_P``, its frame parallel to its
  parent's, its joint at its frame's origin (hinge and slide along ``axis_B``, ball, free), its
  ``<inertial>`` (mass, centre of mass, full inertia about it), no geometry, no contact; gravity,
  the step and RK4 in ``<option>``; each cut joint as site-based ``<connect>`` equalities
  (``LoopJoint``: sites ``<name>_a``, ``<name>_b`` and, for a hinge, ``<name>_a2``, ``<name>_b2``
  one ``hinge_span`` along the axis; equalities ``<name>`` and ``<name>_2``), soft with the time
  constant ``LOOP_SOLREF_STEPS`` steps and MuJoCo's stiffest impedance, as ``models/four_bar``'s;
* the URDF: the tree only (a URDF cannot state a loop): a link per body, a ``revolute`` or
  ``prismatic`` joint per hinge or slide (nominal limits, which the dynamics ignore), joints to
  the world from a ``world`` link; a free or ball root only as the single root link, whose joint
  the scene's ``urdf_root_joint`` adds.

Force elements and rolling contacts are not written (``InputError``): a generated scene holds
bodies, joints, loops and gravity.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from harness.model.errors import InputError
from harness.model.forces import FORCES
from harness.model.joints import FREE, HINGE, JOINTS, SLIDE, keeps_axis
from harness.model.multibody import Multibody

#: The loops' ``solref`` time constant in steps of the scene (MuJoCo's safe minimum is two).
LOOP_SOLREF_STEPS = 2.0
#: The loops' ``solimp``: MuJoCo's stiffest impedance (``models/four_bar/four_bar.xml`` says why).
LOOP_SOLIMP = "0.9999 0.9999 0.001 0.5 2"
#: The kinds a URDF states as a joint below its root, by their URDF names.
_URDF_JOINT = {HINGE.name: "revolute", SLIDE.name: "prismatic"}


def _num(x: float) -> str:
    return repr(float(x)) if x != 0.0 else "0"


def _vec(v) -> str:
    return " ".join(_num(x) for x in np.asarray(v, dtype=float).ravel())


def _inertia_six(I) -> tuple[float, ...]:
    """(Ixx, Iyy, Izz, Ixy, Ixz, Iyz) of a symmetric 3x3 inertia (kg m^2)."""
    I = np.asarray(I, dtype=float)
    return I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]


def check_writable(model: Multibody, source: str) -> None:
    """InputError naming ``source`` when ``model`` holds what these files do not write: a force
    element or a rolling contact."""
    for ft in FORCES.values():
        if ft.elements(model):
            raise InputError(f"{source}: a generated scene writes bodies, joints, loops and gravity; its system has "
                             f"{ft.label}s, which harness.model.model_files does not write")
    if model.contacts:
        raise InputError(f"{source}: a generated scene has no rolling contact (harness.model.model_files writes none)")


def mjcf_text(model: Multibody, name: str, dt: float) -> str:
    """The MJCF of ``model`` (module docstring); ``dt`` (s): the step in ``<option>`` and the
    loops' ``solref`` time constant (``LOOP_SOLREF_STEPS`` steps)."""
    children: dict[str | None, list] = {}
    for b in model.bodies:
        children.setdefault(b.parent, []).append(b)
    sites: dict[str | None, list[str]] = {}
    equalities = []
    solref = f"{_num(LOOP_SOLREF_STEPS * dt)} 1"
    for loop in model.loops:
        ends = [(loop.name, (f"{loop.name}_a", loop.body_a, loop.p_A), (f"{loop.name}_b", loop.body_b, loop.p_B))]
        if keeps_axis(loop.kind):
            span = float(loop.hinge_span)
            ends.append((f"{loop.name}_2",
                         (f"{loop.name}_a2", loop.body_a, np.asarray(loop.p_A, float) + span * np.asarray(loop.axis_A, float)),
                         (f"{loop.name}_b2", loop.body_b, np.asarray(loop.p_B, float) + span * np.asarray(loop.axis_B, float))))
        for eq, (s1, b1, p1), (s2, b2, p2) in ends:
            sites.setdefault(b1, []).append(f'<site name="{s1}" pos="{_vec(p1)}"/>')
            sites.setdefault(b2, []).append(f'<site name="{s2}" pos="{_vec(p2)}"/>')
            equalities.append(f'<connect name="{eq}" site1="{s1}" site2="{s2}" solref="{solref}" solimp="{LOOP_SOLIMP}"/>')

    def body(b, depth: int) -> list[str]:
        pad = "  " * depth
        jt = JOINTS[b.joint]
        if b.joint == FREE.name:
            joint = f'<freejoint name="{b.name}_joint"/>'
        elif jt.axis is None:
            joint = f'<joint name="{b.name}_joint" type="{b.joint}" pos="0 0 0"/>'
        else:
            joint = f'<joint name="{b.name}_joint" type="{b.joint}" axis="{_vec(b.axis_B)}" pos="0 0 0"/>'
        lines = [f'{pad}<body name="{b.name}" pos="{_vec(b.p_PB_P)}">', f"{pad}  {joint}",
                 f'{pad}  <inertial pos="{_vec(b.p_BCm_B)}" mass="{_num(b.mass)}" '
                 f'fullinertia="{_vec(_inertia_six(b.I_Cm_B))}"/>']
        lines += [f"{pad}  {s}" for s in sites.get(b.name, [])]
        for c in children.get(b.name, []):
            lines += body(c, depth + 1)
        return lines + [f"{pad}</body>"]

    out = [f"<!-- {name}: generated by harness.model.model_files from the scene's description (models/{name}/"
           "scene.toml and its builder) for its current parameters; not kept in the repository. -->",
           f'<mujoco model="{name}">',
           '  <compiler angle="radian" inertiafromgeom="false"/>',
           f'  <option timestep="{_num(dt)}" integrator="RK4" gravity="{_vec(model.gravity_W)}">',
           '    <flag contact="disable" energy="enable"/>',
           "  </option>",
           "  <worldbody>"]
    out += [f"    {s}" for s in sites.get(None, [])]
    for b in children.get(None, []):
        out += body(b, 2)
    out.append("  </worldbody>")
    if equalities:
        out += ["  <equality>"] + [f"    {e}" for e in equalities] + ["  </equality>"]
    out.append("</mujoco>")
    return "\n".join(out) + "\n"


def urdf_text(model: Multibody, name: str) -> str:
    """The URDF of ``model``'s tree (module docstring); InputError where a URDF cannot state it
    (a free or ball joint below the root, or beside another root)."""
    roots = [b for b in model.bodies if b.parent is None]
    for b in model.bodies:
        if b.joint not in _URDF_JOINT and not (b.parent is None and len(roots) == 1):
            raise InputError(f"{name}: body {b.name!r}: a URDF states a {b.joint} joint only as its single root's "
                             "(urdf_root_joint), not here")
    world = any(b.joint in _URDF_JOINT for b in roots)
    out = ['<?xml version="1.0"?>',
           f"<!-- {name}: the tree, generated by harness.model.model_files from the scene's description for its "
           "current parameters (a URDF cannot state a loop: the cut joints come from the description). -->",
           f'<robot name="{name}">']
    if world:
        out.append('  <link name="world"/>')
    for b in model.bodies:
        ixx, iyy, izz, ixy, ixz, iyz = (_num(x) for x in _inertia_six(b.I_Cm_B))
        if b.joint in _URDF_JOINT:
            out += [f'  <joint name="{b.name}_joint" type="{_URDF_JOINT[b.joint]}">',
                    f'    <parent link="{b.parent or "world"}"/>',
                    f'    <child link="{b.name}"/>',
                    f'    <origin xyz="{_vec(b.p_PB_P)}" rpy="0 0 0"/>',
                    f'    <axis xyz="{_vec(b.axis_B)}"/>',
                    '    <limit lower="-1000" upper="1000" effort="1000" velocity="1000"/>',
                    "  </joint>"]
        out += [f'  <link name="{b.name}">',
                "    <inertial>",
                f'      <origin xyz="{_vec(b.p_BCm_B)}" rpy="0 0 0"/>',
                f'      <mass value="{_num(b.mass)}"/>',
                f'      <inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" iyz="{iyz}" izz="{izz}"/>',
                "    </inertial>",
                "  </link>"]
    out.append("</robot>")
    return "\n".join(out) + "\n"


def cache_folder() -> Path:
    """Where generated files are kept: ``$XDG_CACHE_HOME/harness/generated`` (``~/.cache`` when
    unset), else, where that cannot be made, the system's temporary folder."""
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "harness" / "generated"
    try:
        root.mkdir(parents=True, exist_ok=True)
        return root
    except OSError:
        fallback = Path(tempfile.gettempdir()) / f"harness-generated-{os.getuid() if hasattr(os, 'getuid') else 0}"
        fallback.mkdir(parents=True, exist_ok=True)
        return fallback


def _write(path: Path, text: str) -> None:
    """``text`` into ``path`` unless it holds it already; atomically (a temporary file renamed),
    so processes that write the same file at once each leave it whole."""
    try:
        if path.read_text() == text:
            return
    except OSError:
        pass
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def generated_files(model: Multibody, name: str, mjcf: str, urdf: str, dt: float, source: str) -> tuple[Path, Path]:
    """Write ``model``'s MJCF and URDF (named ``mjcf`` and ``urdf``) into a folder of
    ``cache_folder()`` named after the scene and a digest of both texts (a system and step
    written once, whatever process asks; another gets its own folder), and return their paths.
    InputError naming ``source`` for a system these files cannot state (``check_writable``)."""
    check_writable(model, source)
    xml, text = mjcf_text(model, name, dt), urdf_text(model, name)
    digest = hashlib.sha256((xml + "\0" + text).encode()).hexdigest()[:16]
    folder = cache_folder() / f"{name}-{digest}"
    folder.mkdir(parents=True, exist_ok=True)
    paths = folder / mjcf, folder / urdf
    _write(paths[0], xml)
    _write(paths[1], text)
    return paths
