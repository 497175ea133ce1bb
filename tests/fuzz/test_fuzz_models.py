"""Fuzzing the models fmionnx hands to MuJoCo and onnxruntime: mutated scenes and ONNX models
end in diagnostics or a bounded compile (and run), never a traceback, a hang or gigabytes.

The seeds hold every construct whose numbers decide what the library allocates or how long
it works: a MuJoCo scene with a height field, a built-in texture, a ``replicate``, a
``flexcomp``, an include and ``<size memory>``; an ONNX model with an initializer, an
``Expand`` and a ``Tile`` whose shapes are constants, a ``Reshape`` and a ``Loop`` with a trip
count. The mutations set those numbers to huge, negative and odd values (issue #38). The
module caps its own process's address space, so a protection that breaks fails an example
(MemoryError, a refused allocation) instead of taking the machine's memory.
"""

from __future__ import annotations

import copy
import io
import resource
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import onnx
import pytest
from hypothesis import given
from hypothesis import strategies as st
from onnx import TensorProto, helper, numpy_helper

from fmionnx import api
from fmionnx.core.errors import DiagnosticError, ModelError, RunError
from fmionnx.kinds.mujoco.library import mujoco_module
from fmionnx.kinds.onnx.ortsetup import onnxruntime_module
from fmionnx.reporters import REPORTER_BY_NAME, FileResult
from fmionnx.runtime.result import RunOptions
from tests.fuzz.harness import (
    check_diagnostics,
    fuzz_settings,
    guarded,
    record,
    shown,
    write_input,
)
from tests.fuzz.mutations import COMMON_TOKENS, XML_TOKENS, mutated_bytes, mutated_xml

#: Address space the module's process may grow by while the fuzzers run (the limits keep a
#: scene within 1 GiB and onnxruntime within 4 GiB; a broken limit meets this first).
HEADROOM = 6 * 1024**3

SCENE = b"""<?xml version="1.0"?>
<mujoco model="seed">
  <size memory="1M"/>
  <asset>
    <hfield name="ground" nrow="8" ncol="8" size="1 1 0.1 0.1"/>
    <texture name="grid" type="2d" builtin="checker" width="16" height="16"/>
    <material name="grid" texture="grid"/>
  </asset>
  <worldbody>
    <geom type="hfield" hfield="ground"/>
    <replicate count="3" offset="0.3 0 0">
      <body pos="0 0 0.5"><joint type="hinge"/><geom size="0.05" material="grid"/></body>
    </replicate>
    <flexcomp name="cloth" type="grid" count="2 2 1" spacing="0.1 0.1 0.1" dim="2" pos="1 1 1"/>
    <include file="part.xml"/>
    <body name="probe" pos="0 0 1"><freejoint/><geom size="0.1"/></body>
  </worldbody>
  <sensor><framepos name="probe_pos" objtype="body" objname="probe"/></sensor>
</mujoco>
"""
PART = b'<mujoco><body pos="0 1 1"><joint/><geom size="0.1"/></body></mujoco>'
#: Numbers that decide a scene's size, as MJCF writes them.
SCENE_NUMBERS = (
    "1000000000", "1000000", "40000", "2147483647", "4294967297", "-1", "0",
    "1500 1500 1", "100000 100000 1", "1e9", "100G", "1T", "16E", "30000",
)  # fmt: skip
#: Attributes whose numbers size what MuJoCo allocates or compiles.
SIZING = frozenset({"count", "nrow", "ncol", "width", "height", "memory", "nuserdata", "nkey"})
#: How MuJoCo and onnxruntime say they ran out of memory (under this module's cap): a
#: limit that should have refused the model first did not. (MuJoCo's "mj_stackAlloc: out
#: of memory" and "could not allocate mjData arena" are not: the arena, of the size the scene
#: declares (`memory="0"`), is too small.)
EXHAUSTED = ("could not allocate memory", "bad_alloc", "unknown exception", "failed to allocate")
#: Base steps a model that validates is run for.
STEPS = 5
#: Seconds a step (or a model's loading, initialization) of such a run may take, by kind.
#: An ONNX loop of 2^62 iterations is stopped there (onnxruntime's terminate flag). A scene
#: is compiled again when it is loaded, which within the limits takes seconds on a loaded
#: machine; a call that cannot be stopped makes the run be abandoned, which ends this
#: process (a finding, loudly): the scenes' timeout is far above any bounded compile.
STEP_TIMEOUT = {"onnx": 10.0, "mujoco": 120.0}


