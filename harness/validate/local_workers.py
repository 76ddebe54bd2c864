"""Run a function in its own worker process on this machine, with a timeout, so that a crash
(even a segfault), a hang or a blow-up in one engine is recorded as that case's failure and
nothing else is lost: the local pool behind ``harness.validate.workers.run_cases`` (callers import
from there, which also dispatches to a Dask cluster).

``Workers(jobs)`` starts ``(key, fn, args)`` cases at most ``effective_jobs(jobs)`` at a time and
returns each one's ``Outcome`` as it ends; ``stream_case`` runs a generator in one worker and
yields an ``Outcome`` per item. Workers are forked (POSIX) so they start in milliseconds; where
fork is unavailable, spawned. Each case gets a fresh process: nothing one case does (a segfault,
a leaked global, an exhausted heap) reaches another.

Hygiene under faults:

* Workers die with their parent. On Linux each worker asks the kernel for ``SIGKILL`` when its
  parent dies (``prctl(PR_SET_PDEATHSIG)``), so even a ``SIGKILL`` of the parent (a CI timeout)
  leaves no orphan. Independently, while cases run, the parent kills its workers on ``SIGTERM``
  (then dies of that ``SIGTERM`` as it would have) and on any exception or normal return.
* Results of any size come back: the parent waits on all result pipes and process sentinels
  at once (``multiprocessing.connection.wait``) and reads a result as soon as it starts to
  arrive, so a worker never blocks for long on a full pipe.
* No spurious timeouts under load: at most ``usable_cpus()`` cases run at once (the CPUs this
  process may use: its affinity mask and its cgroup CPU quota, ``harness.io.cpus``), however
  large ``jobs`` is, and each case's ``timeout`` (wall-clock seconds) counts from that case's own
  start.
"""

from __future__ import annotations

import ctypes
import functools
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import signal
import sys
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Hashable

from harness.io.cpus import usable_cpus
from harness.model.errors import InputError

_PR_SET_PDEATHSIG = 1


@dataclass(frozen=True)
class Outcome:
    """How one case ended: ``status`` is ``ok`` (``value`` holds the result), ``input_error``
    (``message`` is the one-line InputError), ``error`` (an exception, ``message`` says which),
    ``crashed`` (the worker died, e.g. a signal) or ``timeout``. ``wall_s``: wall-clock seconds
    from the case's start to its end."""

    status: str
    value: Any = None
    message: str = ""
    wall_s: float = 0.0


# ------------------------------------------------------------------------------------ CPUs
def effective_jobs(jobs: int | None) -> int:
    """The number of cases run at once for a requested ``jobs``: ``None`` or ``0`` means all
    usable CPUs; anything larger than ``usable_cpus()`` is clamped to it (more processes than
    CPUs only slows every case and makes wall-clock timeouts fire spuriously); at least 1."""
    cpus = usable_cpus()
    return cpus if not jobs or jobs < 0 else max(1, min(int(jobs), cpus))


# ------------------------------------------------------------------------------------ worker side
def _context():
    methods = mp.get_all_start_methods()
    return mp.get_context("fork" if "fork" in methods else "spawn")


