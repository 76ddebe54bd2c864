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
