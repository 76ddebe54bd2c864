"""references/ERRATA.md is generated from references/errata.py, and every test it cites exists."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from harness.references import errata

ROOT = Path(__file__).resolve().parents[2]


def test_errata_file_is_up_to_date():
    assert errata.ERRATA_PATH.read_text() == errata.render(), "run: python -m harness.references.errata"


def _cited():
    for e in errata.ERRATA:
        yield from e.tests
    for _, _, test in errata.VERIFIED:
        yield test


@pytest.mark.parametrize("test", sorted(set(_cited())))
def test_cited_tests_exist(test):
    path, name = test.split("::")
    tree = ast.parse((ROOT / path).read_text())
    assert name in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}, test
