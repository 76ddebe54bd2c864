"""Run a function in its own worker process, with a timeout, so that a crash (even a segfault),
a hang or a blow-up in one engine is recorded as that case's failure and nothing else is lost.

``run_cases(cases, jobs, timeout)`` runs ``(key, fn, args)`` cases at most ``jobs`` at a time
and returns ``{key: Outcome}``. Workers are forked (POSIX) so they start in milliseconds;
where fork is unavailable, spawned.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Hashable

from harness.model.errors import InputError


@dataclass(frozen=True)
class Outcome:
    """How one case ended: ``status`` is ``ok`` (``value`` holds the result), ``input_error``
    (``message`` is the one-line InputError), ``error`` (an exception, ``message`` says which),
    ``crashed`` (the worker died, e.g. a signal) or ``timeout``."""

    status: str
    value: Any = None
    message: str = ""
    wall_s: float = 0.0


def _context():
    methods = mp.get_all_start_methods()
    return mp.get_context("fork" if "fork" in methods else "spawn")


def _worker(conn, fn, args):
    try:
        conn.send(("ok", fn(*args), ""))
    except InputError as err:
        conn.send(("input_error", None, str(err)))
    except BaseException as err:  # anything else is this case's failure
        last = traceback.extract_tb(err.__traceback__)[-1] if err.__traceback__ else None
        where = f" ({os.path.basename(last.filename)}:{last.lineno})" if last else ""
        conn.send(("error", None, f"{type(err).__name__}: {err}{where}"))
    finally:
        conn.close()


def run_cases(cases: list[tuple[Hashable, Callable, tuple]], jobs: int, timeout: float) -> dict[Hashable, Outcome]:
    """Run each ``fn(*args)`` in its own process, ``jobs`` at a time, each limited to ``timeout`` s."""
    ctx = _context()
    pending = list(cases)
    running: dict[Hashable, tuple[Any, Any, float]] = {}
    results: dict[Hashable, Outcome] = {}
    jobs = max(1, jobs)
    while pending or running:
        while pending and len(running) < jobs:
            key, fn, args = pending.pop(0)
            parent, child = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_worker, args=(child, fn, args), daemon=True)
            proc.start()
            child.close()
            running[key] = (proc, parent, time.perf_counter())
        done = []
        for key, (proc, conn, start) in running.items():
            elapsed = time.perf_counter() - start
            if conn.poll():
                try:
                    status, value, message = conn.recv()
                except (EOFError, OSError):
                    proc.join(1.0)
                    results[key] = Outcome("crashed", message=f"worker died (exit code {proc.exitcode})", wall_s=elapsed)
                else:
                    results[key] = Outcome(status, value, message, elapsed)
                proc.join(5.0)
                done.append(key)
            elif not proc.is_alive():
                proc.join()
                results[key] = Outcome("crashed", message=f"worker died (exit code {proc.exitcode})", wall_s=elapsed)
                done.append(key)
            elif elapsed > timeout:
                proc.kill()
                proc.join()
                results[key] = Outcome("timeout", message=f"no result within {timeout:g} s", wall_s=elapsed)
                done.append(key)
        for key in done:
            proc, conn, _ = running.pop(key)
            conn.close()
        if running and not done:
            time.sleep(0.005)
    return results
