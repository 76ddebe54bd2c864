"""``harness check``: read any MJCF/URDF model with four independent importers (MuJoCo,
Pinocchio, Drake and, for a URDF, PyBullet), say which agree on what, check the dynamics with two more engines built
from MuJoCo's reading (the in-house engine and Exudyn), then write a report.

Loads (``load_models``):

* ``--mjcf`` and ``--urdf``: MuJoCo from the MJCF, Pinocchio, Drake and PyBullet from the URDF;
* ``--urdf`` alone: all four from the URDF (MuJoCo compiles URDF itself);
* ``--mjcf`` alone: MuJoCo, Pinocchio and Drake from the MJCF (``pinocchio.buildModelFromMJCF``, Drake's
  ``Parser(plant).AddModels`` into a continuous ``MultibodyPlant``). PyBullet is not asked: its
  ``loadMJCF`` reads an MJCF in part (measured on dm_control's acrobot and cartpole: no ``<default>``
  classes, so geoms and joints typed by a class are dropped; bodies renamed); its reading is a one-line
  refusal shown with the loads (``Reading.other_format``), neither a refusal nor "not compared", and
  the three others compare exactly as without it.

PyBullet (``harness.tools.loaded_models.load_pybullet``) loads the URDF with
``URDF_USE_INERTIA_FROM_FILE`` (``useFixedBase`` unless ``--floating-base``), fixed links not merged by
PyBullet (each link keeps its own inertial; the check merges them, as for the others). Its gravity is
not compared (a URDF states none and PyBullet's default is zero); its M, bias and gravity come from
``calculateMassMatrix`` and ``calculateInverseDynamics`` (zero accelerations; zero velocities too for
gravity) with MuJoCo's gravity, on a fixed base (a floating base's dofs are not mapped: said in the
report). *Its inertia trap*: the URDF is loaded a second time without the flag (PyBullet's default:
inertia from the collision shapes; the file as written, even with ``--strip-geometry``, where PyBullet
finds its meshes; a link without a collision shape gets mass x 6.67e-7 m^2 on its diagonal); where its
inertias differ, the known limitation ``pybullet-urdf-inertia-from-collision-by-default`` is named in
one line of the summary, in the verdict and in the report's importer section (``Classification.trap``),
apart from the vote: it does not change the file's class.

MuJoCo is required: a file it does not load is bad input. Pinocchio and Drake may refuse a file
(a parser error, or a joint the harness cannot compare, such as Pinocchio's planar joint): the
refusal is one line in the result and the report ("Drake: does not load: <reason>") and the
other loaders still compare; when only MuJoCo loads there is nothing to compare (bad input).

The robot is fixed-base (a URDF's root link is welded to the world in every loader) unless
``floating_base`` adds a free joint named ``root_joint`` to the root body in every loader. Joints are
matched by name (MuJoCo's URDF import keeps the URDF joint names), or through a joint map
(``joint_map``, ``--joint-map FILE`` / ``--map mjcf=urdf``: the URDF's joints compared under the
MJCF's names, ``apply_joint_map``; a name neither file has is bad input); a free joint Drake names
after its body is matched to MuJoCo's free joint of that body. A body with several joints: MuJoCo
moves it by its joints in order; Pinocchio's composite joint (its MJCF parser's one joint for such
a body) is split back into the file's joints, in order; Drake's chain of massless bodies (one
joint each) is read as the one body. ``keep_static`` turns off MuJoCo's ``fusestatic``, on by
default for URDF.

Each loader reads the file as written unless the comparison needs a copy (section "the copies
the loaders read"; the report lists each change under "What the loaders read differs"):
``strip`` (``--strip-geometry``) removes geoms, meshes, height fields, textures, materials and
skins, and what refers to them, from every loader's copy (an MJCF's copy read by all its loaders,
a URDF's without ``<visual>``/``<collision>`` for Pinocchio and Drake, MuJoCo's reading of a URDF
stripped in its spec); mass properties then come from the ``<inertial>`` elements, and a body
whose mass MuJoCo derives from its geoms keeps it: MuJoCo compiles the file with its geometry
first and MuJoCo's reading (and an MJCF's copy for Pinocchio and Drake) carries those values as
explicit ``<inertial>`` elements, so that stripping does not change MuJoCo's dynamics (an MJCF's
loaders then all read MuJoCo's geom-derived masses; a URDF's Pinocchio and Drake read its
``<inertial>`` elements, as without stripping); where the geometry does not compile (a missing
mesh file) those masses are lost and the note names the bodies. An MJCF read by every loader
gets names for its unnamed bodies and joints (MuJoCo's ``body<k>``/``joint<j>``) and, in a copy,
a model name (Drake's parser needs one); keyframes that no longer fit (a root joint added, or
Pinocchio's reading of another size) are dropped; the check does not use keyframes. Equality
constraints, tendons and actuators are listed as "not compared" (``not_compared``: counts and
names).

Then, in order:

* the models (``vote``): per joint and per quantity (``QUANTITIES``: type, mass, centre of mass,
  inertia about it, position and orientation in the parent, axis, joint point, range, damping,
  friction loss, armature) and for gravity, which loaders agree within the tolerance. Where all
  the others agree against one (2 against 1, 3 against 1), that one is *the odd one out* (2 against
  2: no majority), and the report names it with both
  values and by how much they differ ("Pinocchio is the odd one out: 8.37758 kg where MuJoCo and
  Drake read 1 kg; they differ by 7.37758 kg (88.1% of 8.37758 kg)"). The odd one out reads the
  file differently from all the others: usually the importer that is wrong, but the file decides
  (only MuJoCo honours ``<compiler settotalmass>``, for instance). The joint settings (range rad
  or m, damping, friction loss, armature) of an MJCF and a URDF are listed, not counted (a URDF
  cannot state an armature); friction loss never counts (only MuJoCo applies it, Drake's parsers
  do not read it). The report's joint-settings table says per joint "same", "differs (by how
  much)" or "only <loader> reads it", and lists each actuator's gear (MuJoCo's ``gear``, Drake's
  gear ratio from a URDF transmission) as not compared. Importer differences that are not
  compared (fused links, masses MuJoCo derives from geoms where the file gives no
  ``<inertial>``, mimic joints, what Drake's parser ignores, Pinocchio's MJCF parser reading only
  the first body under ``<worldbody>``) are notes;
* what the differences come from (``diagnose``, ``Finding``), each named only when putting it
  back reconciles the two readings within the tolerance: a URDF ``<inertial><origin rpy>`` that
  one reading applies and the other does not (mujoco #3559: the difference of the inertias is
  R I0 R^T - I0 of the link's written tensor I0); a fixed child (URDF fixed joint, MJCF body
  without a joint) whose mass properties are missing or different in one reading of the body
  it is merged into (the bodies' ``parts``: with that child's part swapped the readings agree;
  e.g. MuJoCo's ``fusestatic`` dropping a massless link's inertia, an MJCF body without
  ``<inertial>``); an armature only some loaders read, with what it adds to M's diagonal entry
  at zero joint coordinates, and M differing by exactly that diagonal at every state
  (``diagnose_dynamics``); the first of a body's several joints that one reading puts at the
  parent body's origin (Drake's MJCF parser);
* the dynamics terms at random states (``harness.tools.dynamics_terms``) of every loader whose
  joints are MuJoCo's (same names and types; Drake's roll-pitch-yaw ball joints excluded; a
  loader that lacks whole kinematic trees of MuJoCo's is compared on the others, and so is every
  loader then: ``Reading.partial``), pair by pair, with the odd one out per term where one pair
  agrees and two differ;
* free motion under gravity from random states, MuJoCo against Pinocchio (MuJoCo RK4 with
  contacts, constraints, passive forces (gravity compensation and fluid forces included) and
  actuators off; Pinocchio ``aba`` with ``lie_group_integrators.rkmk4_step``), comparing joint
  trajectories and the world pose of every moving body both hold (matched through their joints);
  not run when Pinocchio does not load the file or its joints are not MuJoCo's.

* the in-house engine and Exudyn, two *witnesses of dynamics* (``harness.tools.witnesses``),
  built from MuJoCo's reading (its compiled model read into the harness's ``Multibody`` by
  ``harness.model.from_model_file.read_compiled``, fixed children merged), not from the file:
  they test the dynamics, not a parser, and never vote on the model quantities above (a
  witness would only repeat MuJoCo's reading). What each holds (mass, centre of mass, inertia,
  axis, position in parent per body) is listed against that description in a separate table;
  a difference is a build error and fails the check. The in-house M, bias and gravity (from its
  Newton-Euler accelerations for unit generalized forces) are compared with each loader's at
  the same random states (``Witnesses.dynamics``, the rows ``<loader> vs in-house`` of the
  report's dynamics table, kept out of ``CheckResult.dynamics``); it is named the odd one out in a term when it differs from
  MuJoCo while another loader agrees with MuJoCo (``witness_odd``); the loaders' own odd one out
  is decided among the loaders alone (``dynamics_odd``). Both run free motion from the same
  random states as Pinocchio, compared with MuJoCo's rigid run on every moving body's world
  pose and velocity (in-house at the check's tolerances; Exudyn, order 2, with its own). A
  model the description cannot hold (a body with several joints, equality constraints) leaves
  them "not run: <one line>" in the verdict and the report; the loaders still compare.

The report ``check_<model>.md`` is written atomically after everything has loaded. Its verdict
fails on any disagreement between the loaders that read the file (a refusal is reported, not
judged), on a dynamics term or a free motion beyond tolerance (the witnesses' included), on a
witness holding another model than its description, and ends with the causes found.

MuJoCo's warnings while the dynamics terms and the free motions run (e.g. "Nan, Inf or huge value
in QACC ... The simulation is unstable.") are captured into the result (``CheckResult.warnings``,
``harness.engines.mujoco.warning_capture``: count and first message) and shown in the report and
the summary, never printed on stderr; Drake's parser warnings (Python logging) are captured into
the notes.

Before any loader opens a file, it must be a regular file (symlinks resolved) of at most
``harness.model.input_files.MAX_INPUT_BYTES``, UTF-8 text, whose ``<include>``s, meshes, textures and
height fields lie inside its folder or a folder given with ``--allow-dir`` (``allowed_dirs``;
``harness.model.input_files.check_model_file``); a FIFO, a device, an include outside is bad input.
The copies live in a temporary folder ``harness-check-*``, removed on SIGTERM too
(``atomic.sigterm_exits``). When MuJoCo refuses the file, its own reason is the message (Pinocchio
is asked for a second opinion only on a body's mass or inertia).

Bad input (missing or malformed file, missing mesh, a file MuJoCo cannot load, non-positive
mass, an inertia that is not positive definite or violates the triangle inequality, a model that
only MuJoCo loads, a joint map naming joints the files do not have) raises ``InputError`` naming
the file or the option, before anything is written.


The package: ``reading`` (the files and the loaders' readings), ``comparing`` (which loaders agree),
``causes`` (what the differences come from), ``notes`` (importer differences not compared),
``dynamics`` (joint maps and free motion), ``run`` (``run_check``), ``report`` (verdict and report).
"""

from harness.tools.check.reading import (captured_native_stderr, check_spec_inertials, compile_spec, geom_inertials,
                                         load_models, load_mujoco, load_pinocchio, parse_map_options, read_joint_map,
                                         read_mujoco_spec, strip_geometry, supported_joints)
from harness.tools.check.report import render_report, summary_lines, verdict, write_report
from harness.tools.check.results import LOADERS, CheckResult, Finding, Reading, Vote
from harness.tools.check.classifying import CLASSES, Classification, classify
from harness.tools.check.comparing import vote
from harness.tools.check.run import run_check

__all__ = ["CLASSES", "Classification", "classify", "LOADERS", "CheckResult", "Finding", "Reading", "Vote", "captured_native_stderr",
           "check_spec_inertials", "compile_spec", "geom_inertials", "load_models", "load_mujoco", "load_pinocchio",
           "parse_map_options", "read_joint_map", "read_mujoco_spec", "render_report", "run_check", "strip_geometry",
           "summary_lines", "supported_joints", "verdict", "vote", "write_report"]
