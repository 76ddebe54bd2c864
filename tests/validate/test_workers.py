"""Isolated worker processes: a crash, a hang or an exception is that case's failure only."""

import os
import signal
import time

from harness.model.errors import InputError
from harness.validate.workers import run_cases


def _square(x):
    return x * x


def _die(_):
    os.kill(os.getpid(), signal.SIGKILL)


def _hang(_):
    time.sleep(60)


def _raise(_):
    raise ZeroDivisionError("boom")


def _bad_input(_):
    raise InputError("model.xml: cannot load MJCF")


def test_outcomes_of_each_kind_are_kept_apart():
    cases = [("ok", _square, (3,)), ("killed", _die, (0,)), ("hung", _hang, (0,)),
             ("raised", _raise, (0,)), ("input", _bad_input, (0,)), ("ok2", _square, (4,))]
    out = run_cases(cases, jobs=3, timeout=2.0)
    assert out["ok"].status == "ok" and out["ok"].value == 9
    assert out["ok2"].status == "ok" and out["ok2"].value == 16
    assert out["killed"].status == "crashed" and "exit code -9" in out["killed"].message
    assert out["hung"].status == "timeout"
    assert out["raised"].status == "error" and "ZeroDivisionError: boom" in out["raised"].message
    assert out["input"].status == "input_error" and out["input"].message == "model.xml: cannot load MJCF"


# ------------------------------------------------------------------------------------ hygiene
import subprocess  # noqa: E402
import sys  # noqa: E402
import uuid  # noqa: E402
from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from harness.validate import local_workers, workers  # noqa: E402

_PARENT = """
import time
from harness.validate.workers import run_cases

def long_case(i):
    time.sleep(120)
    return i

run_cases([(i, long_case, (i,)) for i in range(4)], jobs=4, timeout=300)
"""


def _marked(marker: str) -> set[int]:
    """Live (not zombie) processes whose environment holds ``marker``."""
    needle = marker.encode()
    found = set()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if needle not in (entry / "environ").read_bytes():
                continue
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state not in ("Z", "X"):
            found.add(int(entry.name))
    return found


