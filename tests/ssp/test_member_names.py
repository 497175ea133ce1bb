"""Diagnostics about an SSD inside an ``.ssp`` name the archive the user gave, not the cache."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app


def test_a_broken_connection_in_an_ssp_is_reported_as_archive_member(
    fixture_fmu: Callable[[str], Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMIONNX_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    system = tmp_path / "chain.yaml"
    system.write_text(
        "fmionnx: 1\nname: chain\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  a: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        f"  b: {{kind: fmu, path: {fixture_fmu('Gain')}}}\n"
        "connections:\n  - a.y -> b.u\n",
        encoding="utf-8",
    )
    runner = CliRunner()
    assert (
        runner.invoke(
            app, ["export", "chain.yaml", "-o", "good.ssp"], catch_exceptions=False
        ).exit_code
        == 0
    )
    with zipfile.ZipFile("good.ssp") as source, zipfile.ZipFile("bad.ssp", "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "SystemStructure.ssd":
                data = data.replace(b'endConnector="u"', b'endConnector="uu"')
            target.writestr(item, data)
    result = runner.invoke(app, ["validate", "bad.ssp"], catch_exceptions=False)
    assert result.exit_code == 1
    assert "bad.ssp!/SystemStructure.ssd:" in result.output
    assert "error[E021" in result.output
    assert "cache" not in result.output
    json_report = runner.invoke(app, ["validate", "bad.ssp", "-f", "json"], catch_exceptions=False)
    assert '"file": "bad.ssp!/SystemStructure.ssd"' in json_report.output
