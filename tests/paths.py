"""Paths the tests share: the small fixture models, the hostile-input corpus, the repository."""

from __future__ import annotations

from pathlib import Path

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
#: small URDF and DH fixtures beside the tests
FIXTURES = TESTS / "fixtures"
#: the hostile and malformed input corpus (``manifest.yaml`` lists every item and its expected error)
CORPUS = TESTS / "corpus"
