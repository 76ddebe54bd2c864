"""The solutions' memo: computed once, bounded, recorded and adopted across processes."""

from __future__ import annotations

import multiprocessing as mp
import pickle

import numpy as np

from harness.measure import solution_cache

CALLS: list[tuple] = []


@solution_cache.solution_cache(maxsize=2)
def _square(x: float, n: int) -> np.ndarray:
    CALLS.append((x, n))
    return np.full(n, x * x)


def setup_function():
    _square.cache_clear()
    CALLS.clear()


def test_a_solution_is_computed_once_per_arguments():
    a = _square(3.0, 2)
    assert _square(3.0, 2) is a and CALLS == [(3.0, 2)]
    _square(3.0, 3)
    assert CALLS == [(3.0, 2), (3.0, 3)]


def test_the_memo_keeps_the_most_recently_used_up_to_maxsize():
    _square(1.0, 1)
    _square(2.0, 1)
    _square(1.0, 1)  # now the most recent
    _square(4.0, 1)  # evicts 2.0
    CALLS.clear()
    _square(1.0, 1)
    _square(2.0, 1)
    assert CALLS == [(2.0, 1)]


def test_recording_collects_only_what_its_block_computed():
    _square(1.0, 1)
    with solution_cache.recording() as outer:
        _square(1.0, 1)  # found: not recorded
        with solution_cache.recording() as inner:
            _square(5.0, 1)
        _square(6.0, 1)
    assert [args for _, args in inner] == [(5.0, 1)]
    assert [args for _, args in outer] == [(5.0, 1), (6.0, 1)]


def _compute_in_a_child(conn):
    with solution_cache.recording() as entries:
        _square(7.0, 4)
    conn.send(pickle.dumps(entries))
    conn.close()


def test_what_another_process_computed_is_adopted_without_computing():
    parent, child = mp.get_context("fork").Pipe()
    proc = mp.get_context("fork").Process(target=_compute_in_a_child, args=(child,))
    proc.start()
    entries = pickle.loads(parent.recv())
    proc.join()
    assert CALLS == []  # the child's call did not happen here
    solution_cache.adopt(entries)
    np.testing.assert_array_equal(_square(7.0, 4), np.full(4, 49.0))
    assert CALLS == []


def test_adopting_nothing_changes_nothing():
    solution_cache.adopt(None)
    solution_cache.adopt({})
    _square(2.0, 1)
    assert CALLS == [(2.0, 1)]
