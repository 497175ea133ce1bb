"""The committed JSON Schema is generated from the pydantic model and must stay current."""

from __future__ import annotations

import json

import jsonschema

from fmionnx.cli.schema_cmd import schema_text
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.model import ComponentSpec
from tests.conftest import REPO


def test_committed_schema_is_up_to_date() -> None:
    committed = (REPO / "schemas" / "system.schema.json").read_text(encoding="utf-8")
    assert committed == schema_text(), "run `make schema` and commit schemas/system.schema.json"


def test_schema_accepts_the_reference_system_shape() -> None:
    schema = json.loads(schema_text())
    document = {
        "fmionnx": 1,
        "name": "demo",
        "run": {"stop": 1, "step": 0.01},
        "components": {
            "a": {"kind": "fmu", "path": "a.fmu", "parameters": {"k": 2}},
            "w": {"kind": "mujoco", "path": "w.xml", "cameras": {"front": {"width": 64}}},
        },
        "connections": ["a.y -> w.u", {"from": "a.y", "to": "w.v", "factor": 2}],
    }
    jsonschema.validate(document, schema)


def test_schema_rejects_unknown_keys_like_the_loader() -> None:
    schema = json.loads(schema_text())
    document = {"fmionnx": 1, "name": "x", "components": {}, "colour": "red"}
    validator = jsonschema.Draft202012Validator(schema)
    assert any("colour" in error.message for error in validator.iter_errors(document))


def test_every_registered_kind_is_in_the_component_union() -> None:
    union_kinds = {arg.model_fields["kind"].default for arg in ComponentSpec.__origin__.__args__}  # type: ignore[attr-defined]
    assert union_kinds == set(COMPONENT_KINDS)
