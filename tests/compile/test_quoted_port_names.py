"""Ports whose names are no dotted word, named in quotes (a bug hunt).

PyTorch's ONNX export names ports ``input.1`` and ``12``; a camera may be named ``a b``. The
endpoint grammar wants every dotted part to start with a letter, ``_`` or ``$``, so such a
port could be neither connected, recorded, set from a system input nor checked:
``t.input.1`` was E023 "is not an endpoint", whose hint (``component.port``) could not be
followed. The port part of an endpoint may now be quoted, ``p."input.1"``, ``p."12"[1]``,
and E023 shows the quoted form of what was written.

The models are real ONNX graphs, run in-process.
"""

from __future__ import annotations

import re
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from fmionnx.compile.endpoints import endpoint_text, split_endpoint
from fmionnx.core.codes import Severity
from fmionnx.core.errors import DiagnosticError
from fmionnx.core.types import PortRef
from fmionnx.runtime.result import RunStatus
from fmionnx.spec.model import split_connection


def _save(graph: onnx.GraphProto, path: Path) -> Path:
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.save(model, path)
    return path


def _double(name: str, size: int) -> onnx.ValueInfoProto:
    return helper.make_tensor_value_info(name, TensorProto.DOUBLE, [size])


def _models(folder: Path) -> tuple[Path, Path]:
    """``p``: ``12 = [input.1, 2*input.1]``, ``a b = input.1 + 1``; ``q``: ``out = x y + z``."""
    two = helper.make_tensor("two", TensorProto.DOUBLE, [1], [2.0])
    one = helper.make_tensor("one", TensorProto.DOUBLE, [1], [1.0])
    producer = helper.make_graph(
        [
            helper.make_node("Mul", ["input.1", "two"], ["doubled"]),
            helper.make_node("Concat", ["input.1", "doubled"], ["12"], axis=0),
            helper.make_node("Add", ["input.1", "one"], ["a b"]),
        ],
        "torch_like",
        [_double("input.1", 1)],
        [_double("12", 2), _double("a b", 1)],
        initializer=[two, one],
    )
    consumer = helper.make_graph(
        [helper.make_node("Add", ["x y", "z"], ["out"])],
        "sum",
        [_double("x y", 1), _double("z", 1)],
        [_double("out", 1)],
    )
    return _save(producer, folder / "p.onnx"), _save(consumer, folder / "q.onnx")


SYSTEM = """\
fmionnx: 1
name: quoted
run: {{stop: 0.2, step: 0.1}}
components:
  p: {{kind: onnx, path: {p}}}
  q: {{kind: onnx, path: {q}}}
inputs:
  k: {{to: [p."input.1"], value: 2.5}}
connections:
  - p."12"[1] -> q."x y"
  - {{from: p."a b", to: q.z}}
record: [p."12", 'q."x y"', q.out]
plots:
  - {{y: [p."a b", 'p."12"[1]'], title: quoted}}
checks:
  - name: sums
    expect: final(`q."x y"`[0]) + final(`p."a b"`[0]) - final(q.out[0]) == 0
"""


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path`` as the working directory, so messages name `system.yaml`."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def _system(folder: Path, text: str = SYSTEM) -> Path:
    p, q = _models(folder)
    path = folder / "system.yaml"
    path.write_text(text.format(p=p, q=q), encoding="utf-8")
    return path


def test_quoted_ports_connect_record_take_inputs_and_are_checked(folder: Path) -> None:
    path = _system(folder)
    system = fmionnx.load(path)
    assert not [d for d in system.diagnostics if d.severity > Severity.INFO]
    (plot,) = system.compiled.plots
    assert [str(ref) for ref in plot.refs] == ["p.a b", "p.12[1]"]
    outcome = fmionnx.run(path, no_out=True, isolate="none")
    result = outcome.result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["p.12[0]"][-1] == 2.5  # from the system input, at `input.1`
    assert result.signals["p.12[1]"][-1] == 5.0
    assert result.signals["q.x y[0]"][-1] == 5.0  # p."12"[1] -> q."x y"
    assert result.signals["q.out[0]"][-1] == 5.0 + 3.5  # p."a b" -> q.z
    assert [(check.name, check.passed) for check in outcome.checks] == [("sums", True)]
    assert outcome.passed