def _seed_model() -> onnx.ModelProto:
    """``y = Reshape(Tile(Expand(x + w, [2, 3]), [1, 2]), [12])`` and ``z = x`` through a
    ``Loop`` of 3 iterations."""
    body = helper.make_graph(
        [
            helper.make_node("Identity", ["cond_in"], ["cond_out"]),
            helper.make_node("Identity", ["v_in"], ["v_out"]),
        ],
        "body",
        [
            helper.make_tensor_value_info("i", TensorProto.INT64, []),
            helper.make_tensor_value_info("cond_in", TensorProto.BOOL, []),
            helper.make_tensor_value_info("v_in", TensorProto.FLOAT, [1, 3]),
        ],
        [
            helper.make_tensor_value_info("cond_out", TensorProto.BOOL, []),
            helper.make_tensor_value_info("v_out", TensorProto.FLOAT, [1, 3]),
        ],
    )

    def constant(name: str, values: list[int]) -> onnx.NodeProto:
        tensor = numpy_helper.from_array(np.array(values, np.int64), name)
        return helper.make_node("Constant", [], [name], value=tensor)

    nodes = [
        helper.make_node("Add", ["x", "w"], ["a"]),
        constant("expand_shape", [2, 3]),
        helper.make_node("Expand", ["a", "expand_shape"], ["b"]),
        constant("repeats", [1, 2]),
        helper.make_node("Tile", ["b", "repeats"], ["c"]),
        helper.make_node("Reshape", ["c", "flat"], ["y"]),
        constant("trips", [3]),
        helper.make_node(
            "Constant", [], ["go"], value=helper.make_tensor("go", TensorProto.BOOL, [], [1])
        ),
        helper.make_node("Squeeze", ["trips"], ["trip"]),
        helper.make_node("Loop", ["trip", "go", "x"], ["z"], body=body),
    ]
    graph = helper.make_graph(
        nodes,
        "seed",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 3])],
        [
            helper.make_tensor_value_info("y", TensorProto.FLOAT, [12]),
            helper.make_tensor_value_info("z", TensorProto.FLOAT, [1, 3]),
        ],
        initializer=[
            numpy_helper.from_array(np.array([[1, 2, 3]], np.float32), "w"),
            numpy_helper.from_array(np.array([12], np.int64), "flat"),
        ],
    )
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])


SEED_MODEL = _seed_model()
#: Dimension values and shape entries the ONNX mutations draw from.
BIG = st.sampled_from(
    (0, 1, 3, 12, -1, -7, 2**16, 2**26 + 1, 40_000, 10**6, 805_306_368, 2**31, 2**40, 2**62)
)


def allow_growth() -> None:
    """Let this process grow by :data:`HEADROOM` from its size now (soft limit only).

    Set again before each input, not once per module: the process's virtual size drifts
    between inputs (thread stacks and malloc arenas of earlier runs come and go while its
    resident size stays put), and a cap fixed at the start would fall short of a scene that
    is within its limits late in a long run."""
    hard = resource.getrlimit(resource.RLIMIT_AS)[1]
    with Path("/proc/self/status").open(encoding="ascii") as status:
        size = next(int(line.split()[1]) * 1024 for line in status if line.startswith("VmSize:"))
    cap = size + HEADROOM
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))


@pytest.fixture(scope="module", autouse=True)
def capped_address_space() -> Iterator[None]:
    """The module's inputs run under :func:`allow_growth`'s cap; the limit is restored after
    it. MuJoCo and onnxruntime are imported first: importing is not the models' doing, and
    the runs' step timeout (which times loading) must not count it."""
    mujoco_module()
    onnxruntime_module()
    limits = resource.getrlimit(resource.RLIMIT_AS)
    allow_growth()
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, limits)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    work = tmp_path_factory.mktemp("fuzz-models")
    (work / "part.xml").write_bytes(PART)
    (work / "w.bin").write_bytes(b"\0" * 64)
    return work


