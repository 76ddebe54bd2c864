"""Argument types shared by the command-line modules: a bad value becomes argparse's one-line
error (``argument --dt: not a number: 'abc'``), which ``harness.cli.main`` turns into exit code 2."""

from __future__ import annotations

import argparse


def float_arg(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def int_arg(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def csv_list(text: str) -> list[str]:
    """``"a, b,,c"`` -> ``["a", "b", "c"]``."""
    return [s for s in (p.strip() for p in text.split(",")) if s]
