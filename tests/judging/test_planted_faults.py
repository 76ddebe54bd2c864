"""Planted faults, each classified as what it is by the convergence judging
(``harness.judging.checks.judge_convergence``), with a run of the unfaulted engine beside where
the fault is ours to plant:

* an armature of 1e-9 kg m^2 on the crank's hinge of a copied Andrews squeezer MJCF: a model
  difference of MuJoCo's beyond the soft-constraint bound its scene declares (2e-4);
* a Runge-Kutta 4 with one stage dropped (the per-state in-house ``rk4``): a defect, order 2;
* MuJoCo's soft loop constraints on the unmodified Andrews squeezer: a declared model
  difference within its bound, passes;
* Exudyn's generalized-alpha on the heavy top: converges at order 2.

The engine cases run in this process (``reference_case``, ``engine_case``: the bodies of
``validate``'s worker processes), so that a fault planted with ``monkeypatch`` reaches them.
"""

import shutil
from dataclasses import replace

import pytest

from harness.engines.inhouse import integrators
from harness.model.scene import MODELS_DIR
from harness.engines import load_scene
from harness.validate.run import engine_case, model_checks, reference_case

pytest.importorskip("mujoco")

DECLARED = "model difference (declared)"


def _judged(checks):
    """The checks judged by convergence (a class), by name."""
    return {c.check: c for c in checks if c.classification}


@pytest.fixture(scope="module")
def andrews():
    """The Andrews squeezer and its reference case (DOP853, rtol 1e-12; about 7 s)."""
    scene = load_scene("andrews_squeezer")
    return scene, reference_case(scene)


def _mujoco_case(scene, andrews):
    _, (ref, _, _, solutions) = andrews
    _, record, checks, _ = engine_case(scene, "mujoco", ref, True, solutions)
    assert record.status == "ok", record.message
    return _judged(checks)


@pytest.mark.slow
def test_mujocos_soft_loop_constraints_are_a_declared_model_difference_within_its_bound(andrews):
    scene, _ = andrews
    bound = scene.model_differences["mujoco"]["bound"]
    judged = _mujoco_case(scene, andrews)
    assert all(c.passed for c in judged.values()), [(c.check, c.judged) for c in judged.values() if not c.passed]
    soft = {n: c for n, c in judged.items() if c.classification == DECLARED}
    # the loops' soft connects move the bodies' angles and rates: a floor, not the step's error
    assert {"trajectory.orientation", "exact", "closure.position", "reaction.force"} <= set(soft)
    for c in soft.values():
        assert "within its bound" in c.judged
    worst = soft["trajectory.orientation"]
    # measured: 6.3e-5 rad (6.337e-5 at 1e-5 s, 6.270e-5 at 2e-5 s, 6.341e-5 at 5e-6 s)
    assert 1e-5 < worst.floor < bound
    assert worst.floor == pytest.approx(worst.value, rel=0.05)  # the whole error is the floor


@pytest.mark.slow
def test_an_armature_on_one_hinge_is_a_model_difference_beyond_the_soft_constraints_bound(tmp_path, andrews):
    shutil.copytree(MODELS_DIR / "andrews_squeezer", tmp_path / "andrews_squeezer")
    mjcf = tmp_path / "andrews_squeezer" / "andrews_squeezer.xml"
    text = mjcf.read_text()
    hinge = '<joint name="body1_hinge" type="hinge"'
    assert text.count(hinge) == 1
    mjcf.write_text(text.replace(hinge, hinge + ' armature="1e-9"'))
    scene = load_scene("andrews_squeezer", models_dir=tmp_path)
    bound = scene.model_differences["mujoco"]["bound"]
    assert bound == 2e-4  # the scene's bound, unchanged
    # the model files' checks read masses, inertias, joints and axes: not an armature (the
    # dynamics verdict below is what catches it, whichever way those checks go)
    model_checks(scene, ["mujoco"])
    judged = _mujoco_case(scene, andrews)
    failed = {n: c for n, c in judged.items() if not c.passed}
    assert failed, "the armature went unnoticed"
    for c in failed.values():
        assert c.classification == DECLARED, (c.check, c.classification, c.judged)
        assert "beyond its bound" in c.judged
    worst = judged["trajectory.orientation"]
    # measured: 6.2e-3 rad (the soft constraints alone: 6.3e-5), 31x the bound; a constant in the step
    assert worst in failed.values() and judged["exact"] in failed.values()
    assert worst.floor > 10 * bound
    assert worst.floor == pytest.approx(worst.value, rel=0.05)


#: RK4 with its third stage dropped: k3 is never computed and k2 stands in its place, so the
#: fourth stage starts from y + h k2 and the weights become (1, 4, 1) / 6; the order
#: conditions up to order 2 still hold, the third order's sum b_i a_ij c_j is 1/12, not 1/6.
DROPPED_STAGE = integrators.ButcherTableau(
    name="rk4", A=((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (0.0, 1.0, 0.0)), b=(1 / 6, 4 / 6, 1 / 6),
    c=(0.0, 0.5, 1.0), order=4)


def _heavy_top_per_state():
    """The heavy top over 1 s (the class is the same over its 5 s), the per-state in-house RK4 judged."""
    scene = replace(load_scene("heavy_top"), t_end=1.0)
    ref, _, _, solutions = reference_case(scene)
    _, record, checks, _ = engine_case(scene, "inhouse", ref, False, solutions)
    assert record.status == "ok" and record.integrator == "rk4", (record.integrator, record.message)
    return _judged(checks)


def test_rk4_with_a_dropped_stage_is_a_defect_of_order_two(monkeypatch):
    judged = _heavy_top_per_state()  # unfaulted: order 4, or at the resolution
    assert all(c.passed and c.classification == "converges" for c in judged.values())
    assert judged["trajectory.orientation"].order == pytest.approx(4.0, abs=0.3)

    monkeypatch.setitem(integrators.FIXED_STEP, "rk4", DROPPED_STAGE)
    judged = _heavy_top_per_state()
    defects = {n: c for n, c in judged.items() if c.classification == "defect"}
    # measured orders 1.93 (momentum_drift.Lz) to 2.04 (exact); the others at the resolution
    assert {"trajectory.position", "trajectory.orientation", "exact", "energy_drift"} <= set(defects)
    for c in defects.values():
        assert not c.passed
        assert 1.0 <= c.order <= 3.0 and c.order == pytest.approx(2.0, abs=0.2), (c.check, c.order)
        assert "where the method's is 4" in c.judged
        assert c.floor == 0.0
    assert all(c.classification in ("defect", "converges") for c in judged.values())
    assert all("at the resolution" in c.judged for c in judged.values() if c.classification == "converges")


def test_exudyns_generalized_alpha_converges_at_order_two():
    scene = load_scene("heavy_top")
    ref, _, _, solutions = reference_case(scene)
    _, record, checks, _ = engine_case(scene, "exudyn", ref, True, solutions)
    assert record.status == "ok", record.message
    judged = _judged(checks)
    assert all(c.passed and c.classification == "converges" for c in judged.values()), \
        [(c.check, c.classification, c.judged) for c in judged.values()]
    ordered = {n: c.order for n, c in judged.items() if "at the resolution" not in c.judged}
    # measured: 2.00-2.06, momentum_drift.Lz 2.62 (its error at 2h is the pre-asymptotic one)
    assert {"trajectory.position", "trajectory.orientation", "exact", "energy_drift"} <= set(ordered)
    for name, order in ordered.items():
        if name.startswith("momentum_drift"):
            assert order >= 2.0 - 0.3, (name, order)
        else:
            assert order == pytest.approx(2.0, abs=0.3), (name, order)
