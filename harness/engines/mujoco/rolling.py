"""MuJoCo and rolling contacts: the rim geometry from the scene, the contact force, contact settings.

MuJoCo has no rolling (nonholonomic) constraint: the disk is a ``cylinder`` geom (size
``R h``: radius and half-height, axis along body z) on a ``plane`` geom, held by frictional
soft contact. The MJCF carries the contact settings (``models/rolling_disk/README.md`` reports
the study that chose them: ``harness rolling-study``); ``apply_contacts`` only rewrites the
cylinder's size from the scene's parameters.

Contact force (``ContactForceReader``): after ``mj_forward``, ``mj_contactForce`` gives each
active contact's force in its contact frame (rows of ``contact.frame``: normal, then the two
tangents); rotated to world and summed over the contacts that involve the rim geom, signed as
the force the floor exerts on the disk. The moment is that of these forces about the ideal
contact point C of the scene's geometry (``harness.model.rolling_contact``): nonzero when MuJoCo
holds the disk at two points (both rim edges near upright) or at a point away from C.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from harness.engines.mujoco.integrators import INTEGRATORS
from harness.model import rotations
from harness.model.errors import InputError
from harness.model.rolling_contact import contact_offset


def apply_contacts(spec: mujoco.MjSpec, model, source: Path) -> None:
    """Write each rolling contact's radius and half-thickness into its cylinder geom's size and,
    for a contact on one circle (``circle_z``), place the geom on the body's axis: centred on the
    circle when it is the mid circle (``circle_z = 0``: a cylinder on its side), otherwise just
    beyond it, away from the centre of mass (centre at ``circle_z + h sgn(circle_z)`` from it
    along body z, m), so that the circle is the geom's inner edge (a cone's base rim: the inner
    edge touches the plane, the outer one stays 2 h sin(tilt) above it)."""
    bodies = {b.name: b for b in model.bodies}
    for contact in getattr(model, "contacts", ()):
        geom = spec.geom(contact.geom)
        if geom is None:
            raise InputError(f"{source}: MJCF has no geom named {contact.geom!r} for the rolling contact of {contact.body!r}")
        if geom.type != mujoco.mjtGeom.mjGEOM_CYLINDER:
            raise InputError(f"{source}: geom {contact.geom!r} must be a cylinder (the rolling rim)")
        geom.size = [contact.radius, contact.half_thickness, 0.0]
        if contact.circle_z is not None:
            c = float(contact.circle_z)
            geom.pos = np.asarray(bodies[contact.body].p_BCm_B, float) + \
                np.array([0.0, 0.0, c + contact.half_thickness * np.sign(c)])


def apply_options(spec: mujoco.MjSpec, options: dict) -> None:
    """Apply contact/solver settings to a spec (used by the settings study). Keys:
    ``cone`` ("pyramidal"/"elliptic"), ``impratio``, ``noslip_iterations``, ``iterations``,
    ``tolerance``, ``condim`` (3, 4, 6; on every geom), ``friction`` (sliding, torsional, rolling
    coefficients on every geom), ``solref`` and ``solimp`` (on every geom), ``integrator``,
    ``timestep``."""
    o = spec.option
    for key, value in options.items():
        if key == "cone":
            o.cone = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}[value]
        elif key in ("impratio", "noslip_iterations", "iterations", "tolerance", "timestep"):
            setattr(o, key, value)
        elif key == "integrator":
            o.integrator = INTEGRATORS[value]
        elif key in ("condim", "friction", "solref", "solimp"):
            for geom in spec.geoms:
                if key == "condim":
                    geom.condim = int(value)
                elif key == "friction":
                    geom.friction = [float(x) for x in value]
                else:
                    setattr(geom, key, list(value))
        else:
            raise KeyError(f"unknown MuJoCo option {key!r}")


def describe_contact(m: mujoco.MjModel) -> str:
    """The contact settings of a compiled model, for the report's provenance."""
    o = m.opt
    g = int(np.argmax(m.geom_type == mujoco.mjtGeom.mjGEOM_CYLINDER)) if m.ngeom else 0
    return (f"impratio {o.impratio:g}, noslip_iterations {o.noslip_iterations}, condim {m.geom_condim[g]}, "
            f"friction {m.geom_friction[g][0]:g}, solref {m.geom_solref[g][0]:g} {m.geom_solref[g][1]:g}, "
            f"solimp {' '.join(f'{x:g}' for x in m.geom_solimp[g][:3])}")


class ContactForceReader:
    """Reads the floor's force on each rolling body at every saved sample into the run's
    ``SampleBuffer`` (its reactions named after the contacts; module docstring)."""

    def __init__(self, m: mujoco.MjModel, model):
        self.items = []
        for contact in model.contacts:
            gid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, contact.geom)
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, contact.body)
            self.items.append((contact, gid, bid))
        self.names = [c.name for c in model.contacts]
        self._f6 = np.zeros(6)

    def read(self, m: mujoco.MjModel, d: mujoco.MjData, k: int, buf) -> None:
        """Store sample ``k`` in ``buf`` (``mj_forward`` must have run on ``d``)."""
        for contact, gid, bid in self.items:
            R = d.xmat[bid].reshape(3, 3)
            c_W = d.xipos[bid] + contact_offset(R, contact.radius, contact.half_thickness, contact.circle_z)
            f_tot, m_tot = np.zeros(3), np.zeros(3)
            for i in range(d.ncon):
                con = d.contact[i]
                if gid not in (con.geom1, con.geom2):
                    continue
                mujoco.mj_contactForce(m, d, i, self._f6)
                frame = con.frame.reshape(3, 3)  # rows: normal (from geom1 to geom2), tangents
                f = frame.T @ self._f6[:3]  # force on geom2 (world)
                if con.geom1 == gid:
                    f = -f
                f_tot += f
                m_tot += rotations.cross(con.pos - c_W, f)
            buf.set_reaction(contact.name, k, f_tot, m_tot)
