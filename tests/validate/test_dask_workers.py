"""``--dask``: the sweeps' cases on a ``dask.distributed`` cluster give what the local pool gives.

One ``LocalCluster`` (2 worker processes, one thread each) serves the whole module."""

import logging
import math
import operator
import os
import socket
import time
from types import SimpleNamespace

import pandas as pd
import pytest

distributed = pytest.importorskip("distributed")

from harness.cli.main import build_parser, main  # noqa: E402
from harness.model.scene import load_scene  # noqa: E402
from harness.validate import dask_workers  # noqa: E402
from harness.validate.workers import Outcome, run_cases  # noqa: E402


@pytest.fixture(scope="module")
def address():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                       silence_logs=logging.ERROR)
    try:
        yield cluster.scheduler_address
    finally:
        dask_workers.close_clients()
        cluster.close()


# Importable functions only: a case travels pickled by reference, as the harness's own cases do.
CASES = [
    ("ok", math.factorial, (5,)),
    ("raises", operator.truediv, (1, 0)),
    ("crashes", os._exit, (3,)),
    ("hangs", time.sleep, (30,)),
    ("bad input", load_scene, ("no_such_scene",)),
    ("large", bytes, (3 << 20,)),  # 3 MiB, more than a pipe or a small message holds
    ("ok again", abs, (-2,)),
]


def test_run_cases_on_dask_gives_the_local_outcomes(address):
    remote = run_cases(CASES, None, 1.0, dask=address)
    local = run_cases(CASES, None, 1.0)
    assert list(remote) == list(local) == [key for key, _, _ in CASES]  # the cases' order
    for key in local:
        r, l = remote[key], local[key]
        assert (r.status, r.message, r.value) == (l.status, l.message, l.value), key
    assert [local[k].status for k in local] == ["ok", "error", "crashed", "timeout", "input_error", "ok", "ok"]
    assert local["raises"].message.startswith("ZeroDivisionError: division by zero")
    assert local["crashes"].message == "worker died (exit code 3)"
    assert remote["hangs"].message == "no result within 1 s" and 1.0 <= remote["hangs"].wall_s < 5


def test_stress_with_dask_gives_the_local_map(address, tmp_path, capsys, monkeypatch):
    """The issue's done-when: ``harness stress --dask tcp://...`` against a running scheduler
    and workers gives the same map as a local run."""
    from harness.studies.stress import report

    for plot in ("map_png", "variant_png"):  # seconds of drawing each, and not what is compared
        monkeypatch.setattr(report, plot, lambda *a: None)
    common = ["stress", "--variants", "torque_free_spin_1e3", "--engines", "mujoco", "--quick", "--quiet"]
    assert main(common + ["--out-dir", str(tmp_path / "local")]) == 0
    assert main(common + ["--out-dir", str(tmp_path / "dask"), "--dask", address]) == 0
    capsys.readouterr()
    local, remote = (pd.read_csv(tmp_path / d / "stress_map.csv") for d in ("local", "dask"))
    assert len(local) == 4  # MuJoCo's four integrators
    pd.testing.assert_frame_equal(local, remote)
    local, remote = (pd.read_csv(tmp_path / d / "stress.csv", comment="#").drop(columns="wall_s")
                     for d in ("local", "dask"))
    assert len(local) > 4
    pd.testing.assert_frame_equal(local, remote)


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize("command", [["stress", "--quick", "--engines", "mujoco"], ["validate", "--scenes", "torque_free"],
                                     ["workprecision", "--quick", "--scenes", "torque_free"], ["zoo", "dm_control"]])
def test_an_unreachable_scheduler_is_one_line_and_nothing_written(command, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(dask_workers, "CONNECT_TIMEOUT", 0.3)
    out = tmp_path / "out"
    address = f"tcp://127.0.0.1:{_closed_port()}"
    code = main(command + ["--out-dir", str(out), "--dask", address])
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("harness: error: --dask " + address), err
    assert "cannot reach the Dask scheduler" in lines[0]
    assert not out.exists()


def test_the_address_is_checked_when_parsed(capsys):
    args = build_parser().parse_args(["stress", "--dask", "127.0.0.1:8786"])
    assert args.dask == "tcp://127.0.0.1:8786"
    assert main(["stress", "--dask", "tcp://127.0.0.1"]) == 2
    assert "not a scheduler address" in capsys.readouterr().err


def test_a_dead_dask_worker_is_that_case_crashing():
    """The Dask worker itself dying under a case (killed from outside: the case's own crash never
    reaches it) is that case's ``crashed`` outcome."""
    from distributed.scheduler import KilledWorker

    class Dead:
        status = "error"

        def exception(self):
            return KilledWorker("harness-case-1", SimpleNamespace(address="tcp://127.0.0.1:1"), 0)

    outcome = dask_workers.DaskWorkers._outcome(None, dask_workers._Submitted("k", Dead(), time.monotonic(), 1.0))
    assert isinstance(outcome, Outcome) and outcome.status == "crashed"
    assert outcome.message.startswith("the Dask worker running it died")
