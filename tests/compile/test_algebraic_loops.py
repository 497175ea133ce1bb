"""Algebraic loops in the compiler: refused by default, resolved into the compiled system on
request (members, tear inputs, order, solver), and carried through the compiled-system file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.compile.graph import execution_order, loop_groups
from fmionnx.compile.ir import CompiledSystem, LoopSolver
from fmionnx.compile.systemfile import from_json, to_json
from tests.conftest import build_fixture_fmu

LOOP = """
fmionnx: 1
name: loops
run: {{stop: 1, step: 0.1{settings}}}
components:
  src: {{kind: signal, outputs: {{y: {{constant: 1.0}}}}}}
  b: {{kind: fmu, path: {gain}}}
  a: {{kind: fmu, path: {gain}}}
  sink: {{kind: fmu, path: {gain}}}
connections:
  - a.y -> sink.u
  - a.y -> b.u
  - b.y -> a.u
  - src.y -> b.v[1]
  - b.w[1] -> a.v[1]
  - a.w[1] -> sink.v[1]
"""


def _compile(tmp_path: Path, settings: str) -> api.CompileResult:
    path = tmp_path / "system.yaml"
    path.write_text(LOOP.format(settings=settings, gain=build_fixture_fmu("Gain")), "utf-8")
    return api.compile_system(path)


def _system(tmp_path: Path, settings: str) -> CompiledSystem:
    result = _compile(tmp_path, settings)
    assert result.system is not None, [str(d) for d in result.diagnostics]
    return result.system


def test_without_the_setting_a_loop_is_e035_with_a_hint_to_iterate(tmp_path: Path) -> None:
    result = _compile(tmp_path, "")
    assert result.system is None
    (error,) = [d for d in result.diagnostics if d.code == "E035"]
    assert error.message == "algebraic loop: a.y -> b.u -> b.y -> a.u -> a.y"
    assert error.hint is not None
    assert "algebraic_loops" in error.hint


def test_e035_marks_only_the_connections_of_the_loop(tmp_path: Path) -> None:
    """``a.y -> sink.u`` leaves a port of the loop but is no edge of it: no caret, no note."""
    result = _compile(tmp_path, "")
    (error,) = [d for d in result.diagnostics if d.code == "E035"]
    lines = (tmp_path / "system.yaml").read_text("utf-8").splitlines()
    assert lines[error.span.line - 1].strip() == "- a.y -> b.u"
    assert [lines[n.span.line - 1].strip() for n in error.notes if n.span] == ["- b.y -> a.u"]


def test_e035_on_a_self_loop_marks_that_connection_alone(tmp_path: Path) -> None:
    gain = build_fixture_fmu("Gain")
    path = tmp_path / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: self_loop\nrun: {stop: 1, step: 0.1}\ncomponents:\n"
        f"  pi: {{kind: fmu, path: {gain}}}\n  room: {{kind: fmu, path: {gain}}}\n"
        "connections:\n  - pi.y -> room.u\n  - pi.y -> pi.u\n",
        "utf-8",
    )
    result = api.compile_system(path)
    (error,) = [d for d in result.diagnostics if d.code == "E035"]
    assert error.message == "algebraic loop: pi.y -> pi.u -> pi.y"
    assert error.span.line == 9  # `- pi.y -> pi.u`, not `- pi.y -> room.u` above it
    assert not error.notes


def test_a_loop_to_iterate_is_resolved_into_the_compiled_system(tmp_path: Path) -> None:
    system = _system(tmp_path, ", algebraic_loops: {solver: newton, relaxation: 0.5}")
    (loop,) = system.loops
    assert loop.members == ("b", "a")  # declaration order
    assert [str(t) for t in loop.tears] == ["b.u"]  # b reads a, stepped after it
    assert loop.cycle == ("a.y", "b.u", "b.y", "a.u")  # from the first connection
    assert loop.solver == LoopSolver("newton", 1e-10, 50, 0.5)
    # producers first, the loop's members together, consumers after
    assert system.order == ("src", "b", "a", "sink")
    assert system.loop_of("a") is loop
    assert system.loop_of("sink") is None


def test_the_loop_travels_in_the_compiled_system_file(tmp_path: Path) -> None:
    system = _system(tmp_path, ", algebraic_loops: {}")
    back = from_json(to_json(system))
    assert back == system
    assert back.loops[0].solver == LoopSolver()
    assert back.content_hash == system.content_hash
    # the loop is part of the content hash; systems without loops hash as they did
    assert dataclasses.replace(system, loops=()).content_hash != system.content_hash


def test_loops_sharing_a_component_are_solved_together(tmp_path: Path) -> None:
    gain = build_fixture_fmu("Gain")
    path = tmp_path / "two.yaml"
    path.write_text(
        f"""
fmionnx: 1
name: two
run: {{stop: 1, step: 0.1, algebraic_loops: {{}}}}
components:
  a: {{kind: fmu, path: {gain}}}
  b: {{kind: fmu, path: {gain}}}
connections:
  - a.y -> b.u
  - b.y -> a.u
  - a.w -> b.v
  - b.w -> a.v
""",
        "utf-8",
    )
    system = api.compile_system(path).system
    assert system is not None
    (loop,) = system.loops  # the scalar loop and the vector loop run through the same pair
    assert loop.members == ("a", "b")
    assert sorted(str(t) for t in loop.tears) == ["a.u", "a.v"]


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ("{solver: secant}", "Input should be 'fixed-point' or 'newton'"),
        ("{tolerance: 0}", "greater than 0"),
        ("{max_iterations: 0}", "greater than or equal to 1"),
        ("{relaxation: 3}", "less than or equal to 2"),
        ("{solver: newton, tries: 3}", "tries"),
    ],
)
def test_bad_settings_are_schema_errors(tmp_path: Path, settings: str, message: str) -> None:
    result = _compile(tmp_path, f", algebraic_loops: {settings}")
    assert result.system is None
    assert any(message in d.message for d in result.diagnostics), [
        d.message for d in result.diagnostics
    ]


def test_without_loops_the_order_is_unchanged(tmp_path: Path) -> None:
    system = _system(tmp_path, ", algebraic_loops: {}")
    plain = [c for c in system.connections if str(c) != "b.y -> a.u"]
    assert loop_groups(system.components, plain) == []
    assert execution_order(system.components, plain) == ("src", "b", "a", "sink")


def test_graph_json_shows_the_loops(tmp_path: Path) -> None:
    from fmionnx.export.graph import to_json

    document = to_json(_system(tmp_path, ", algebraic_loops: {solver: newton}"))
    assert document["loops"] == [
        {
            "members": ["b", "a"],
            "tears": ["b.u"],
            "cycle": ["a.y", "b.u", "b.y", "a.u"],
            "solver": "newton",
        }
    ]
