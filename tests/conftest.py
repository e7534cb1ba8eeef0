"""Shared fixtures. Fixture URDFs live in tests/fixtures/."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

FIXTURES = Path(__file__).parent / "fixtures"


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def catalogue():
    from kinematics import default_catalogue

    return default_catalogue()
