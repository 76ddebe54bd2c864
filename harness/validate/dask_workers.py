"""Isolated cases on a Dask cluster: the executor behind every sweep's ``--dask ADDRESS``.

``DaskWorkers(address, jobs)`` has the interface of the local pool,
``harness.validate.local_workers.Workers`` (``start``, ``wait``, ``free``, ``len``, a context
manager), so ``harness.validate.workers.run_cases`` and the stress study's work-conserving loop
run on a ``dask.distributed`` scheduler when given its address and on the local pool otherwise
(``workers.open_workers``). Nothing else in the harness imports Dask.

Each case is one Dask task, ``_remote_case``, which runs the case on the Dask worker through the
very local pool (``local_workers.Workers`` with one slot): the worker forks a fresh process for it,
limits its BLAS to one thread and enforces its timeout from the case's own start. So the isolation
contract and the ``Outcome`` are those of a local run: a case that raises is ``error``, one
whose process dies (a segfault, ``os._exit``) is ``crashed`` with the same message, one past its
timeout is ``timeout``; the Dask worker itself survives all three and takes the next case. Only
a Dask worker that dies under a case (killed from outside, out of memory) reaches Dask, which
resubmits the task to another worker (up to ``distributed.scheduler.allowed-failures`` times, the
scheduler's setting, then that case is ``crashed``: "Dask worker lost: ...").

Nothing here can hang on a lost cluster. While cases wait, this side looks at the cluster every
``POLL_S`` s: a lost scheduler (the client's connection closed, which cancels every task) ends
every waiting case at once, ``crashed`` with "Dask scheduler lost"; a cluster left without any
worker for ``NO_WORKER_S`` s (a nanny restarts its worker sooner) ends them ``crashed`` with
"Dask worker lost". Waiting has one overall deadline: when no case has ended (nor started, nor
the cluster's workers changed) for the longest waiting case's timeout plus ``GRACE_S`` s, every
waiting case ends ``timeout`` together. After any of the three the cluster counts as lost: the
cases started later end at once with the same reason, not one timeout after another; leaving
the context prints one line on stderr naming the cause (once per process and address: a later
executor on that address, a command's next batch of cases, fails its cases at once, without
asking the cluster), and the command's own report and exit code (a failed run) follow. distributed's own loggers are silenced
while a client is open (its tracebacks of these expected failures are not ours to print; our
messages do not go through them).

A Dask worker process is daemonic (``distributed.worker.daemon``) and multiprocessing refuses
children to daemonic processes; ``_remote_case`` lifts that flag in the worker process. The case
processes die with it anyway (``PR_SET_PDEATHSIG``, ``local_workers._die_with_parent``).

At most ``slots`` cases are submitted at once: the cluster's worker threads (``jobs``, when given,
caps it), so a case starts as it is submitted. Cases and results travel pickled
(``cloudpickle``); a Dask worker first imports the harness modules this process has loaded
(``_preload``, once each), as a forked local worker inherits them. So a worker needs the harness
importable: the same environment on every worker, and the scene files at the same paths for a
cluster of several machines.

``connect(address)`` checks a Dask scheduler answers there (``CONNECT_TIMEOUT`` s for the
connection and Dask's handshake both: a server that accepts but is not Dask, e.g. an HTTP server,
fails it too) and has a worker, and raises ``InputError`` (exit 2, one line "cannot reach a Dask
scheduler at ADDRESS: ...") otherwise; it keeps one client per address for the
process, closed at exit or by ``close_clients()``.
"""

from __future__ import annotations

import atexit
import logging
import pickle
import sys
import threading
import time
import uuid
from dataclasses import dataclass
from typing import Any, Callable, Hashable

from harness.model.errors import InputError
from harness.validate.local_workers import Outcome, Workers

CONNECT_TIMEOUT = 5.0  # s to reach the scheduler and end Dask's handshake, and again for a first worker to be there
NO_WORKER_S = 5.0  # s the cluster may have no worker while cases wait (a nanny restarts one sooner)
GRACE_S = 60.0  # s past the longest waiting case's timeout without any result before waiting ends
POLL_S = 0.5  # s between looks at the cluster (its scheduler, its workers) while cases wait