def test_a_quoted_input_is_set_by_its_system_input_from_the_command_line(folder: Path) -> None:
    path = _system(folder)
    outcome = fmionnx.run(path, no_out=True, isolate="none", params={"k": 4})
    assert outcome.result.signals["q.out[0]"][-1] == 8.0 + 5.0


@pytest.mark.parametrize(
    ("written", "hint"),
    [
        ("p.input.1", '`p."input.1"`'),
        ("p.12[1]", '`p."12"[1]`'),
        ("p.a b", '`p."a b"`'),
    ],
)
def test_an_unquoted_name_is_e023_whose_hint_quotes_it(
    folder: Path, written: str, hint: str
) -> None:
    text = SYSTEM.replace('p."12"[1] -> q."x y"', f'{written} -> q."x y"')
    path = _system(folder, text)
    result = CliRunner().invoke(app, ["validate", path.name])
    assert result.exit_code == 1
    assert "Traceback" not in result.output
    line = re.search(r"^system\.yaml:10:5: error\[E023 bad-endpoint\]: (.*)$", result.output, re.M)
    assert line is not None, result.output
    assert line.group(1) == f"`{written}` is not an endpoint"
    assert f"quote a port name that is not a dotted word: {hint}" in result.output


def test_the_hints_quoted_form_is_the_fix(folder: Path) -> None:
    """What E023 suggests compiles (the hint is followed, not only printed)."""
    text = SYSTEM.replace('p."12"[1] -> q."x y"', 'p.12[1] -> q."x y"')
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(folder, text))
    (error,) = [d for d in refused.value.diagnostics if d.code == "E023"]
    assert error.hint is not None
    suggested = error.hint.split("`")[1]
    fixed = text.replace('p.12[1] -> q."x y"', f'{suggested} -> q."x y"')
    assert not [d for d in fmionnx.load(_system(folder, fixed)).diagnostics if d.code == "E023"]


def test_a_quoted_name_of_an_unknown_component_or_port_is_said_so(folder: Path) -> None:
    text = SYSTEM.replace('p."12"[1] -> q."x y"', 'r."12"[1] -> q."x  y"')
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(folder, text))
    found = {d.code: d for d in refused.value.diagnostics}
    assert found["E020"].message == 'unknown component `r` in `r."12"[1]`'
    assert found["E021"].message == "component `q` (onnx) has no port `x  y`"
    assert found["E021"].hint == "did you mean `x y`?"


@pytest.mark.parametrize(
    ("text", "parts"),
    [
        ('t."input.1"', ("t", "input.1", None)),
        ('t."12"[0,1]', ("t", "12", "0,1")),
        ('sub.gain."a b"', ("sub.gain", "a b", None)),
        ('t."medium[1].T"', ("t", "medium[1].T", None)),
        ('t.""', None),  # an empty name
        ('t."a"b"', None),  # a name cannot hold `"`
        ('t."a', None),
    ],
)
def test_the_quotes_hold_the_whole_port_name(
    text: str, parts: tuple[str, str, str | None] | None
) -> None:
    assert split_endpoint(text, {"t": None, "sub.gain": None}) == parts


def test_an_arrow_inside_quotes_belongs_to_the_name() -> None:
    assert split_connection('a.y -> t."x->y"') == ("a.y", 't."x->y"')
    assert split_connection('t."x->y"[0] -> a.u') == ('t."x->y"[0]', "a.u")
    assert split_connection("a.y -> b.u -> c.v") is None
    assert split_connection('t."x -> a.u') == ('t."x', "a.u")  # unbalanced: E023 at `t."x`


