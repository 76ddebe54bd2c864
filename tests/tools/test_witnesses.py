"""``harness check`` with the in-house engine and Exudyn built from MuJoCo's reading of the file
(``harness.tools.witnesses``): on a third-party robot their free motion converges to MuJoCo's (judged
by convergence, no tolerance), they are "not run" on a body with two joints, and a perturbed
in-house mass is named on the witnesses' line, never in the file's class (witnesses never vote)."""

import sysconfig
from dataclasses import replace
from pathlib import Path

import pytest

from harness.tools import witnesses
from harness.tools.check import render_report, run_check, summary_lines, verdict
from harness.tools.check.classifying import witness_line

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
UR5 = ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf"
FAST = {"n_states": 2, "n_free": 1, "t_end": 0.2}


@pytest.fixture(scope="module")
def ur5():
    return run_check(None, UR5, strip=True, **FAST)


def test_ur5_inhouse_and_exudyn_agree_with_the_loaders(ur5):
    res = ur5
    # the loaders agree; the file's one defect is ur5's wrist_3_link: 0.1879 kg with the inertia of a
    # 1.45 kg/m^3 box (ur_description's cylinder inertia of the whole wrist), lighter than air
    c = res.classes
    assert not c.disagreements and [(d.kind, d.element) for d in c.defects] == [("implausible density",
                                                                                 "link 'wrist_3_link'")]
    w = res.witnesses
    assert not w.refusal and w.rows and all(r.ok for r in w.rows)
    assert all("in-house" not in (d.a, d.b) for d in res.dynamics)   # the loaders' table is the loaders'
    inhouse = w.dynamics
    assert {d.term for d in inhouse} == {"M", "bias", "gravity"}
    assert {d.a for d in inhouse} | {d.b for d in inhouse} >= {"MuJoCo", "Pinocchio", "Drake", "in-house"}
    assert all(d.passed and d.max_rel < 1e-10 for d in inhouse)
    assert {f.witness for f in w.free} == {"in-house", "Exudyn"} and all(f.passed for f in w.free)
    # judged by convergence: each difference from MuJoCo's RK4 falls at the lower method's order or
    # sits at the resolution (1e-9 of the motion's scale)
    for f in w.free:
        for e in f.models.values():
            assert e.classification == "converges", (f.witness, e.reason)
            order = 4 if f.witness == "in-house" else 2
            assert e.error <= e.resolution * 10 or e.observed_order >= order - 0.5, (f.witness, e.reason)
    assert {f.method for f in w.free} == {"rk4_compiled", "TrapezoidalIndex2"}
    report = render_report(res, "harness check")
    assert "## The in-house engine and Exudyn (witnesses of dynamics)" in report
    assert "| MuJoCo vs in-house | M |" in report and "| Exudyn | TrapezoidalIndex2 | 0 |" in report
    assert any(line.startswith("  witnesses (never vote): in-house converges") for line in summary_lines(res))


def test_a_body_with_two_joints_leaves_the_witnesses_not_run(tmp_path):
    mjcf = tmp_path / "two.xml"
    mjcf.write_text("""<mujoco model="two"><worldbody>
  <body name="a" pos="0 0 1"><joint name="ja" type="hinge" axis="0 1 0"/>
    <inertial pos="0 0 -0.3" mass="1" diaginertia="0.02 0.03 0.01"/>
    <body name="b" pos="0 0 -0.6"><joint name="jb1" type="hinge" axis="1 0 0"/><joint name="jb2" type="hinge" axis="0 1 0"/>
      <inertial pos="0 0.1 -0.2" mass="0.5" diaginertia="0.01 0.02 0.015"/></body></body>
</worldbody></mujoco>""")
    res = run_check(mjcf, None, **FAST)
    assert res.witnesses.refusal and "2 joints" in res.witnesses.refusal
    assert witness_line(res).startswith("witnesses (in-house, Exudyn): not run: body 'b' has 2 joints")
    assert "- in-house: not run:" in render_report(res, "harness check")
    assert res.dynamics and not res.witnesses.dynamics   # the loaders still compare


def test_a_perturbed_inhouse_mass_fails_and_names_the_inhouse_engine(monkeypatch):
    from harness.engines import inhouse

    real = inhouse.build

    def heavier(model):
        nem = real(model)
        mass = nem.mass.copy()
        mass[2] *= 1.01
        Minv = nem.Minv.copy()
        Minv[6:9, 6:9] /= 1.01
        return replace(nem, mass=mass, Minv=Minv, weight_W=mass[:, None] * model.gravity_W[None, :])

    monkeypatch.setattr(inhouse, "build", heavier)
    res = run_check(None, UR5, strip=True, n_states=1, n_free=0, t_end=0.1)
    assert not res.classes.disagreements   # the witnesses never vote on the file
    assert "in-house holds body" in " ".join(res.witnesses.problems)
    line = witness_line(res)
    assert "in-house holds another model than MuJoCo's reading" in line and "in-house dynamics M" in line
    assert "in-house" not in verdict(res)
