"""The import contract of the layers (docs/architecture.md), read from the source itself.

Every ``import`` counts, lazy ones inside functions included (they are how layers leak). A
module may import its own layer and the layers listed for it; nothing imports the surface; no
backend imports another; and there is no cycle between packages.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import networkx as nx
import pytest

from fmionnx.kinds.registry import COMPONENT_KINDS

PACKAGE = Path(__file__).resolve().parents[2] / "fmionnx"

#: Layer of each top-level part of the package (``fmionnx.<part>``).
LAYER_OF = {
    "core": "core",
    "kinds": "kinds",
    "spec": "spec",
    "compile": "compile",
    "runtime": "runtime",
    "backends": "backends",
    "pipeline": "pipeline",
    "results": "pipeline",
    "api": "surface",
    "cli": "surface",
    "export": "surface",
    "lock": "surface",
    "lsp": "surface",
    "reporters": "surface",
    "__init__": "surface",
    "__main__": "surface",
    "entry": "surface",
    "spawned": "surface",
}

#: What each layer may import besides itself. ``compile`` holds both the compiler and the
#: compiled system; below the compiler only the compiled system's modules may be used.
ALLOWED = {
    "core": set(),
    "kinds": {"core"},
    "spec": {"core", "kinds"},
    "compile": {"core", "kinds", "spec"},
    "runtime": {"core", "kinds", "compiled system"},
    "backends": {"core", "kinds", "runtime", "compiled system"},
    "pipeline": {"core", "kinds", "spec", "compile", "compiled system", "runtime", "backends"},
    "surface": {
        "core",
        "kinds",
        "spec",
        "compile",
        "compiled system",
        "runtime",
        "backends",
        "pipeline",
        "surface",
    },
}

#: The compiled system and what it is made of: usable by the runtime and the backends. The rest
#: of ``compile`` (the compiler, resolution, type checks) reads front-end models.
COMPILED_SYSTEM = (
    "fmionnx.compile.checkir",
    "fmionnx.compile.ir",
    "fmionnx.compile.overrides",  # pure functions of the compiled system: a sweep worker applies them
    "fmionnx.compile.studyir",
    "fmionnx.compile.systemfile",
    "fmionnx.compile.ros2.fields",
    "fmionnx.compile.ros2.messages",
    "fmionnx.compile.ros2.names",
    "fmionnx.compile.ros2.plan",
    "fmionnx.compile.ros2.qos",
    "fmionnx.compile.ros2.types",
)


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _type_checking_only(tree: ast.Module) -> set[int]:
    """Nodes inside ``if TYPE_CHECKING:`` blocks (annotations only: nothing is imported)."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.If)
            and isinstance(node.test, ast.Name)
            and node.test.id == "TYPE_CHECKING"
        ):
            for child in node.body:
                inside.update(id(n) for n in ast.walk(child))
    return inside