def validate_model(path: Path, data: bytes) -> api.CompileResult:
    """``fmionnx validate MODEL`` in-process: the lone model's compile, then every report."""
    allow_growth()
    result = guarded("check_model", data, lambda: api.check_model(path))
    check_diagnostics(result, data)
    for diagnostic in result.diagnostics:  # the limits refuse first: no library runs dry
        text = diagnostic.message.lower()
        assert not any(sign in text for sign in EXHAUSTED), (diagnostic, shown(data))
    for name, reporter in REPORTER_BY_NAME.items():
        stream = io.StringIO()
        guarded(
            f"the {name} reporter",
            data,
            lambda r=reporter, s=stream: r.render(  # type: ignore[misc]
                [FileResult(path, result.diagnostics, document="model")], s, color=False
            ),
        )
    return result


def run_briefly(path: Path, data: bytes) -> None:
    """A model that validates runs its first steps (as the one component of a system) to a
    result or a documented fault."""
    allow_growth()
    kind = "onnx" if path.suffix == ".onnx" else "mujoco"
    system_file = path.with_name("system.yaml")
    system_file.write_text(
        f"fmionnx: 1\nname: fuzz\nrun: {{stop: 1, step: 0.002}}\n"
        f"components:\n  model: {{kind: {kind}, path: {path.name}}}\n",
        "utf-8",
    )

    def run() -> None:
        try:
            system = api.load(system_file)
            settings = system.compiled.run
            system.run(
                stop_time=settings.start + STEPS * settings.step,
                options=RunOptions(step_timeout=STEP_TIMEOUT[kind]),
            )
            record("run: ran")
        except (DiagnosticError, ModelError, RunError) as error:
            record(f"run: {type(error).__name__}")

    guarded("load and run", data, run)


# -- MuJoCo scenes ------------------------------------------------------------------------------


def test_the_seed_scene_compiles_and_runs(folder: Path) -> None:
    path = write_input(folder / "scene.xml", SCENE)
    result = validate_model(path, SCENE)
    assert result.ok, [d.message for d in result.diagnostics]
    run_briefly(path, SCENE)


@st.composite
def mutated_scene(draw: st.DrawFn) -> bytes:
    """The seed scene with 1 to 3 edits: a number that sizes something (a count, rows,
    columns, a texture's width, the memory) set to a hostile value, or an element duplicated
    or moved (a ``replicate`` inside another, an include repeated)."""
    from lxml import etree

    root = etree.fromstring(SCENE)
    for _ in range(draw(st.integers(1, 3))):
        elements = list(root.iter(etree.Element))
        sized = [(e, a) for e in elements for a in e.attrib if a in SIZING]
        op = draw(st.sampled_from(("number", "number", "duplicate", "move")))
        if op == "number" and sized:
            element, attribute = draw(st.sampled_from(sized))
            value = draw(st.one_of(st.sampled_from(SCENE_NUMBERS), st.integers().map(str)))
            element.set(attribute, value)
        else:
            element = draw(st.sampled_from(elements[1:]))
            parent = element.getparent()
            if op == "duplicate":
                parent.insert(parent.index(element), copy.deepcopy(element))
            else:
                target = draw(st.sampled_from(elements))
                if element not in target.iterancestors() and target is not element:
                    parent.remove(element)
                    target.append(element)
    return bytes(etree.tostring(root, xml_declaration=True, encoding="UTF-8"))


@given(mutated_scene())
@fuzz_settings(60)
def test_mutated_scene_sizes_end_in_diagnostics_or_a_bounded_compile(
    folder: Path, mutated: bytes
) -> None:
    """Counts, rows, columns, widths and memory set to huge, negative and odd values;
    elements duplicated and moved."""
    path = write_input(folder / "scene.xml", mutated)
    if validate_model(path, mutated).ok:
        run_briefly(path, mutated)