@pytest.mark.parametrize(
    "ref",
    [PortRef("t", "input.1", (0,)), PortRef("t", "a b"), PortRef("t", "x.y"), PortRef("t", "v[1]")],
)
def test_endpoint_text_parses_back_to_its_ref(ref: PortRef) -> None:
    parts = split_endpoint(endpoint_text(ref), {"t": None})
    assert parts is not None
    component, port, index = parts
    parsed = None if index is None else tuple(int(i) for i in index.split(","))
    assert (component, port, parsed) == (ref.component, ref.port, ref.index)


def test_a_parameter_name_is_the_port_name_as_the_model_writes_it(folder: Path) -> None:
    """``--param``/``params=`` split the component off by prefix: no quotes are needed."""
    outcome = fmionnx.run(_system(folder), no_out=True, isolate="none", params={"p.input.1": 4})
    assert outcome.result.signals["q.out[0]"][-1] == 8.0 + 5.0


@pytest.mark.parametrize("signal", ['p."12"', PortRef("p", "12")])
def test_signals_to_record_name_a_quoted_port_as_text_or_as_a_ref(
    folder: Path, signal: str | PortRef
) -> None:
    outcome = fmionnx.run(_system(folder), no_out=True, isolate="none", signals=[signal])
    assert list(outcome.result.signals) == ["p.12[0]", "p.12[1]"]


@pytest.mark.parametrize(
    ("written", "hint"),
    [
        # names no port of `p` quoted either: the grammar, not a quoting that leads to E021
        (
            "p.nope.1",
            'write `component.port`, or `component.port[i]` for one element, or `component."port '
            'name"` for a port whose name is no dotted word',
        ),
        (
            'p."12',
            'a quoted port name is written `component."port name"`, an index after the closing '
            'quote; the name can be neither empty nor hold `"`',
        ),
        ("p", "write `component.port`, or `component.port[i]` for one element"),
    ],
)
def test_e023_explains_quoting_where_no_quoted_fix_is_known(
    folder: Path, written: str, hint: str
) -> None:
    text = SYSTEM.replace('p."12"[1] -> q."x y"', f"'{written} -> q.z'").replace(
        '{{from: p."a b", to: q.z}}', 'p."a b"[0] -> q."x y"[0]'
    )
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(folder, text))
    (error,) = [d for d in refused.value.diagnostics if d.code == "E023"]
    assert error.message == f"`{written}` is not an endpoint"
    assert error.hint == hint


def test_quoted_ports_survive_an_ssp_round_trip(folder: Path) -> None:
    """The SSD's connectors carry the names as the models do (`input.1`, `x y`); read back,
    an endpoint made of one was E023 "is not an endpoint": the reader quotes such a port."""
    from tests.ssp.test_roundtrip import compiled, round_trip

    path = _system(folder)
    archive, back = round_trip(path, folder)
    original = compiled(path)
    for other in (compiled(archive), compiled(back)):
        assert [(str(c.src), str(c.dst)) for c in other.connections] == [
            (str(c.src), str(c.dst)) for c in original.connections
        ]
    result = fmionnx.run(archive, no_out=True, isolate="none").result
    assert result.status is RunStatus.COMPLETED, result.error
    assert result.signals["q.out[0]"][-1] == 5.0 + 3.5


def test_hints_that_pick_an_element_of_a_quoted_port_can_be_followed(folder: Path) -> None:
    """A check naming an array whole and a connection of 2 elements into 1 suggested
    `q.x y[0]` and `p.12[0]`, which do not parse: the hints quote the port."""
    text = SYSTEM.replace(
        'final(`q."x y"`[0]) + final(`p."a b"`[0]) - final(q.out[0]) == 0', 'final(`q."x y"`) == 5'
    )
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(folder, text))
    assert [d.hint for d in refused.value.diagnostics] == [
        'pick an element, between backticks: `` `q."x y"[0]` ``'
    ]
    text = SYSTEM.replace('  - p."12"[1] -> q."x y"', '  - p."12" -> q."x y"')
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(folder, text))
    assert [d.hint for d in refused.value.diagnostics] == ['select one element, e.g. `p."12"[0]`']
