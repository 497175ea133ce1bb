"""Command-line interface. Commands live in one module each and are registered here."""

from __future__ import annotations

from fmionnx.cli import (  # noqa: F401 - importing registers the commands
    build_cmd,
    graph_cmd,
    inspect_cmd,
    lock_cmd,
    node_cmd,
    ros2_cmd,
    run_cmd,
    schema_cmd,
    ssp_cmd,
    validate_cmd,
)
from fmionnx.cli.app import app


def main() -> None:
    """Console-script entry point."""
    app()
