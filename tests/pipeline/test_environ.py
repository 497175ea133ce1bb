"""Variables set for a while are put back as they were: set to their old value, or unset."""

from __future__ import annotations

import os

import pytest

from fmionnx.core.environ import put_back, variables_set


def test_variables_set_for_a_block_are_put_back(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMIONNX_TEST_KEPT", "old")
    monkeypatch.delenv("FMIONNX_TEST_NEW", raising=False)
    with variables_set({"FMIONNX_TEST_KEPT": "new", "FMIONNX_TEST_NEW": "1"}):
        assert os.environ["FMIONNX_TEST_KEPT"] == "new"
        assert os.environ["FMIONNX_TEST_NEW"] == "1"
    assert os.environ["FMIONNX_TEST_KEPT"] == "old"
    assert "FMIONNX_TEST_NEW" not in os.environ


def test_put_back_unsets_what_was_not_set(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FMIONNX_TEST_NEW", "1")
    put_back({"FMIONNX_TEST_NEW": None})
    assert "FMIONNX_TEST_NEW" not in os.environ