_CLIENTS: dict[str, Any] = {}
_LOCK = threading.Lock()
_LOG_LEVELS: dict[str, int] = {}  # distributed's loggers' levels before ``connect`` silenced them
_LOST: dict[str, tuple[str, str]] = {}  # address -> (why, status): a cluster lost in this process stays lost
_TOLD: set[str] = set()  # the addresses whose loss was said on stderr


# ------------------------------------------------------------------------------------ client
def _why(err: BaseException) -> str:
    if isinstance(err, TimeoutError) and not str(err):  # asyncio.wait_for's: the handshake never came
        return (f"no Dask handshake within {CONNECT_TIMEOUT:g} s (something that is not a Dask scheduler "
                "listens there?)")
    if isinstance(err, (OSError, ValueError, TimeoutError)):
        text = " ".join(str(err).split())
        return text[:200] or type(err).__name__
    return f"what answers there does not speak Dask's protocol ({type(err).__name__} reading its answer)"


def _unreachable(address: str, err: BaseException) -> InputError:
    return InputError(f"cannot reach a Dask scheduler at {address}: {_why(err)}")


def _silence_distributed() -> None:
    """Silence distributed's loggers in this process (the levels its logging config set,
    ``distributed.config.initialize_logging``), once, until ``close_clients``: the failures it
    logs here with tracebacks (a lost scheduler, a failed reconnection) are expected and reported
    by this module in one line; the harness's own messages do not go through them."""
    if _LOG_LEVELS:
        return
    names = ["distributed"] + [name for name, logger in list(logging.root.manager.loggerDict.items())
                               if name.startswith("distributed.") and isinstance(logger, logging.Logger)
                               and logger.level != logging.NOTSET]
    for name in names:
        logger = logging.getLogger(name)
        _LOG_LEVELS[name] = logger.level
        logger.setLevel(logging.CRITICAL + 1)


def _restore_logging() -> None:
    for name, level in _LOG_LEVELS.items():
        logging.getLogger(name).setLevel(level)
    _LOG_LEVELS.clear()


def _restore_logging_unless(clients: dict) -> None:
    if not clients:  # no client left open to speak for
        _restore_logging()


def connect(address: str):
    """The ``distributed.Client`` of the scheduler at ``address`` (``tcp://host:port``), made
    once per process. InputError, one line, when no Dask scheduler answers there within
    ``CONNECT_TIMEOUT`` s (the connection and Dask's handshake) or it has no worker within as
    long."""
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
            # distributed's connect bounds the connection, not the handshake after it (a server
            # that accepts and says nothing would hold it for ever): the whole probe is bounded
            comm = await asyncio.wait_for(comm_connect(address, timeout=CONNECT_TIMEOUT), CONNECT_TIMEOUT)
            await comm.close()

        _silence_distributed()
        try:
            asyncio.run(probe())
        except Exception as err:
            _restore_logging_unless(_CLIENTS)
            raise _unreachable(address, err) from None
        try:
            client = Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except Exception as err:
            _restore_logging_unless(_CLIENTS)
            raise _unreachable(address, err) from None
        try:
            client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
        except Exception:
            client.close()
            _restore_logging_unless(_CLIENTS)
            raise InputError(f"--dask {address}: the Dask scheduler has no worker (start one with "
                             f"`dask worker {address}`)") from None
        if not _CLIENTS:
            atexit.register(close_clients)
        _CLIENTS[address] = client
        return client


def close_clients() -> None:
    """Close every client ``connect`` made (the clusters keep running) and give distributed's
    loggers their levels back."""
    with _LOCK:
        for client in _CLIENTS.values():
            try:
                client.close(timeout=CONNECT_TIMEOUT)
            except Exception:  # a scheduler already gone
                pass
        _CLIENTS.clear()
        _LOST.clear()
        _TOLD.clear()
        _restore_logging()


def cluster_threads(address: str) -> int:
    """Worker threads of the cluster at ``address`` now (at least 1)."""
    return max(1, sum(connect(address).nthreads().values()))


