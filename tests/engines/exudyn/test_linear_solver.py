"""Exudyn's linear solver by system size (``harness.engines.exudyn.engine.linear_solver``): the
sparse LU on a large system (four_bar_chain, IFToMM A02) runs through the flat singular position
as the dense LU does, and every other shipped scene keeps the dense LU it always had."""

from dataclasses import replace

import numpy as np
import pytest

from harness.engines import get_engine, integrator_of, load_scene
from harness.engines.base import RunSettings
from harness.engines.exudyn import engine as exudyn_engine
from harness.engines.exudyn.integrators import NODE_TYPE
from harness.engines.exudyn.model import build
from harness.model.scene import available_scenes
from harness.references import four_bar_chain as chain

ENGINE = get_engine("exudyn")


def _chain(n: int):
    return replace(load_scene("four_bar_chain", {"N": n}), not_run={})


def _run(scene, t_end: float = 1.0, dt: float = 1e-3):
    return ENGINE.simulate(scene, RunSettings(t_end=t_end, dt=dt, save_every=0.05, integrator="GeneralizedAlpha"))


@pytest.mark.parametrize("n, solver", [(2, "EXUdense"), (4, "EigenSparse")])
def test_solver_goes_by_the_size_of_the_system(n, solver):
    """four_bar_chain at N = 2 (67 coordinates) stays dense, at N = 4 (123) it is sparse."""
    system = build(_chain(n).multibody(), "RotationRotationVector")
    size = exudyn_engine.system_size(system)
    assert (size >= exudyn_engine.SPARSE_MIN_SIZE) == (solver == "EigenSparse"), size
    assert exudyn_engine.linear_solver(system) == solver


def test_sparse_solver_runs_through_the_flat_position_as_the_dense_one():
    """four_bar_chain N = 4, 1 s at 1 ms through the first flat position (t = 0.715 s, where the 4
    loops lose 4 rows for an instant): the sparse run with one Jacobian per step (its settings say
    so) is within 5e-5 m of the exact motion in every crank's tip (measured 1.76e-5 m) and within
    1e-7 m of the dense LU's run with full Newton (measured 3.6e-10 m; a window folded at the flat
    position would be off by metres)."""
    scene = _chain(4)
    sparse = _run(scene)
    assert sparse.status == "ok", sparse.message
    assert "sparse LU (EigenSparse)" in sparse.stats["settings"]
    assert "one Jacobian per step" in sparse.stats["settings"]
    assert sparse.t[-1] == pytest.approx(1.0)
    theta, _, _ = chain.crank_motion(scene.params, sparse.t)
    assert theta[0] > 0.0 > theta[-1]  # the cranks pass the flat position theta = 0 (along the ground)
    assert chain.exact_error_series(scene, sparse).max() < 5e-5

    chosen = exudyn_engine.linear_solver
    try:
        exudyn_engine.linear_solver = lambda system: "EXUdense"
        dense = _run(scene)
    finally:
        exudyn_engine.linear_solver = chosen
    assert "dense LU (EXUdense)" in dense.stats["settings"] and "full Newton" in dense.stats["settings"]
    assert np.abs(sparse.p_WCm_W - dense.p_WCm_W).max() < 1e-7


@pytest.mark.parametrize("name", [n for n in available_scenes() if n != "four_bar_chain"])
def test_other_scenes_keep_their_solver(name):
    """Every shipped scene but four_bar_chain is below the sparse threshold: its runs are as before
    (dense LU, or the full-pivot LU where rows are dependent)."""
    scene = load_scene(name)
    system = build(scene.multibody(), NODE_TYPE[integrator_of(scene, "exudyn")])
    assert exudyn_engine.linear_solver(system) in ("EXUdense", "EigenDense")
    assert exudyn_engine.system_size(system) < exudyn_engine.SPARSE_MIN_SIZE
