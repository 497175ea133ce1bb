"""A model's run-time check is remembered for its bytes (:mod:`fmionnx.kinds.onnx.checked`).

The check itself must still stop every model it stopped before: other bytes, other limits,
external data and a switched-off cache all check again. A run of a remembered model loads
what was checked without importing ``onnx``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from fmionnx.core import codes
from fmionnx.core.errors import ModelError
from fmionnx.core.private import KEY_FILE, user_key
from fmionnx.kinds.onnx import checked, interface
from fmionnx.kinds.onnx.runner import SESSIONS
from tests.security.test_onnx_files import WEIGHTS, _runner, _save, _scale


@pytest.fixture
def secret(tmp_path: Path) -> Path:
    """A file outside the model's folder that holds exactly what the model expects."""
    path = tmp_path / "secret.bin"
    path.write_bytes(WEIGHTS.tobytes())
    return path


@pytest.fixture(autouse=True)
def _no_kept_sessions() -> None:
    """Every instantiate here makes its session (none is taken from an earlier test)."""
    SESSIONS.clear()


def _step(path: Path) -> list[float]:
    runner = _runner(path)
    runner.instantiate()
    runner.setup(0.0, 1.0)
    runner.input_buffer("x")[:] = 2.0
    runner.step(0.0, 0.1)
    values = [float(v) for v in runner.output_buffer("y")]
    runner.terminate()
    SESSIONS.clear()
    return values


def _refuse(*_: object) -> None:
    raise AssertionError("the model was checked again")


def test_a_model_that_passed_is_not_checked_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = _save(_scale(None), tmp_path / "model" / "scale.onnx")
    assert not checked.passed(path.read_bytes())
    assert _step(path) == [2.0, 4.0, 6.0]
    assert checked.passed(path.read_bytes())
    with monkeypatch.context() as patch:
        patch.setattr(interface, "parse_checked_model", _refuse)
        assert _step(path) == [2.0, 4.0, 6.0]


def test_other_bytes_are_checked(tmp_path: Path, secret: Path) -> None:
    path = _save(_scale(None), tmp_path / "model" / "scale.onnx")
    runner = _runner(path)
    assert _step(path) == [2.0, 4.0, 6.0]  # remembered
    _save(_scale("../secret.bin"), path)  # rewritten after it passed
    with pytest.raises(ModelError, match="outside the model's folder") as info:
        runner.instantiate()
    assert info.value.code is codes.UNSAFE_ARCHIVE


def test_other_limits_check_again(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = _save(_scale(None), tmp_path / "model" / "scale.onnx")
    assert _step(path) == [2.0, 4.0, 6.0]  # remembered under the default limits
    runner = _runner(path)
    monkeypatch.setenv("FMIONNX_MAX_MODEL_ELEMENTS", "2")  # the weights hold 3
    assert not checked.passed(path.read_bytes())
    with pytest.raises(ModelError) as info:
        runner.instantiate()
    assert info.value.code is codes.RESOURCE_LIMIT


def test_a_model_with_external_data_is_checked_every_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "model"
    path = _save(_scale("weights.bin"), folder / "scale.onnx")
    (folder / "weights.bin").write_bytes(WEIGHTS.tobytes())
    assert _step(path) == [2.0, 4.0, 6.0]
    assert not checked.passed(path.read_bytes())
    assert not [p for p in checked.entry(b"").parent.glob("*") if not p.name.startswith(".")]


@pytest.mark.parametrize("forgery", ["unsigned", "other key", "group-writable", "link"])
def test_a_verdict_that_is_not_this_users_own_is_ignored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, forgery: str
) -> None:
    path = _save(_scale(None), tmp_path / "model" / "scale.onnx")
    data = path.read_bytes()
    assert _step(path) == [2.0, 4.0, 6.0]
    verdict = checked.entry(data)
    assert checked.passed(data)
    if forgery == "unsigned":
        verdict.write_bytes(b"0" * 64)
    elif forgery == "other key":
        (verdict.parent / KEY_FILE).unlink()
        user_key(verdict.parent, make=True)  # a new key: every verdict signed before is void
    elif forgery == "group-writable":
        verdict.parent.chmod(0o775)
    else:
        planted = tmp_path / "planted"
        planted.write_bytes(verdict.read_bytes())
        verdict.unlink()
        verdict.symlink_to(planted)
    assert not checked.passed(data)
    with monkeypatch.context() as patch:
        patch.setattr(interface, "parse_checked_model", _refuse)
        with pytest.raises(AssertionError, match="checked again"):
            _step(path)


def test_remembering_can_be_switched_off(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(checked.SWITCH, "0")
    path = _save(_scale(None), tmp_path / "model" / "scale.onnx")
    assert _step(path) == [2.0, 4.0, 6.0]
    monkeypatch.delenv(checked.SWITCH)
    assert not checked.passed(path.read_bytes())


def test_a_run_of_a_remembered_model_does_not_import_onnx(tmp_path: Path) -> None:
    """Two runs of a system in fresh processes: the compile cache and this record leave
    ``onnx`` out of the second."""
    _save(_scale(None), tmp_path / "scale.onnx")
    system = tmp_path / "system.yaml"
    system.write_text(
        "fmionnx: 1\nname: scaled\nrun: {stop: 3.0, step: 1.0}\n"
        "components:\n  s: {kind: onnx, path: scale.onnx}\n",
        encoding="utf-8",
    )
    program = (
        "import sys, fmionnx; "
        f"result = fmionnx.load({str(system)!r}).run(isolate='none'); "
        "print(result.status.value, 'onnx' in sys.modules)"
    )
    seen = [
        subprocess.run(
            [sys.executable, "-c", program], capture_output=True, text=True, check=True
        ).stdout.split()
        for _ in range(2)
    ]
    assert seen == [["completed", "True"], ["completed", "False"]]
