"""Whatever bytes a user feeds in, the front end and compiler answer with diagnostics."""

from __future__ import annotations

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fmionnx import api
from fmionnx.core.diagnostics import Severity

FRAGMENTS = [
    "fmionnx: 1\n",
    "name: demo\n",
    "run: {stop: 1, step: 0.01}\n",
    "components:\n",
    "  a: {kind: fmu, path: a.fmu}\n",
    "  b: {kind: onnx, path: b.onnx, period: 0.1}\n",
    "  c: {kind: mujoco, path: c.xml, cameras: {f: {}}}\n",
    "connections:\n",
    "  - a.y -> b.x\n",
    "  - {from: a.y[0], to: c.u, factor: 2}\n",
    "plots:\n  - {xy: [a.y, b.z]}\n",
    "ros2: {nodes: {a: node}}\n",
    "  - [\n",
    "  ? x\n",
    "\t",
    "&anchor *anchor\n",
    "!!binary aGVsbG8=\n",
    "- - -\n",
    "{]\n",
    "\xe9\n",
]


@given(st.lists(st.sampled_from(FRAGMENTS), max_size=12), st.binary(max_size=40))
@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_compile_never_raises(tmp_path: Path, fragments: list[str], noise: bytes) -> None:
    path = tmp_path / "system.yaml"
    path.write_bytes("".join(fragments).encode("utf-8") + noise)
    result = api.compile_system(path)
    if result.system is None:
        assert any(d.severity is Severity.ERROR for d in result.diagnostics)
    for diagnostic in result.diagnostics:
        assert diagnostic.span is not None
        assert diagnostic.message
