"""``--dask``: the sweeps' cases on a ``dask.distributed`` cluster give what the local pool gives.

One ``LocalCluster`` (2 worker processes, one thread each) serves the whole module."""

import json
import logging
import math
import operator
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import pandas as pd
import pytest

distributed = pytest.importorskip("distributed")

from harness.cli.main import build_parser, main  # noqa: E402
from harness.engines import load_scene  # noqa: E402
from harness.validate import dask_workers  # noqa: E402
from harness.validate.local_workers import _prctl  # noqa: E402
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
    assert len(lines) == 1 and lines[0].startswith(f"harness: error: cannot reach a Dask scheduler at {address}: "), err
    assert not out.exists()


@pytest.fixture
def not_dask(request):
    """``tcp://127.0.0.1:PORT`` where something that is not a Dask scheduler listens: ``silent``
    accepts and never says anything, ``http`` is Python's HTTP server (which waits for a request
    line that never comes), ``http answers`` replies an HTTP 400 at once."""
    import http.server
    import threading

    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args):  # its log is its stderr, not the command's
            pass

    if request.param == "http":
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        try:
            yield f"tcp://127.0.0.1:{server.server_address[1]}"
        finally:
            server.shutdown()
            server.server_close()
        return
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(4)
    listener.settimeout(0.05)
    accepted, over = [], threading.Event()

    def serve():
        while not over.is_set():
            try:
                conn, _ = listener.accept()
            except OSError:  # none yet
                continue
            accepted.append(conn)
            if request.param == "http answers":
                conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        over.set()
        thread.join(5)
        listener.close()
        for conn in accepted:
            conn.close()


@pytest.mark.parametrize("not_dask", ["silent", "http", "http answers"], indirect=True)
def test_a_server_that_is_not_dask_is_one_line_within_the_timeout(not_dask, tmp_path, capsys, monkeypatch):
    """The issue's case 1: the handshake after the connection is bounded too (it hung for ever)."""
    monkeypatch.setattr(dask_workers, "CONNECT_TIMEOUT", 0.5)
    out = tmp_path / "out"
    start = time.monotonic()
    code = main(["stress", "--quick", "--engines", "mujoco", "--out-dir", str(out), "--dask", not_dask])
    wall = time.monotonic() - start
    err = capsys.readouterr().err
    assert code == 2 and wall < 5, (code, wall)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"harness: error: cannot reach a Dask scheduler at {not_dask}: "), err
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
    assert outcome.message.startswith("Dask worker lost: ")


# ------------------------------------------------------------------ a lost worker, a lost scheduler
# Dask processes of their own, started here without a nanny (``dask worker --no-nanny``: nothing
# restarts one that is killed), bound to 127.0.0.1, killed by the test and with this process
# (PR_SET_PDEATHSIG). The cases sleep a second or two.
def _spawn(*argv: str) -> subprocess.Popen:
    prctl = _prctl()

    def die_with_us():
        if prctl is not None:
            prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG

    return subprocess.Popen([sys.executable, "-m", *argv], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=die_with_us)


def _dask_worker(scheduler: str) -> subprocess.Popen:
    return _spawn("distributed.cli.dask_worker", scheduler, "--no-nanny", "--nthreads", "1", "--host", "127.0.0.1",
                  "--no-dashboard", "--death-timeout", "30")


def _until(what, timeout: float = 30.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = what()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"not within {timeout} s")


def _stop(procs) -> None:
    for proc in procs:
        proc.kill()
        proc.wait(10)


def _kill_when_running(client, pid_of, sig=signal.SIGKILL) -> threading.Thread:
    """In a thread: send ``sig`` to the process ``pid_of(worker address)`` as soon as a worker runs a case."""
    def kill():
        busy = _until(lambda: [w for w, keys in client.processing().items() if keys])
        os.kill(pid_of(busy[0]), sig)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


@pytest.fixture(scope="module")
def bare_scheduler():
    """A scheduler without workers, on 127.0.0.1: each test brings (and kills) its own."""
    cluster = distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp", host="127.0.0.1",
                                       scheduler_port=0, dashboard_address=":0", silence_logs=logging.ERROR)
    try:
        yield cluster.scheduler_address
    finally:
        dask_workers.close_clients()
        cluster.close()


SLEEPS = [(f"sleep {i}", time.sleep, (1.0,)) for i in range(3)]


def _connected(address: str, n_workers: int):
    client = dask_workers.connect(address)
    client.wait_for_workers(n_workers, timeout=30)
    return client


def test_a_killed_workers_case_runs_again_on_another(bare_scheduler):
    """The issue's case 2, another worker left: Dask resubmits the dead worker's case there."""
    procs = [_dask_worker(bare_scheduler) for _ in range(2)]
    try:
        client = _connected(bare_scheduler, 2)
        pids = client.run(os.getpid)
        killer = _kill_when_running(client, pids.get)
        start = time.monotonic()
        out = run_cases(SLEEPS, None, 20.0, dask=bare_scheduler)
        wall = time.monotonic() - start
        killer.join(5)
        assert {k: o.status for k, o in out.items()} == {k: "ok" for k, _, _ in SLEEPS}, out
        assert wall < 15, wall  # 3 sleeps of 1 s on 2 workers, one started again: not timeout + 60 s
        assert sum(p.poll() is not None for p in procs) == 1
    finally:
        _stop(procs)