@given(st.data())
@fuzz_settings(40)
def test_mutated_scene_numbers_end_in_diagnostics_or_a_bounded_compile(
    folder: Path, data: st.DataObject
) -> None:
    """Any attribute of the scene set to any value (hostile sizes among them), elements
    dropped, renamed, duplicated and moved."""
    mutated = data.draw(mutated_xml(SCENE, max_ops=3, extra=SCENE_NUMBERS), label="scene")
    path = write_input(folder / "scene.xml", mutated)
    if validate_model(path, mutated).ok:
        run_briefly(path, mutated)


@given(st.data())
@fuzz_settings(40)
def test_byte_mutated_scenes_end_in_diagnostics(folder: Path, data: st.DataObject) -> None:
    mutated = data.draw(mutated_bytes(SCENE, XML_TOKENS), label="scene")
    validate_model(write_input(folder / "scene.xml", mutated), mutated)


# -- ONNX models --------------------------------------------------------------------------------


@st.composite
def mutated_model(draw: st.DrawFn) -> bytes:
    """The seed model with 1 to 3 edits of the numbers that size its tensors: a stored
    tensor's dims (also declared external, in a 64-byte file), a graph input's or output's
    dimension, a constant shape's entries, the loop's trip count, a node's integer
    attribute."""
    model = onnx.ModelProto()
    model.CopyFrom(SEED_MODEL)
    graph = model.graph
    constants = [n for n in graph.node if n.op_type == "Constant"]
    for _ in range(draw(st.integers(1, 3))):
        op = draw(
            st.sampled_from(("dims", "external", "value_info", "constant", "attribute", "trips"))
        )
        if op in ("dims", "external"):
            tensor = draw(st.sampled_from(list(graph.initializer)))
            tensor.ClearField("dims")
            tensor.dims.extend(draw(st.lists(BIG, min_size=1, max_size=3)))
            if op == "external":
                tensor.ClearField("raw_data")
                tensor.ClearField("float_data")
                tensor.ClearField("int64_data")
                tensor.data_location = TensorProto.EXTERNAL
                del tensor.external_data[:]
                entry = tensor.external_data.add()
                entry.key, entry.value = "location", "w.bin"
        elif op == "value_info":
            value = draw(st.sampled_from([*graph.input, *graph.output]))
            dims = value.type.tensor_type.shape.dim
            if dims:
                dims[draw(st.integers(0, len(dims) - 1))].dim_value = draw(BIG)
        elif op == "trips":  # a loop of up to 2^62 iterations: stopped by the step timeout
            (node,) = [n for n in constants if n.output[0] == "trips"]
            tensor = node.attribute[0].t
            tensor.CopyFrom(numpy_helper.from_array(np.array([draw(BIG)], np.int64), "trips"))
        elif op == "constant":
            node = draw(st.sampled_from(constants))
            tensor = node.attribute[0].t
            if tensor.data_type == TensorProto.INT64:
                values = draw(st.lists(BIG, min_size=1, max_size=4))
                tensor.CopyFrom(numpy_helper.from_array(np.array(values, np.int64), tensor.name))
        else:
            node = draw(st.sampled_from(list(graph.node)))
            node.attribute.append(helper.make_attribute("axis", draw(BIG)))
    return model.SerializeToString()


def test_the_seed_model_compiles_and_runs(folder: Path) -> None:
    data = SEED_MODEL.SerializeToString()
    path = write_input(folder / "model.onnx", data)
    result = validate_model(path, data)
    assert result.ok, [d.message for d in result.diagnostics]
    run_briefly(path, data)


@given(mutated_model())
@fuzz_settings(60)
def test_mutated_onnx_shapes_end_in_diagnostics_or_a_bounded_run(
    folder: Path, mutated: bytes
) -> None:
    path = write_input(folder / "model.onnx", mutated)
    if validate_model(path, mutated).ok:
        run_briefly(path, mutated)


@given(st.data())
@fuzz_settings(40)
def test_byte_mutated_onnx_models_end_in_diagnostics(folder: Path, data: st.DataObject) -> None:
    mutated = data.draw(mutated_bytes(SEED_MODEL.SerializeToString(), COMMON_TOKENS))
    validate_model(write_input(folder / "model.onnx", mutated), mutated)


def test_shown_inputs_stay_short() -> None:
    assert len(shown(b"x" * 100_000)) < 4000
