"""The executor of every sweep: run each case in its own process with a timeout, on this
machine or on a Dask cluster, so that a crash (even a segfault), a hang or a blow-up in one
engine is recorded as that case's failure and nothing else is lost.

``run_cases(cases, jobs, timeout)`` runs ``(key, fn, args)`` cases at most ``jobs`` at a time
and returns ``{key: Outcome}`` in the cases' order. ``open_workers(jobs, dask)`` gives the
executor for a caller that decides what to start next as cases end (the stress study): the local
pool ``Workers`` (``harness.validate.local_workers``: forked workers, their hygiene under faults),
or with ``dask="tcp://host:port"`` its Dask twin (``harness.validate.dask_workers.DaskWorkers``:
each case in its own process on a Dask worker, the same outcomes), which is how every sweep's
``--dask`` reaches the cases. The local pool's ``Outcome``, ``Workers``, ``effective_jobs``,
``in_worker`` and ``stream_case`` are imported here too, so that callers import from this one
module.
"""

from __future__ import annotations

import collections
from typing import Callable, Hashable

from harness.validate.dask_workers import DaskWorkers
from harness.validate.local_workers import Outcome, Workers, effective_jobs, in_process, in_worker, stream_case

__all__ = ["Outcome", "Workers", "effective_jobs", "in_worker", "open_workers", "run_cases", "stream_case"]


def open_workers(jobs: int | None = None, dask: str | None = None):
    """The executor of a sweep: the local pool ``Workers(jobs)``, or with ``dask`` (a scheduler
    address, ``tcp://host:port``) ``harness.validate.dask_workers.DaskWorkers(dask, jobs)``, which
    has the same interface and isolation. InputError when that scheduler cannot be reached."""
    if dask:
        return DaskWorkers(dask, jobs)
    return Workers(jobs)


def run_cases(cases: list[tuple[Hashable, Callable, tuple]], jobs: int | None, timeout: float | Callable[[Hashable], float],
              on_done: Callable[[Hashable, Outcome], None] | None = None,
              dask: str | None = None,
              follow: Callable[[Hashable, Outcome], list] | None = None) -> dict[Hashable, Outcome]:
    """Run each ``fn(*args)`` in its own process, at most ``effective_jobs(jobs)`` at a time,
    each limited to ``timeout`` wall-clock seconds from its own start (or ``timeout(key)``, per
    case). Returns ``{key: Outcome}``
    for every case, in the order of ``cases``; ``on_done(key, outcome)``, if given, is called in
    this process as each case ends (e.g. to tick a progress bar). Workers still running when this
    returns or raises (or when the process gets SIGTERM) are killed; on Linux they also die if
    this process is killed outright.

    ``dask``: the address of a ``dask.distributed`` scheduler (``tcp://host:port``): the cases run
    there instead, each in its own process on a Dask worker, at most as many at once as the
    cluster has worker threads (``jobs`` caps it), with the same outcomes
    (``harness.validate.dask_workers``). ``follow(key, outcome)``, if given, returns further
    cases to run once that case has ended (cases that need its result: a scene's engine runs after
    its reference run), queued behind the others and returned with them. Inside a worker (``in_worker``: a daemonic process may
    start none of its own) the cases run in this process, one after the other, under the
    enclosing worker's budget."""
    pending = collections.deque(cases)
    order = [key for key, _, _ in cases]
    results: dict[Hashable, Outcome] = {}

    def ended(key, outcome) -> None:
        results[key] = outcome
        if on_done is not None:
            on_done(key, outcome)
        more = follow(key, outcome) if follow is not None else ()
        pending.extend(more)
        order.extend(k for k, _, _ in more)

    if dask is None and in_worker():
        while pending:
            key, fn, args = pending.popleft()
            ended(key, in_process(fn, args))
        return {key: results[key] for key in order}
    with open_workers(jobs, dask) as workers:
        while pending or len(workers):
            while pending and workers.free():
                key, fn, args = pending.popleft()
                workers.start(key, fn, args, timeout(key) if callable(timeout) else timeout)
            for key, outcome in workers.wait():
                ended(key, outcome)
    return {key: results[key] for key in order}
