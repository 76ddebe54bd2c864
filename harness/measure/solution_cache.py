"""The reference modules' expensive solutions, kept in memory and handed from one process to another.

A reference module (``references/<scene>.py``) that integrates its system to judge runs (the
Andrews squeezer's DAE, the four-bar's equation of motion: seconds each) keeps every solution
with ``@solution_cache()`` instead of ``functools.lru_cache``: the same memo (keyed by the
call's arguments: the parameters, the sampled times, the tolerances; bounded per function,
oldest out first), whose entries can also leave the process that computed them.

``recording()`` collects the entries computed inside a ``with`` block, and ``adopt(entries)``
puts them in another process's memo. Validation's reference run judges itself against the
closed form at the very times every engine's run is saved at, so its worker returns what it
computed and each engine run's worker adopts it, instead of integrating the system again
(``harness.validate.run``). Entries are plain picklable values (NumPy arrays, dataclasses of
the reference module), so they cross a fork, a pipe and a Dask worker alike. A value from the
memo is shared: callers must not modify it.
"""

from __future__ import annotations

import collections
import contextlib
import functools
from typing import Any, Callable, Hashable, Iterator

_MEMO: dict[str, collections.OrderedDict] = {}  # function's module.qualname -> {args: value}
_MAXSIZE: dict[str, int] = {}  # function's module.qualname -> its maxsize
_RECORDERS: list[dict] = []  # the open ``recording()`` blocks, innermost last
_DEFAULT_MAXSIZE = 16


def solution_cache(maxsize: int = _DEFAULT_MAXSIZE) -> Callable[[Callable], Callable]:
    """Decorator: memoise a function of hashable positional arguments, keeping at most
    ``maxsize`` results (the least recently used goes first), like ``functools.lru_cache``,
    with entries that ``recording`` collects and ``adopt`` installs. The wrapper's
    ``cache_clear()`` empties its memo."""

    def decorate(fn: Callable) -> Callable:
        name = f"{fn.__module__}.{fn.__qualname__}"
        memo = _MEMO.setdefault(name, collections.OrderedDict())
        _MAXSIZE[name] = maxsize

        @functools.wraps(fn)
        def cached(*args: Hashable) -> Any:
            try:
                value = memo[args]
            except KeyError:
                value = fn(*args)
                _store(name, args, value)
                for entries in _RECORDERS:
                    entries[(name, args)] = value
                return value
            memo.move_to_end(args)
            return value

        cached.cache_clear = memo.clear  # type: ignore[attr-defined]
        return cached

    return decorate


def _store(name: str, args: tuple, value: Any) -> None:
    memo = _MEMO.setdefault(name, collections.OrderedDict())
    memo[args] = value
    memo.move_to_end(args)
    while len(memo) > _MAXSIZE.get(name, _DEFAULT_MAXSIZE):
        memo.popitem(last=False)


@contextlib.contextmanager
def recording() -> Iterator[dict]:
    """``with recording() as entries:`` fills ``entries`` with every solution computed (not
    found in the memo) inside the block: ``{(function name, args): value}``, for ``adopt``."""
    entries: dict = {}
    _RECORDERS.append(entries)
    try:
        yield entries
    finally:
        del _RECORDERS[next(i for i, e in enumerate(_RECORDERS) if e is entries)]  # by identity


def adopt(entries: dict | None) -> None:
    """Put ``entries`` (from ``recording`` in this or another process) in this process's memo,
    so that the decorated functions return them without computing; None adopts nothing. An
    entry of a function this process has not imported is kept until it is."""
    for (name, args), value in (entries or {}).items():
        _store(name, args, value)
