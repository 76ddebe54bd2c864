"""MuJoCo's warnings captured instead of printed: one capture for the stepping engine
(``engine.MujocoEngine.simulate``), ``mujoco.rollout`` (``rollout.RolloutModel.run``) and
``harness check`` (``harness.tools.check.run_check``).

MuJoCo's C library reports a warning (e.g. "Nan, Inf or huge value in QACC at DOF 1. The
simulation is unstable.") through ``mju_warning``: without a user handler it prints it on file
descriptor 2 and appends it to ``MUJOCO_LOG.TXT`` in the working folder. ``captured_warnings``
installs a handler (``mujoco.set_mju_user_warning``) that appends each message to a list instead,
and restores the previous handler on exit. MuJoCo still counts every warning in
``MjData.warning`` whoever handles its text, so blow-up guards that read those counters are not
affected.

A run record keeps them as ``warning_stats(messages)``: ``{"count": n, "first": first message}``
(the trajectory's ``stats["warnings"]``, shown in the validation report and ``check_<model>.md``).
"""

from __future__ import annotations

import mujoco

from harness.engines.base import warning_stats  # noqa: F401 - the engines' common form, re-exported


class captured_warnings:
    """Context manager: MuJoCo's warning messages (``mju_user_warning``) are appended to
    ``messages`` (a list of str) instead of being printed; the previous handler is restored on
    exit. The handler is process-wide: one capture at a time per process (as the engines run)."""

    def __enter__(self) -> "captured_warnings":
        self.messages: list[str] = []
        self._previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.messages.append)
        return self

    def __exit__(self, *exc) -> None:
        mujoco.set_mju_user_warning(self._previous)

    def stats(self) -> dict:
        """``warning_stats`` of the messages so far."""
        return warning_stats(self.messages)
