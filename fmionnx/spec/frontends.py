"""Front ends by file suffix: each turns a file into a SystemSpec plus a SourceMap."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.spec.yaml import LoadedSpec, load_yaml_system

FrontEnd = Callable[[Path, DiagnosticBag], LoadedSpec]


def load_ssp_system(path: Path, bag: DiagnosticBag) -> LoadedSpec:
    """The SSP front end, imported when an SSP file is read (YAML runs do not pay for it)."""
    from fmionnx.spec.ssp import load_ssp_system as load

    return load(path, bag)


FRONTENDS: Mapping[str, FrontEnd] = {
    ".yaml": load_yaml_system,
    ".yml": load_yaml_system,
    ".ssp": load_ssp_system,
    ".ssd": load_ssp_system,
}


def load_system(path: Path, bag: DiagnosticBag) -> LoadedSpec:
    """Load a system file with the front end its suffix selects."""
    from fmionnx.spec.sourcemap import SourceMap

    frontend = FRONTENDS.get(path.suffix.lower())
    suffixes = ", ".join(f"`{s}`" for s in sorted(FRONTENDS))
    if frontend is None and path.is_dir():
        bag.emit(
            codes.NOT_A_FILE,
            f"`{path}` is a folder, not a system file",
            Span(path),
            hint=f"name the system files (ending in {suffixes}), e.g. `{path / '*.yaml'}`",
        )
        return LoadedSpec(None, SourceMap(path), path)
    if frontend is None:
        bag.emit(
            codes.UNSUPPORTED_MODEL,
            f"`{path.name or path}` is not a system file fmionnx reads",
            Span(path),
            hint=f"system files end in {suffixes}",
        )
        return LoadedSpec(None, SourceMap(path), path)
    return frontend(path, bag)
