"""Shared settings of the validation tests: the ``slow`` marker (MuJoCo runs), registered here if not globally."""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "slow: a slow test (MuJoCo simulations); deselect with -m 'not slow'")
