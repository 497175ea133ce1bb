"""Models shared by every case of the diagnostics corpus, made once per session.

Each case folder is copied to a temporary folder and these models are linked beside its
``system.yaml``, so system files name them by bare file name and golden output holds no
machine paths.
"""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper

from tests.conftest import FIXTURE_BUILD, build_fixture_fmu

CASES = Path(__file__).resolve().parent
MODEL_DIR = FIXTURE_BUILD / "case-models"

FMI1_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="1.0" modelName="Old" modelIdentifier="Old" guid="{0}"
  numberOfContinuousStates="0" numberOfEventIndicators="0">
  <ModelVariables/>
</fmiModelDescription>
"""

#: An FMI 3 array of 10^9 elements, declared in a few hundred bytes (E008).
HUGE_ARRAY_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Huge" instantiationToken="{2}">
  <CoSimulation modelIdentifier="Huge"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="x" valueReference="1" causality="output"><Dimension start="1000000000"/></Float64>
  </ModelVariables>
  <ModelStructure><Output valueReference="1"/></ModelStructure>
</fmiModelDescription>
"""

#: Written last; a cache without it (made before a model was added) is made again.
COMPLETE = ".complete-2"

NO_BINARY_DESCRIPTION = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="WindowsOnly" guid="{1}">
  <CoSimulation modelIdentifier="WindowsOnly"/>
  <ModelVariables>
    <ScalarVariable name="u" valueReference="0" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="1" causality="output"><Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="2"/></Outputs></ModelStructure>
</fmiModelDescription>
"""


def _tiny_onnx(path: Path) -> None:
    """``y = x * n`` (float32 [1,3] times int64 [1]) and ``label_out = label`` (strings)."""
    graph = helper.make_graph(
        [
            helper.make_node("Cast", ["n"], ["n_float"], to=TensorProto.FLOAT),
            helper.make_node("Mul", ["x", "n_float"], ["y"]),
            helper.make_node("Identity", ["label"], ["label_out"]),
        ],
        "tiny",
        [
            helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 3]),
            helper.make_tensor_value_info("n", TensorProto.INT64, [1]),
            helper.make_tensor_value_info("label", TensorProto.STRING, [1]),
        ],
        [
            helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 3]),
            helper.make_tensor_value_info("label_out", TensorProto.STRING, [1]),
        ],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)


def make_case_models() -> Path:
    """Build (once per change of the fixture FMUs' sources) the folder of models every case
    may use: the marker names the source-hashed builds it was made from."""
    built = {name: build_fixture_fmu(name) for name in ("Gain", "Integrator", "Vector3")}
    stamp = "\n".join(path.name for path in built.values()) + "\n"
    marker = MODEL_DIR / COMPLETE
    if marker.exists() and marker.read_text(encoding="utf-8") == stamp:
        return MODEL_DIR
    MODEL_DIR.mkdir(parents=True, exist_ok=True)
    for name, path in built.items():
        shutil.copy(path, MODEL_DIR / f"{name}.fmu")
    _tiny_onnx(MODEL_DIR / "tiny.onnx")
    shutil.copy(CASES / "models" / "scene.xml", MODEL_DIR / "scene.xml")
    (MODEL_DIR / "notzip.fmu").write_text("this is not a zip archive\n", encoding="utf-8")
    with zipfile.ZipFile(MODEL_DIR / "evil.fmu", "w") as archive:
        archive.writestr("modelDescription.xml", NO_BINARY_DESCRIPTION)
        archive.writestr("../../escaped.txt", "outside")
    old = MODEL_DIR / "fmi1"
    old.mkdir(exist_ok=True)
    (old / "modelDescription.xml").write_text(FMI1_DESCRIPTION, encoding="utf-8")
    windows = MODEL_DIR / "windows_only"
    (windows / "binaries" / "win64").mkdir(parents=True, exist_ok=True)
    (windows / "modelDescription.xml").write_text(NO_BINARY_DESCRIPTION, encoding="utf-8")
    (windows / "binaries" / "win64" / "WindowsOnly.dll").write_bytes(b"MZ")
    (MODEL_DIR / "a_folder").mkdir(exist_ok=True)
    with zipfile.ZipFile(MODEL_DIR / "huge_array.fmu", "w") as archive:
        archive.writestr("modelDescription.xml", HUGE_ARRAY_DESCRIPTION)
    marker.write_text(stamp, encoding="utf-8")
    return MODEL_DIR


@pytest.fixture(scope="session")
def case_models() -> Path:
    """The shared model folder."""
    return make_case_models()
