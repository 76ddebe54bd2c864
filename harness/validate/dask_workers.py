"""Isolated cases on a Dask cluster: the executor behind every sweep's ``--dask ADDRESS``.

``DaskWorkers(address, jobs)`` has the interface of ``harness.validate.workers.Workers``
(``start``, ``wait``, ``free``, ``len``, a context manager), so ``run_cases`` and the stress
study's work-conserving loop run on a ``dask.distributed`` scheduler when given its address and on
the local pool otherwise (``workers.open_workers``). Nothing else in the harness imports Dask.

Each case is one Dask task, ``_remote_case``, which runs the case on the Dask worker through the
very local pool (``workers.run_cases`` with one slot): the worker forks a fresh process for it,
limits its BLAS to one thread and enforces its timeout from the case's own start. So the isolation
contract and the ``Outcome`` are those of a local run: a case that raises is ``error``, one
whose process dies (a segfault, ``os._exit``) is ``crashed`` with the same message, one past its
timeout is ``timeout``; the Dask worker itself survives all three and takes the next case. Only
a Dask worker that dies under a case (killed from outside, out of memory) reaches Dask, which
retries the task elsewhere and then gives up: that case is ``crashed`` ("the Dask worker running
it died"). A case whose task outlives its timeout by ``GRACE_S`` on this side (a worker that hangs
or vanishes without Dask noticing) is ``timeout`` and its task is cancelled.

A Dask worker process is daemonic (``distributed.worker.daemon``) and multiprocessing refuses
children to daemonic processes; ``_remote_case`` lifts that flag in the worker process. The case
processes die with it anyway (``PR_SET_PDEATHSIG``, ``workers._die_with_parent``).

At most ``slots`` cases are submitted at once: the cluster's worker threads (``jobs``, when given,
caps it), so a case starts as it is submitted. Cases and results travel pickled
(``cloudpickle``); a Dask worker first imports the harness modules this process has loaded
(``_preload``, once each), as a forked local worker inherits them. So a worker needs the harness
importable: the same environment on every worker, and the scene files at the same paths for a
cluster of several machines.

``connect(address)`` checks the scheduler answers (``CONNECT_TIMEOUT`` s) and has a worker, and
raises ``InputError`` (exit 2, one line) otherwise; it keeps one client per address for the
process, closed at exit or by ``close_clients()``.
"""

from __future__ import annotations

import atexit
import pickle
import sys
import threading
import time
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Hashable

from harness.model.errors import InputError
from harness.validate.workers import Outcome

CONNECT_TIMEOUT = 5.0  # s to reach the scheduler, and again for a first worker to be there
GRACE_S = 60.0  # s past a case's timeout before this side gives up on its task

_CLIENTS: dict[str, Any] = {}
_LOCK = threading.Lock()


# ------------------------------------------------------------------------------------ client
def _why(err: BaseException) -> str:
    if isinstance(err, (OSError, ValueError, TimeoutError)):
        text = " ".join(str(err).split())
        return text[:200] or type(err).__name__
    return f"no Dask scheduler answered there ({type(err).__name__})"


def connect(address: str):
    """The ``distributed.Client`` of the scheduler at ``address`` (``tcp://host:port``), made
    once per process. InputError, one line, when no scheduler answers within
    ``CONNECT_TIMEOUT`` s or it has no worker within as long."""
    import asyncio

    with _LOCK:
        client = _CLIENTS.get(address)
        if client is not None and client.status == "running":
            return client
        try:
            from distributed import Client
            from distributed.comm import connect as comm_connect
        except ImportError as err:  # pragma: no cover - a dependency of the project
            raise InputError(f"--dask needs dask.distributed: pip install 'dask[distributed]' ({err})") from None

        async def probe() -> None:  # a bare handshake first: a failed Client leaves noise behind
            comm = await comm_connect(address, timeout=CONNECT_TIMEOUT)
            await comm.close()

        try:
            asyncio.run(probe())
        except Exception as err:
            raise InputError(f"--dask {address}: cannot reach the Dask scheduler: {_why(err)}") from None
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except Exception as err:
            raise InputError(f"--dask {address}: cannot reach the Dask scheduler: {_why(err)}") from None
        try:
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
        except Exception:
            client.close()
            raise InputError(f"--dask {address}: the Dask scheduler has no worker (start one with "
                             f"`dask worker {address}`)") from None
        if not _CLIENTS:
            atexit.register(close_clients)
        _CLIENTS[address] = client
        return client


def close_clients() -> None:
    """Close every client ``connect`` made (the clusters keep running)."""
    with _LOCK:
        for client in _CLIENTS.values():
            try:
                client.close()
            except Exception:  # a scheduler already gone
                pass
        _CLIENTS.clear()


def cluster_threads(address: str) -> int:
    """Worker threads of the cluster at ``address`` now (at least 1)."""
    return max(1, sum(connect(address).nthreads().values()))


def slots(address: str, jobs: int | None) -> int:
    """Cases run at once on the cluster: its worker threads, at most ``jobs`` when given (> 0)."""
    threads = cluster_threads(address)
    return threads if not jobs or jobs < 0 else max(1, min(int(jobs), threads))


# ------------------------------------------------------------------------------------ worker side
_IMPORTED: set[str] = set()  # in a Dask worker: the harness modules ``_remote_case`` imported