def slots(address: str, jobs: int | None) -> int:
    """Cases run at once on the cluster: its worker threads, at most ``jobs`` when given (> 0);
    for a cluster lost during this run, ``jobs`` or 1, without asking it."""
    if address in _LOST:
        return max(1, int(jobs)) if jobs and jobs > 0 else 1
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

    mp.current_process()._config["daemon"] = False  # see the module docstring
    _preload(preload)
    warnings.filterwarnings("ignore", message=r".*use of fork\(\) may lead to deadlocks", category=DeprecationWarning)
    set_quiet(quiet)  # as the local pool's forked workers inherit it
    fn, args = pickle.loads(payload)
    with Workers(1) as pool:  # one case in a fresh process, its timeout from its start
        pool.start(0, fn, args, timeout)
        ((_, outcome),) = pool.wait()
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
    """``harness.validate.local_workers.Workers`` on the Dask scheduler at ``address``: ``start``
    submits a case, ``wait`` returns the cases that ended as ``[(key, Outcome)]``; on leaving the
    context the tasks still running are cancelled. ``lost``: why the cluster can run no more
    cases (None while it can); the cases started from then on end at once with that reason, in
    this executor and in those made later in this process for the same address (a command's
    next batch of cases)."""

    def __init__(self, address: str, jobs: int | None = None):
        import cloudpickle

        self._dumps = cloudpickle.dumps
        self.address = address
        self.lost: str | None = None
        self._lost_as = "crashed"  # the status of the cases the loss ends
        if address in _LOST:
            self.lost, self._lost_as = _LOST[address]
            self.client = None
        else:
            self.client = connect(address)
        self.jobs = jobs
        self.slots = slots(address, jobs)
        self._running: dict[Any, _Submitted] = {}
        self._ended = threading.Event()  # set by each task's done callback
        self._failed: list[tuple[Hashable, Outcome]] = []  # cases ended by the loss, not yet returned by wait
        self._n_lost = 0  # cases the loss ended
        self._event = time.monotonic()  # the last case started or ended, or change of the cluster's workers
        self._workers: frozenset | None = None  # the cluster's worker addresses at the last look
        self._no_worker_since: float | None = None

    def __enter__(self) -> "DaskWorkers":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Cancel the tasks still running (their cases get no outcome); after a loss, say so in
        one line on stderr."""
        futures = [s.future for s in self._running.values()]
        self._running.clear()
        if futures and self.lost is None:
            try:
                self.client.cancel(futures, force=True)
            except Exception:  # a scheduler already gone
                pass
        if self.lost is not None and self._n_lost and self.address not in _TOLD:
            _TOLD.add(self.address)
            print(f"harness: {self.lost}: the cases not finished are recorded as failed", file=sys.stderr, flush=True)

    def __len__(self) -> int:
        return len(self._running) + len(self._failed)

    def free(self) -> int:
        """How many more cases may start now (workers that joined since count; after a loss,
        any number: each ends at once)."""
        if self.lost is not None:
            return max(1, self.slots)
        if not self._running:
            workers = self._look()
            if workers:
                threads = sum(workers.values())
                self.slots = threads if not self.jobs or self.jobs < 0 else max(1, min(int(self.jobs), threads))
        return max(0, self.slots - len(self._running))

    def start(self, key: Hashable, fn: Callable, args: tuple, timeout: float) -> None:
        """Submit ``fn(*args)``, run in its own process on a Dask worker, limited to ``timeout`` s
        from its start there."""
        from harness.io.progress import is_quiet

        if self.lost is None:
            name = getattr(fn, "__name__", "case")
            try:
                future = self.client.submit(_remote_case, self._dumps((fn, args)), float(timeout), is_quiet(),
                                            _loaded_modules(), key=f"harness-{name}-{uuid.uuid4().hex}", pure=False,
                                            retries=0)
            except Exception:
                if self.client.status == "running":
                    raise
                self._lose(f"Dask scheduler lost (the connection to {self.address} closed)")
            else:
                self._event = time.monotonic()
                self._running[future.key] = _Submitted(key, future, self._event, float(timeout))
                future.add_done_callback(lambda _: self._ended.set())
                return
        self._n_lost += 1
        self._failed.append((key, Outcome(self._lost_as, message=self.lost, wall_s=0.0)))

    def _lose(self, why: str, status: str = "crashed") -> None:
        """The cluster can run no more cases: ``why`` is their reason from now on, ``status`` their end."""
        if self.lost is None:
            self.lost, self._lost_as = why, status
            _LOST[self.address] = (why, status)

    def _look(self) -> dict | None:
        """The cluster's workers now, ``{address: threads}``; None when the scheduler does not
        answer within ``CONNECT_TIMEOUT`` s. Notes a lost scheduler and a change of workers."""
        if self.client.status != "running":  # the connection closed: distributed cancelled every task
            self._lose(f"Dask scheduler lost (the connection to {self.address} closed)")
            return None
        try:
            workers = self.client.nthreads(callback_timeout=CONNECT_TIMEOUT)
        except Exception:
            if self.client.status != "running":
                self._lose(f"Dask scheduler lost (the connection to {self.address} closed)")
            return None
        now = time.monotonic()
        if frozenset(workers) != self._workers:
            self._workers = frozenset(workers)
            self._event = now  # a lost worker's tasks start again elsewhere (Dask resubmits them)
        self._no_worker_since = None if workers else (self._no_worker_since or now)
        return workers

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
            if type(err).__name__ in ("KilledWorker", "NoValidWorkerError"):
                return Outcome("crashed", message=f"Dask worker lost: {_one_line(err)}", wall_s=wall)
            return Outcome("error", message=f"{type(err).__name__}: {_one_line(err)} (on the Dask worker)", wall_s=wall)
        if status == "cancelled" and self.client.status != "running":  # distributed cancels all on a lost connection
            self._lose(f"Dask scheduler lost (the connection to {self.address} closed)")
        if self.lost is not None:
            self._n_lost += 1
            return Outcome(self._lost_as, message=self.lost, wall_s=wall)
        return Outcome("crashed", message=f"its Dask task was {status}", wall_s=wall)

    def _end_all(self) -> list[tuple[Hashable, Outcome]]:
        """After a loss: every waiting case ends with its reason; their tasks are cancelled."""
        now = time.monotonic()
        ended = []
        for sub in self._running.values():
            if sub.future.done():
                ended.append((sub.key, self._outcome(sub)))
            else:
                self._n_lost += 1
                ended.append((sub.key, Outcome(self._lost_as, message=self.lost, wall_s=now - sub.start)))
        futures = [s.future for s in self._running.values() if not s.future.done()]
        self._running.clear()
        if futures and self.client.status == "running":
            try:
                self.client.cancel(futures, force=True)
            except Exception:  # a scheduler already gone
                pass
        return ended

    def wait(self) -> list[tuple[Hashable, Outcome]]:
        """Block until at least one submitted case ends; ``[(key, Outcome)]``, ``[]`` if none runs.
        Bounded: a lost scheduler, no worker for ``NO_WORKER_S`` s or no progress for the longest
        waiting timeout plus ``GRACE_S`` s ends every waiting case at once."""
        if self._failed:
            ended, self._failed = self._failed, []
            return ended
        while self._running:
            self._ended.clear()  # before looking: a task ending from here on sets it again
            if not any(s.future.done() for s in self._running.values()):
                self._ended.wait(POLL_S)
            ended: list[tuple[Hashable, Outcome]] = []
            for fkey, sub in list(self._running.items()):
                if sub.future.done():
                    del self._running[fkey]
                    ended.append((sub.key, self._outcome(sub)))
            if ended:
                self._event = time.monotonic()
                return ended + self._end_all() if self.lost is not None else ended
            self._look()
            now = time.monotonic()
            if self.lost is None and self._no_worker_since is not None and now - self._no_worker_since > NO_WORKER_S:
                self._lose(f"Dask worker lost (no worker left on the scheduler at {self.address} "
                           f"for {NO_WORKER_S:g} s)")
            if self.lost is not None:
                return self._end_all()
            limit = max(s.timeout for s in self._running.values()) + GRACE_S
            if now - self._event > limit:
                self._lose(f"no result from the Dask cluster at {self.address} for {limit:g} s", "timeout")
                return self._end_all()
        return []


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split())[:300]
