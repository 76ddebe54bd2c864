"""Progress bars and one-line notes on stderr, decided the same way by every command.

``make_bar(total, desc=..., quiet=...)`` returns a ``tqdm`` bar drawn on stderr when stderr is a
terminal and ``quiet`` is false, and otherwise a ``NoBar``: one that prints one line per tick
(``[12/57] heavy_top mujoco ok 0.8 s``) when stderr is not a terminal (a log file, a pipe, CI),
and nothing with ``quiet``. Both count: ``bar.n`` is the number of ticks so far, ``bar.total``
the planned number. ``bar.done(label)`` ticks one finished case and names it (``case_label``
builds the usual ``<scene> <engine> <status> <wall> s``); ``bar.update(n)`` ticks without a name
(the line then shows the last ``set_postfix_str`` or the bar's ``desc``). Use a bar as a context
manager (or call ``close()``).

``set_quiet(True)`` (the CLI's ``--quiet``) makes the process quiet: no bar from ``make_bar``
and no ``note``. Worker processes forked afterwards inherit it. ``note(text)`` prints one line on
stderr, above a bar if one is drawn (except when quiet).
"""

from __future__ import annotations

import io
import os
import sys
from typing import Any, TextIO

_QUIET = False


def set_quiet(quiet: bool) -> None:
    """Make this process (and the workers it forks later) quiet, or not."""
    global _QUIET
    _QUIET = bool(quiet)


def is_quiet() -> bool:
    """True after ``set_quiet(True)``."""
    return _QUIET


def _is_terminal(stream: TextIO) -> bool:
    """True when ``stream`` is an interactive terminal."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # closed or not a real file
        return False


def bar_enabled(quiet: bool = False, stream: TextIO | None = None) -> bool:
    """Whether a bar is drawn: ``stream`` (default stderr) is a terminal and neither ``quiet``
    nor ``set_quiet(True)``."""
    return not (quiet or _QUIET) and _is_terminal(sys.stderr if stream is None else stream)


class NoBar:
    """A bar that draws nothing but counts like ``tqdm``: ``n`` ticks of ``total``. With
    ``lines`` (stderr not a terminal, not quiet) each tick prints one line on ``stream``:
    ``[n/total] label``, the label of ``done(label)``, else the last postfix, else ``desc``."""

    def __init__(self, total: int | None = None, desc: str = "", *, lines: bool = False,
                 stream: TextIO | None = None) -> None:
        self.total, self.n, self.desc = total, 0, desc
        self.lines, self.stream, self.postfix = lines, stream, ""

    def update(self, n: int = 1) -> None:
        self.n += n
        if n > 0:
            self._line(self.postfix or self.desc)

    def done(self, label: str = "", n: int = 1) -> None:
        """Tick ``n`` finished cases, named ``label`` on the line."""
        self.n += n
        if n > 0:
            self._line(label or self.postfix or self.desc)

    def _line(self, label: str) -> None:
        if not self.lines or _QUIET:
            return
        count = f"{self.n}/{self.total}" if self.total is not None else f"{self.n}"
        try:
            stream = sys.stderr if self.stream is None else self.stream
            stream.write(f"[{count}] {' '.join(str(label).split())}\n")
            stream.flush()
        except (OSError, ValueError):  # a closed stream: a progress line is not worth an error
            pass

    def set_description(self, desc: str = "", refresh: bool = True) -> None:
        self.desc = desc

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = s

    def refresh(self) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> "NoBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def case_label(key: Any, outcome: Any = None) -> str:
    """``heavy_top mujoco ok 0.8 s``: a case's key (a name or a tuple of names) and, given its
    ``Outcome`` (``harness.validate.workers``), how it ended and its wall time."""
    parts = key if isinstance(key, tuple) else (key,)
    text = " ".join(str(p) for p in parts)
    if outcome is not None:
        text += f" {getattr(outcome, 'status', '')} {getattr(outcome, 'wall_s', 0.0):.1f} s"
    return text


_TQDM_BAR = None


def _tqdm_bar():
    """``tqdm`` with ``done(label, n)`` (the label as its postfix), made once."""
    global _TQDM_BAR
    if _TQDM_BAR is None:
        from tqdm import tqdm

        class Bar(tqdm):
            def done(self, label: str = "", n: int = 1) -> None:
                if label:
                    self.set_postfix_str(label[:60], refresh=False)
                self.update(n)

        _TQDM_BAR = Bar
    return _TQDM_BAR


def make_bar(total: int | None, *, desc: str = "", unit: str = "run", quiet: bool = False,
             stream: TextIO | None = None) -> Any:
    """A progress bar over ``total`` items (None: unknown) on ``stream`` (default stderr): a
    ``tqdm`` bar when ``bar_enabled(quiet, stream)``; else a ``NoBar``, printing one line per
    tick unless ``quiet`` or ``set_quiet(True)``."""
    stream = sys.stderr if stream is None else stream
    if not bar_enabled(quiet, stream):
        return NoBar(total, desc, lines=not (quiet or _QUIET), stream=stream)
    try:  # a terminal that reports no width (e.g. a bare pseudo-terminal) gets 80 x 24
        sized = os.get_terminal_size(stream.fileno()).columns > 0
    except (AttributeError, ValueError, OSError, io.UnsupportedOperation):
        sized = False
    return _tqdm_bar()(total=total, desc=desc, unit=unit, file=stream, leave=True, mininterval=0.2,
                       **({"dynamic_ncols": True} if sized else {"ncols": 80, "nrows": 24}))


def note(text: str, stream: TextIO | None = None) -> None:
    """Print ``text`` as one line on ``stream`` (default stderr), unless quiet. On a terminal
    the line first clears the current one, so that it does not run into a bar being drawn
    (the bar redraws itself on its next tick)."""
    if _QUIET:
        return
    stream = sys.stderr if stream is None else stream
    prefix = "\r\x1b[2K" if _is_terminal(stream) else ""
    try:
        stream.write(f"{prefix}{text}\n")
        stream.flush()
    except (OSError, ValueError):  # a closed stream: the note is not worth an error
        pass
