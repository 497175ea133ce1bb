"""What a user without rclpy is told to do (issue #34): a command that works from a clone.

fmionnx is installed from a clone (it is not on PyPI), so ``pip install 'fmionnx[rclpy]'``
cannot work; and rich read ``[rclpy]`` in that hint as markup and printed
``pip install 'fmionnx'``. No rclpy or DDS is loaded here: only the text is checked.
"""

from __future__ import annotations

import importlib.util

import pytest
import typer

from fmionnx.backends.ros2 import rclpy_env
from fmionnx.cli.app import ExitCode, fail


def test_the_hint_installs_the_extra_from_the_clone(monkeypatch: pytest.MonkeyPatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "rclpy" else real(name, *a)
    )
    problem = rclpy_env.rclpy_problem()
    assert problem is not None
    assert "pip install -e '.[rclpy]'" in problem
    assert "make setup-test" in problem
    assert "'fmionnx[" not in problem


def test_an_error_prints_square_brackets_as_written(capsys: pytest.CaptureFixture[str]) -> None:
    message = f"--middleware rclpy: rclpy is not installed: {rclpy_env.INSTALL_HINT}"
    exit_ = fail(message)
    assert isinstance(exit_, typer.Exit)
    assert exit_.exit_code == ExitCode.USAGE
    printed = " ".join(capsys.readouterr().err.split())  # unwrapped
    assert printed == f"error: {' '.join(message.split())}"
    assert "'.[rclpy]'" in printed


def test_markup_like_text_in_an_error_is_not_interpreted(
    capsys: pytest.CaptureFixture[str],
) -> None:
    fail("column `nn.power[0]` and [bold]not bold[/bold]")
    assert "nn.power[0]` and [bold]not bold[/bold]" in capsys.readouterr().err
