"""Fixtures of the results tests: system files written as the runtime tests write them."""

from __future__ import annotations

from tests.backends.conftest import write_system

__all__ = ["write_system"]