def _until(predicate, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="looks processes up in /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_workers_die_with_a_killed_parent(sig, tmp_path):
    marker = f"HARNESS_WORKER_TEST={uuid.uuid4().hex}"
    env = {**os.environ, "HARNESS_WORKER_TEST": marker.split("=", 1)[1]}
    parent = subprocess.Popen([sys.executable, "-c", _PARENT], env=env, cwd=tmp_path)
    expected = min(4, local_workers.usable_cpus())
    try:
        assert _until(lambda: len(_marked(marker) - {parent.pid}) >= expected, 20.0), "workers did not start"
        started = _marked(marker) - {parent.pid}
        parent.send_signal(sig)
        assert parent.wait(10) == -sig  # it died of the signal, as it would have without workers
        assert _until(lambda: not (_marked(marker) & started), 5.0), f"orphaned workers: {_marked(marker) & started}"
        assert not _marked(marker)
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        for pid in _marked(marker):  # only processes this test started carry the marker
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def _big(n):
    return bytes(range(256)) * (n // 256)


def _segv(_):
    import faulthandler

    faulthandler.disable()  # pytest's traceback dump on SIGSEGV would only clutter the output
    os.kill(os.getpid(), signal.SIGSEGV)


def test_results_larger_than_a_pipe_come_back():
    n = 3 << 20  # 3 MiB, far more than a pipe holds (64 KiB)
    out = run_cases([("big", _big, (n,)), ("big2", _big, (n // 2,)), ("small", _square, (5,))], jobs=2, timeout=60.0)
    assert out["big"].status == "ok" and out["big"].value == bytes(range(256)) * (n // 256)
    assert out["big2"].status == "ok" and len(out["big2"].value) == n // 2
    assert out["small"].value == 25


def test_a_segfault_is_that_case_crashing_only():
    out = run_cases([("a", _square, (2,)), ("segv", _segv, (0,)), ("b", _square, (3,))], jobs=2, timeout=30.0)
    assert out["segv"].status == "crashed" and "SIGSEGV" in out["segv"].message and "-11" in out["segv"].message
    assert (out["a"].status, out["a"].value, out["b"].status, out["b"].value) == ("ok", 4, "ok", 9)


def _span(t):
    start = time.monotonic()
    time.sleep(t)
    return start, time.monotonic()


def test_jobs_are_clamped_to_the_usable_cpus(monkeypatch):
    monkeypatch.setattr(local_workers, "usable_cpus", lambda: 2)
    assert (workers.effective_jobs(100), workers.effective_jobs(None), workers.effective_jobs(0),
            workers.effective_jobs(1)) == (2, 2, 2, 1)
    out = run_cases([(i, _span, (0.25,)) for i in range(6)], jobs=100, timeout=30.0)
    spans = [out[i].value for i in range(6)]
    most = max(sum(s <= t < e for s, e in spans) for t, _ in spans)  # cases running at each case's start
    assert most <= 2


def test_usable_cpus_is_within_the_affinity_mask():
    assert 1 <= local_workers.usable_cpus() <= len(os.sched_getaffinity(0))


def test_each_timeout_counts_from_the_cases_own_start(monkeypatch):
    monkeypatch.setattr(local_workers, "usable_cpus", lambda: 1)
    # one at a time: the third case starts about 1.2 s after the first, past the 1 s timeout
    out = run_cases([(i, _span, (0.6,)) for i in range(3)], jobs=3, timeout=1.0)
    assert [out[i].status for i in range(3)] == ["ok"] * 3
    assert all(out[i].wall_s < 1.0 for i in range(3))


def test_workers_are_killed_when_the_parent_loop_fails(monkeypatch):
    started = []

    class Recording(set):
        def add(self, proc):
            started.append(proc)
            super().add(proc)

    monkeypatch.setattr(local_workers, "_LIVE", Recording())

    def broken_wait(self):
        raise RuntimeError("parent failed")

    monkeypatch.setattr(workers.Workers, "wait", broken_wait)
    with pytest.raises(RuntimeError, match="parent failed"):
        run_cases([(i, _hang, (i,)) for i in range(2)], jobs=2, timeout=60.0)
    assert started and all(p.exitcode == -signal.SIGKILL for p in started)
    assert not local_workers._LIVE


def _blas_threads():
    from threadpoolctl import threadpool_info

    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_a_worker_runs_its_blas_on_one_thread():
    """Workers run side by side, one per CPU: each one's BLAS gets one thread (three concurrent
    in-house runs of a loop scene were 15x slower with a thread per CPU each)."""
    import numpy  # noqa: F401 - loaded before the fork, as in every command

    parent = _blas_threads()
    outcome = run_cases([("blas", _blas_threads, ())], jobs=1, timeout=30)["blas"]
    assert outcome.status == "ok", outcome.message
    assert outcome.value and all(n == 1 for n in outcome.value)
    if (os.cpu_count() or 1) > 1 and "OPENBLAS_NUM_THREADS" not in os.environ:
        assert max(parent) > 1  # the limit is the worker's, not inherited: the parent keeps its threads


def _three_then_hang(hang: float):
    import time as _time

    for k in range(3):
        yield k
    _time.sleep(hang)
    yield 99


def _raises_after_one():
    yield 1
    raise ValueError("bad point")


def test_a_stream_yields_each_item_as_it_comes_and_ends_a_hang_at_its_budget():
    """``stream_case``: one worker for a sequence of items, each under its own budget: the items
    before a hang arrive, the hang ends as ``timeout`` within the budget, the worker is gone."""
    import time

    from harness.validate.local_workers import _LIVE, stream_case

    start = time.monotonic()
    outcomes = list(stream_case(_three_then_hang, (30.0,), 0.5))
    assert [o.value for o in outcomes[:3]] == [0, 1, 2] and all(o.status == "ok" for o in outcomes[:3])
    assert outcomes[3].status == "timeout" and len(outcomes) == 4
    assert time.monotonic() - start < 10 and not _LIVE
    assert [o.value for o in stream_case(_three_then_hang, (0.0,), 5.0)] == [0, 1, 2, 99]
    errors = list(stream_case(_raises_after_one, (), 5.0))
    assert [o.status for o in errors] == ["ok", "error"] and "ValueError: bad point" in errors[1].message


def _nested(x):
    from harness.validate.workers import in_worker, run_cases, stream_case

    inner = run_cases([("inner", abs, (x,))], 1, 5.0)["inner"]
    streamed = [o.value for o in stream_case(_three_then_hang, (0.0,), 5.0)]
    return in_worker(), inner.status, inner.value, streamed


def test_cases_started_inside_a_worker_run_in_it():
    """A worker is a daemonic process, which may start none of its own: ``run_cases`` and
    ``stream_case`` called inside one (a zoo model's check, its witnesses' runs) run the cases in
    that worker, under its budget, instead of failing."""
    from harness.validate.workers import in_worker, run_cases

    outcome = run_cases([("outer", _nested, (-3,))], 1, 30.0)["outer"]
    assert outcome.status == "ok", outcome.message
    assert outcome.value == (True, "ok", 3, [0, 1, 2, 99]) and not in_worker()