def test_the_only_workers_loss_fails_every_case_at_once(bare_scheduler, monkeypatch, capfd):
    """The issue's case 2, no worker left: the waiting case and those not yet started end
    ``crashed`` ("Dask worker lost") within ``NO_WORKER_S`` s, one line says so."""
    monkeypatch.setattr(dask_workers, "NO_WORKER_S", 1.0)
    procs = [_dask_worker(bare_scheduler)]
    try:
        client = _connected(bare_scheduler, 1)
        killer = _kill_when_running(client, lambda _: procs[0].pid)
        capfd.readouterr()
        start = time.monotonic()
        out = run_cases(SLEEPS, None, 20.0, dask=bare_scheduler)  # one slot: two wait their turn
        wall = time.monotonic() - start
        killer.join(5)
        start = time.monotonic()  # a command's next batch (validate's engine runs after its references)
        again = run_cases(SLEEPS, None, 20.0, dask=bare_scheduler)
        again_wall = time.monotonic() - start
    finally:
        _stop(procs)
        dask_workers.close_clients()  # forgets the loss
    assert [o.status for o in out.values()] == ["crashed"] * 3, out
    assert all(o.message.startswith("Dask worker lost (no worker left on the scheduler") for o in out.values())
    assert wall < 10, wall
    assert again == {k: Outcome("crashed", message=out["sleep 0"].message) for k, _, _ in SLEEPS} and again_wall < 0.5
    err = capfd.readouterr().err.strip().splitlines()
    assert err == [f"harness: {out['sleep 0'].message}: the cases not finished are recorded as failed"], err


def test_a_hung_cluster_ends_every_waiting_case_at_one_deadline(bare_scheduler, monkeypatch, capfd):
    """A worker that hangs (stopped: the scheduler still counts it) gives no result: when none
    came for the longest waiting timeout plus ``GRACE_S``, every case ends ``timeout`` at once, the
    waiting one and those not yet started, not one deadline after another."""
    monkeypatch.setattr(dask_workers, "GRACE_S", 0.5)
    procs = [_dask_worker(bare_scheduler)]
    try:
        client = _connected(bare_scheduler, 1)
        stopper = _kill_when_running(client, lambda _: procs[0].pid, signal.SIGSTOP)
        capfd.readouterr()
        start = time.monotonic()
        out = run_cases([(k, time.sleep, (0.8,)) for k, _, _ in SLEEPS], None, 1.0, dask=bare_scheduler)
        wall = time.monotonic() - start
        stopper.join(5)
    finally:
        _stop(procs)
        dask_workers.close_clients()  # forgets the loss
    message = f"no result from the Dask cluster at {bare_scheduler} for 1.5 s"
    assert [(o.status, o.message) for o in out.values()] == [("timeout", message)] * 3, out
    assert wall < 6, wall  # 1.5 s once, not three times
    err = capfd.readouterr().err.strip().splitlines()
    assert err == [f"harness: {message}: the cases not finished are recorded as failed"], err


def test_a_lost_scheduler_fails_the_cases_in_one_line_without_tracebacks(tmp_path, monkeypatch, capfd):
    """The issue's case 3: the scheduler killed under a case; every case ends ``crashed``
    ("Dask scheduler lost"), one line says so, and none of distributed's tracebacks shows, not
    even once its client gives up reconnecting."""
    monkeypatch.setattr(dask_workers, "CONNECT_TIMEOUT", 1.0)  # the client's reconnection window too
    logged = []  # what distributed's loggers let through (its handlers write to the stderr of its import)
    recorder = logging.Handler()
    recorder.emit = logged.append
    loggers = [logging.getLogger(name) for name in ("distributed", "distributed.client", "distributed.core")]
    for logger in loggers:
        logger.addHandler(recorder)
    file = tmp_path / "scheduler.json"
    procs = [_spawn("distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(file))]
    try:
        address = _until(lambda: file.exists() and json.loads(file.read_text() or "{}").get("address"))
        procs.append(_dask_worker(address))
        client = _connected(address, 1)
        killer = _kill_when_running(client, lambda _: procs[0].pid)
        capfd.readouterr()
        start = time.monotonic()
        out = run_cases(SLEEPS, None, 20.0, dask=address)
        wall = time.monotonic() - start
        killer.join(5)
        _until(lambda: client.status == "closed", 20)  # it tried to reconnect and gave up, logging it
        dask_workers.close_clients()
    finally:
        _stop(procs)
        for logger in loggers:
            logger.removeHandler(recorder)
    assert [o.status for o in out.values()] == ["crashed"] * 3, out
    assert all(o.message == f"Dask scheduler lost (the connection to {address} closed)" for o in out.values())
    assert wall < 10, wall
    err = capfd.readouterr().err.strip().splitlines()
    assert err == [f"harness: {out['sleep 0'].message}: the cases not finished are recorded as failed"], err
    assert [r.getMessage() for r in logged if r.levelno >= logging.WARNING] == []