@functools.lru_cache(maxsize=None)
def _prctl():
    """libc's ``prctl`` on Linux, else None (looked up once, in the parent, before forking).
    Note: the kernel sends the death signal when the *thread* that forked the worker ends; the
    parent's calls block until their workers end, so that thread outlives them."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def _die_with_parent() -> None:
    """In a worker: SIGKILL when the parent dies (Linux), default SIGTERM/SIGINT handling (a
    forked worker inherits the parent's Python handlers), and exit at once if the parent is
    already gone."""
    for sig in (signal.SIGTERM,):
        try:
            signal.signal(sig, signal.SIG_DFL)
        except (ValueError, OSError):
            pass
    prctl = _prctl()
    if prctl is not None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    parent = mp.parent_process()
    if parent is not None and parent.pid is not None and os.getppid() != parent.pid:
        os._exit(1)  # the parent died before prctl took effect


def _worker(conn, fn, args):
    """Body of a worker process: run ``fn(*args)`` and send ``(status, value, message)``.

    The worker's BLAS runs one thread (``threadpoolctl``): workers run side by side, one per
    CPU, and an OpenBLAS that starts a thread per CPU for each small product oversubscribes them.
    Measured on 2 cores: three concurrent in-house runs of ``bricard`` (1 s at 1 ms) took 13-15 s
    each with OpenBLAS's default threads, 0.8-1.1 s with one; a run alone takes 0.65 s either
    way. NumPy is loaded before the fork, so ``OPENBLAS_NUM_THREADS`` would come too late."""
    _start_worker()
    try:
        conn.send(("ok", fn(*args), ""))
    except InputError as err:
        conn.send(("input_error", None, str(err)))
    except BaseException as err:  # anything else is this case's failure
        conn.send(("error", None, _failure(err)))
    finally:
        conn.close()


def _start_worker() -> None:
    """What every worker process does first: die with its parent (``_die_with_parent``) and run
    its BLAS on one thread (``_worker``'s docstring says why)."""
    _die_with_parent()
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")


def _failure(err: BaseException) -> str:
    """A case's exception in one line: its type, its text and where it was raised."""
    last = traceback.extract_tb(err.__traceback__)[-1] if err.__traceback__ else None
    where = f" ({os.path.basename(last.filename)}:{last.lineno})" if last else ""
    return f"{type(err).__name__}: {err}{where}"


# ------------------------------------------------------------------------------------ parent side
# Worker processes started by this process and not yet reaped. Changed only by the thread that
# runs the cases, read by the SIGTERM handler (which runs in the main thread between bytecodes,
# so it sees the set whole; a lock here could deadlock against the interrupted thread).
_LIVE: set = set()


def _kill_live() -> None:
    for proc in list(_LIVE):
        try:
            proc.kill()
        except (OSError, ValueError, AttributeError):
            pass


def _died(proc) -> str:
    code = proc.exitcode
    if code is not None and code < 0:
        try:
            return f"worker died (exit code {code}, {signal.Signals(-code).name})"
        except ValueError:
            pass
    return f"worker died (exit code {code})"


@dataclass
class _Running:
    key: Hashable
    proc: Any
    conn: Any
    start: float
    timeout: float


class Workers:
    """Worker processes for isolated cases, at most ``slots`` at a time.

    Use as a context manager: on leaving it (normally or by an exception) every worker still
    running is killed; inside it, a ``SIGTERM`` to this process kills the workers and then
    terminates the process as the signal would have (installed only from the main thread, and
    only where ``SIGTERM`` has its default action or a Python handler, which is then chained).

    ``start(key, fn, args, timeout)`` starts a case (``timeout`` in wall-clock seconds from now);
    ``wait()`` blocks until at least one running case ends and returns ``[(key, Outcome)]``.
    ``slots = effective_jobs(jobs)``.
    """

    def __init__(self, jobs: int | None = None):
        self.slots = effective_jobs(jobs)
        self._ctx = _context()
        _prctl()  # look it up before forking, once
        self._running: dict[int, _Running] = {}
        self._serial = 0
        self._previous: Any = None
        self._installed = False

    # -- context
    def __enter__(self) -> "Workers":
        if threading.current_thread() is threading.main_thread():
            previous = signal.getsignal(signal.SIGTERM)
            if previous is signal.SIG_DFL or callable(previous):
                self._previous = previous
                signal.signal(signal.SIGTERM, self._on_sigterm)
                self._installed = True
        return self

    def __exit__(self, *exc) -> None:
        try:
            self.close()
        finally:
            if self._installed:
                signal.signal(signal.SIGTERM, self._previous)
                self._installed = False

    def _on_sigterm(self, signum, frame) -> None:
        _kill_live()
        previous, self._installed = self._previous, False
        signal.signal(signal.SIGTERM, previous)
        if callable(previous):
            previous(signum, frame)
        else:
            os.kill(os.getpid(), signum)  # default action: die of SIGTERM, as without us

    def close(self) -> None:
        """Kill and reap every worker still running (their cases get no outcome)."""
        for run in list(self._running.values()):
            self._finish(run, kill=True)
        self._running.clear()

    # -- cases
    def __len__(self) -> int:
        return len(self._running)

    def free(self) -> int:
        """How many more cases may start now."""
        return max(0, self.slots - len(self._running))

    def start(self, key: Hashable, fn: Callable, args: tuple, timeout: float) -> None:
        """Start ``fn(*args)`` in a new worker process, limited to ``timeout`` s from now."""
        parent, child = self._ctx.Pipe(duplex=False)
        proc = self._ctx.Process(target=_worker, args=(child, fn, args), daemon=True)
        proc.start()
        _LIVE.add(proc)
        child.close()
        self._serial += 1
        self._running[self._serial] = _Running(key, proc, parent, time.monotonic(), float(timeout))

    def _finish(self, run: _Running, kill: bool = False) -> None:
        if kill and run.proc.is_alive():
            run.proc.kill()
        run.proc.join(5.0)
        if run.proc.is_alive():  # sent its result but does not exit
            run.proc.kill()
            run.proc.join()
        _LIVE.discard(run.proc)
        run.conn.close()

    def wait(self) -> list[tuple[Hashable, Outcome]]:
        """Block until at least one running case ends (result, crash or timeout); return the
        cases that ended as ``[(key, Outcome)]``. Returns ``[]`` at once if none is running."""
        while self._running:
            now = time.monotonic()
            deadline = min(r.start + r.timeout for r in self._running.values())
            handles = [r.conn for r in self._running.values()] + [r.proc.sentinel for r in self._running.values()]
            ready = set(mpc.wait(handles, timeout=max(0.0, deadline - now)))
            ended: list[tuple[Hashable, Outcome]] = []
            for serial, run in list(self._running.items()):
                outcome = None
                if run.conn in ready or run.proc.sentinel in ready:
                    # Read the result first: a worker may have exited with its whole result
                    # still in the pipe, and a large result is read while the worker writes it.
                    if run.conn.poll():
                        try:
                            status, value, message = run.conn.recv()
                        except (EOFError, OSError):
                            run.proc.join(1.0)
                            outcome = Outcome("crashed", message=_died(run.proc), wall_s=time.monotonic() - run.start)
                        else:
                            outcome = Outcome(status, value, message, time.monotonic() - run.start)
                    else:
                        run.proc.join(1.0)
                        outcome = Outcome("crashed", message=_died(run.proc), wall_s=time.monotonic() - run.start)
                    self._finish(run)
                elif time.monotonic() - run.start > run.timeout:
                    self._finish(run, kill=True)
                    outcome = Outcome("timeout", message=f"no result within {run.timeout:g} s",
                                      wall_s=time.monotonic() - run.start)
                if outcome is not None:
                    del self._running[serial]
                    ended.append((run.key, outcome))
            if ended:
                return ended
        return []


def in_worker() -> bool:
    """Whether this process is itself a worker (a daemonic process, which may start none of its
    own): cases then run in this process, under the enclosing worker's budget (a zoo model's
    ``check``, a scene of ``workprecision`` on a Dask worker)."""
    return bool(mp.current_process().daemon)


def in_process(fn: Callable, args: tuple) -> Outcome:
    """``fn(*args)`` in this process, as an ``Outcome`` (``harness.validate.workers.run_cases``
    inside a worker)."""
    start = time.monotonic()
    try:
        outcome = Outcome("ok", fn(*args), "", time.monotonic() - start)
    except InputError as err:
        outcome = Outcome("input_error", None, str(err), time.monotonic() - start)
    except Exception as err:  # noqa: BLE001 - the case's failure, as a worker would report it
        outcome = Outcome("error", None, _failure(err), time.monotonic() - start)
    return outcome


def _stream_worker(conn, fn, args):
    """Body of a streaming worker: send ``("item", x)`` for each item ``fn(*args)`` yields, then
    ``("end", None)``; an exception is ``("error", message)`` (``_worker``'s isolation)."""
    _start_worker()
    try:
        for item in fn(*args):
            conn.send(("item", item))
        conn.send(("end", None))
    except InputError as err:
        conn.send(("input_error", str(err)))
    except BaseException as err:  # anything else is this stream's failure
        conn.send(("error", _failure(err)))
    finally:
        conn.close()


def stream_case(fn: Callable, args: tuple, item_timeout: float):
    """Run the generator ``fn(*args)`` in one worker process and yield ``Outcome``s as it goes:
    ``ok`` with each item it yields, as soon as it yields it, each within ``item_timeout``
    wall-clock seconds of the one before (or of the start); then nothing more. A worker that is
    silent for longer is killed and the stream ends with ``timeout``; one that dies or raises
    ends it with ``crashed`` or ``error`` (``input_error`` for bad input). One process for a whole
    sequence of runs, each under its own budget: a curve of points, where forking a worker per
    point would cost more than the points (a hang still ends in ``item_timeout``). The worker dies
    with this process (``_die_with_parent``) and is killed if the caller stops iterating. Inside a
    worker (``in_worker``) the generator runs in this process, under the enclosing budget."""
    if in_worker():  # in a worker already: in this process, under the enclosing worker's budget
        last = time.monotonic()
        try:
            for item in fn(*args):
                yield Outcome("ok", item, "", time.monotonic() - last)
                last = time.monotonic()
        except InputError as err:
            yield Outcome("input_error", None, str(err), time.monotonic() - last)
        except Exception as err:  # noqa: BLE001 - the stream's failure, as a worker would report it
            yield Outcome("error", None, _failure(err), time.monotonic() - last)
        return
    ctx = _context()
    _prctl()
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_stream_worker, args=(child, fn, args), daemon=True)
    proc.start()
    _LIVE.add(proc)
    child.close()
    last = time.monotonic()
    try:
        while True:
            ready = mpc.wait([parent, proc.sentinel], timeout=max(0.0, last + item_timeout - time.monotonic()))
            if not ready:
                yield Outcome("timeout", message=f"no result within {item_timeout:g} s",
                              wall_s=time.monotonic() - last)
                return
            if parent.poll():
                try:
                    kind, value = parent.recv()
                except (EOFError, OSError):
                    proc.join(1.0)
                    yield Outcome("crashed", message=_died(proc), wall_s=time.monotonic() - last)
                    return
                now = time.monotonic()
                if kind == "item":
                    yield Outcome("ok", value, "", now - last)
                    last = time.monotonic()
                    continue
                if kind != "end":
                    yield Outcome(kind, None, value, now - last)
                return
            proc.join(1.0)
            yield Outcome("crashed", message=_died(proc), wall_s=time.monotonic() - last)
            return
    finally:
        if proc.is_alive():
            proc.kill()
        proc.join(5.0)
        _LIVE.discard(proc)
        parent.close()