def _loaded_modules() -> tuple[str, ...]:
    """The harness modules this process has imported (the engines among them)."""
    return tuple(sorted(name for name in list(sys.modules) if name == "harness" or name.startswith("harness.")))


def _preload(names: tuple[str, ...]) -> None:
    """Import ``names`` in this Dask worker once, so that the processes it forks start with them
    loaded, as the local pool's forked workers start with what the parent loaded (an engine's
    import, e.g. Pinocchio's, is otherwise paid once per case)."""
    import importlib

    for name in names:
        if name not in _IMPORTED:
            _IMPORTED.add(name)
            try:
                importlib.import_module(name)
            except Exception:  # the case itself will say what is missing
                pass


def _remote_case(payload: bytes, timeout: float, quiet: bool, preload: tuple[str, ...] = ()) -> bytes:
    """Dask task body: run one pickled ``(fn, args)`` in its own process on this worker, as the
    local pool does, and return its pickled ``Outcome``."""
    import multiprocessing as mp
    import warnings

    from harness.io.progress import set_quiet
    from harness.validate.workers import run_cases

    mp.current_process()._config["daemon"] = False  # see the module docstring
    _preload(preload)
    warnings.filterwarnings("ignore", message=r".*use of fork\(\) may lead to deadlocks", category=DeprecationWarning)
    set_quiet(quiet)  # as the local pool's forked workers inherit it
    fn, args = pickle.loads(payload)
    outcome = run_cases([(0, fn, args)], 1, timeout)[0]
    try:
        return pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as err:  # a value that does not travel
        return pickle.dumps(Outcome("error", None, f"result not picklable: {type(err).__name__}: {err}", outcome.wall_s))


# ------------------------------------------------------------------------------------ parent side
@dataclass
class _Submitted:
    key: Hashable
    future: Any
    start: float
    timeout: float


class DaskWorkers:
    """``harness.validate.workers.Workers`` on the Dask scheduler at ``address``: ``start``
    submits a case, ``wait`` returns the cases that ended as ``[(key, Outcome)]``; on leaving the
    context the tasks still running are cancelled."""

    def __init__(self, address: str, jobs: int | None = None):
        import cloudpickle

        self._dumps = cloudpickle.dumps
        self.address = address
        self.client = connect(address)
        self.jobs = jobs
        self.slots = slots(address, jobs)
        self._running: dict[Any, _Submitted] = {}
        self._ended = threading.Event()  # set by each task's done callback

    def __enter__(self) -> "DaskWorkers":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Cancel the tasks still running (their cases get no outcome)."""
        futures = [s.future for s in self._running.values()]
        self._running.clear()
        if futures:
            try:
                self.client.cancel(futures, force=True)
            except Exception:  # a scheduler already gone
                pass

    def __len__(self) -> int:
        return len(self._running)

    def free(self) -> int:
        """How many more cases may start now (workers that joined since count)."""
        if not self._running:
            self.slots = slots(self.address, self.jobs)
        return max(0, self.slots - len(self._running))

    def start(self, key: Hashable, fn: Callable, args: tuple, timeout: float) -> None:
        """Submit ``fn(*args)``, run in its own process on a Dask worker, limited to ``timeout`` s
        from its start there."""
        from harness.io.progress import is_quiet

        name = getattr(fn, "__name__", "case")
        future = self.client.submit(_remote_case, self._dumps((fn, args)), float(timeout), is_quiet(), _loaded_modules(),
                                    key=f"harness-{name}-{uuid.uuid4().hex}", pure=False, retries=0)
        self._running[future.key] = _Submitted(key, future, time.monotonic(), float(timeout))
        future.add_done_callback(lambda _: self._ended.set())

    def _outcome(self, sub: _Submitted) -> Outcome:
        wall = time.monotonic() - sub.start
        status = sub.future.status
        if status == "finished":
            try:
                return pickle.loads(sub.future.result())
            except Exception as err:
                return Outcome("error", message=f"result did not come back: {type(err).__name__}: {err}", wall_s=wall)
        if status == "error":
            err = sub.future.exception()
            if type(err).__name__ == "KilledWorker":
                return Outcome("crashed", message=f"the Dask worker running it died ({_one_line(err)})", wall_s=wall)
            return Outcome("error", message=f"{type(err).__name__}: {_one_line(err)} (on the Dask worker)", wall_s=wall)
        return Outcome("crashed", message=f"its Dask task was {status}", wall_s=wall)

    def wait(self) -> list[tuple[Hashable, Outcome]]:
        """Block until at least one submitted case ends; ``[(key, Outcome)]``, ``[]`` if none runs."""
        while self._running:
            self._ended.clear()  # before looking: a task ending from here on sets it again
            now = time.monotonic()
            deadline = min(s.start + s.timeout + GRACE_S for s in self._running.values())
            if not any(s.future.done() for s in self._running.values()):
                self._ended.wait(max(0.0, deadline - now))
            ended: list[tuple[Hashable, Outcome]] = []
            for fkey, sub in list(self._running.items()):
                if sub.future.done():
                    outcome = self._outcome(sub)
                elif time.monotonic() > sub.start + sub.timeout + GRACE_S:
                    self.client.cancel([sub.future], force=True)
                    outcome = Outcome("timeout", message=f"no result within {sub.timeout:g} s",
                                      wall_s=time.monotonic() - sub.start)
                else:
                    continue
                del self._running[fkey]
                ended.append((sub.key, outcome))
            if ended:
                return ended
        return []


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split())[:300]