def _imports(path: Path, package: str) -> Iterator[str]:
    """Every module ``path`` imports (``package``: its own package, for relative imports)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped = _type_checking_only(tree)
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                module = ".".join([*base, *([node.module] if node.module else [])])
            else:
                module = node.module or ""
            names = [alias.name for alias in node.names]
            if not (module == "fmionnx" and names == ["__version__"]):  # a constant, no code
                yield module
            for name in names:  # `from fmionnx import api` imports fmionnx.api
                yield f"{module}.{name}"


def _part(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "fmionnx":
        return None
    if len(parts) == 1:
        return "__init__"
    return parts[1] if parts[1] in LAYER_OF else None


def _layer(module: str) -> str | None:
    part = _part(module)
    if part is None:
        return None
    if part == "compile" and module.startswith(COMPILED_SYSTEM):
        return "compiled system"
    return LAYER_OF[part]


def _edges() -> list[tuple[str, str]]:
    edges = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = _module_name(path)
        package = here if path.name == "__init__.py" else here.rpartition(".")[0]
        for target in _imports(path, package):
            if _part(target) is not None and target != "fmionnx.__version__":
                edges.append((here, target))
    return edges


def test_every_top_level_part_has_a_layer() -> None:
    parts = {p.stem for p in PACKAGE.glob("*.py")}
    parts |= {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").is_file()}
    assert parts <= set(LAYER_OF), f"give these a layer: {sorted(parts - set(LAYER_OF))}"


def test_lower_layers_never_import_higher_ones() -> None:
    broken = []
    for here, target in _edges():
        mine, theirs = _layer(here), _layer(target)
        assert mine is not None
        assert theirs is not None
        if mine == "compiled system":
            mine = "compile"
        same = mine == theirs or (mine == "compile" and theirs == "compiled system")
        if not same and theirs not in ALLOWED[mine]:
            broken.append(f"{here} ({mine}) imports {target} ({theirs})")
    assert broken == []


def test_no_backend_imports_another() -> None:
    broken = [
        f"{here} imports {target}"
        for here, target in _edges()
        if here.startswith("fmionnx.backends.")
        and target.startswith("fmionnx.backends.")
        and here.split(".")[2] != target.split(".")[2]
        and len(target.split(".")) > 2
    ]
    assert broken == []


def test_no_cycle_between_packages() -> None:
    graph: nx.DiGraph = nx.DiGraph()
    for here, target in _edges():
        a, b = _part(here), _part(target)
        if a != b and a not in ("__init__", "__main__"):
            graph.add_edge(a, b)
    assert list(nx.simple_cycles(graph)) == []


def test_the_compiled_system_imports_no_front_end() -> None:
    """The IR and its file refer to no spec type: a worker can read it without the front end."""
    broken = [
        f"{here} imports {target}"
        for here, target in _edges()
        if _layer(here) == "compiled system"
        and target.startswith(("fmionnx.spec", "fmionnx.compile.compiler"))
    ]
    assert broken == []


#: Modules outside ``kinds/`` that may import a specific kind, and why.
KIND_IMPORTS_ALLOWED = {
    "fmionnx.cli.build_cmd": "`fmionnx build` is the FMU kind's own tool (an FMU from C sources)",
}


def test_only_a_kind_imports_its_modules() -> None:
    """Everything else reaches a kind through the kind table and the protocols of
    ``kinds/base.py`` (docs/architecture.md): the runtime's native kernel through
    ``core/cosim.py``, a study's worker through ``settle_worker``, a lone model through
    ``kind_for_path``."""
    specific = {f"fmionnx.kinds.{name}" for name in COMPONENT_KINDS}
    broken = [
        f"{here} imports {target}"
        for here, target in _edges()
        if not here.startswith("fmionnx.kinds")
        and here not in KIND_IMPORTS_ALLOWED
        and any(target == s or target.startswith(f"{s}.") for s in specific)
    ]
    assert broken == []


def test_the_kind_import_check_sees_a_lazy_import(tmp_path: Path) -> None:
    path = tmp_path / "sample.py"
    path.write_text("def f():\n    from fmionnx.kinds.onnx.runner import x\n", encoding="utf-8")
    found = list(_imports(path, "fmionnx.runtime"))
    assert "fmionnx.kinds.onnx.runner" in found


@pytest.mark.parametrize(
    ("source", "expected"),
    [
        ("import fmionnx.spec.model\n", ["fmionnx.spec.model"]),
        ("def f():\n    from fmionnx.cli import app\n", ["fmionnx.cli", "fmionnx.cli.app"]),
        ("from .base import X\n", ["fmionnx.kinds.base", "fmionnx.kinds.base.X"]),
        ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import fmionnx.cli\n", []),
    ],
)
def test_the_reader_sees_lazy_and_relative_imports(
    tmp_path: Path, source: str, expected: list[str]
) -> None:
    path = tmp_path / "sample.py"
    path.write_text(source, encoding="utf-8")
    found = [m for m in _imports(path, "fmionnx.kinds") if m.startswith("fmionnx")]
    assert found == expected
