"""``--scheduler``: a malformed address or a scheduler that does not answer is one clear line,
and the results folder is not made (a corrected retry needs no ``--resume`` or ``--force``)."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.backends.sweep import engine
from fmionnx.cli import app
from tests.sweep.conftest import WriteStudy

STUDY = """\
fmionnx: 1
system: system.yaml
parameters:
  gain.k: [1, 2]
metrics:
  y: final(gain.y)
"""


def _sweep(study: Path, out: Path, scheduler: str) -> tuple[int, str]:
    result = CliRunner().invoke(
        app,
        ["sweep", str(study), "--out", str(out), "--scheduler", scheduler],
        env={"COLUMNS": "200", "NO_COLOR": "1"},
    )
    return result.exit_code, result.output


@pytest.mark.parametrize(
    ("address", "says"),
    [
        ("http://127.0.0.1:8786", "expected SCHEME://HOST:PORT with SCHEME one of tcp, tls"),
        ("tcp://127.0.0.1", "no valid port"),
        ("tcp://127.0.0.1:99999", "no valid port"),
        ("127.0.0.1:8786", "expected SCHEME://HOST:PORT"),
        ("tcp://127.0.0.1:8786/x", "nothing after the port"),
    ],
)
def test_a_malformed_address_is_a_usage_error_before_anything_is_written(
    write_study: WriteStudy, tmp_path: Path, address: str, says: str
) -> None:
    out = tmp_path / "out"
    code, output = _sweep(write_study(STUDY), out, address)
    assert code == 2, output
    assert says in output
    assert "Traceback" not in output
    assert not out.exists()


def test_a_scheduler_that_does_not_answer_leaves_no_folder(
    write_study: WriteStudy, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(engine, "CONNECT_TIMEOUT", 2)
    with socket.socket() as probe:  # a port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    out = tmp_path / "out"
    code, output = _sweep(write_study(STUDY), out, f"tcp://127.0.0.1:{port}")
    assert code == 1, output
    assert f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}" in output
    assert "Traceback" not in output
    assert not out.exists()


def test_addresses_dask_accepts_pass_the_check() -> None:
    for address in ("tcp://10.0.0.5:8786", "tls://scheduler.lan:8786", "tcp://[::1]:8786"):
        assert engine.scheduler_problem(address) is None
