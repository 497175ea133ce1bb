"""The Python API: everything the CLI does, callable from code and tests.

>>> from fmionnx import api
>>> result = api.compile_system("systems/sign_follower.yaml")
>>> result.ok, [str(d.span) for d in result.diagnostics]
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Severity
from fmionnx.spec.frontends import load_system


@dataclass(frozen=True)
class CompileResult:
    """A compiled system (None when there were errors) and every diagnostic, sorted."""

    system: CompiledSystem | None
    diagnostics: tuple[Diagnostic, ...]

    @property
    def ok(self) -> bool:
        """True when no diagnostic is an error."""
        return all(d.severity is not Severity.ERROR for d in self.diagnostics)


def compile_system(path: str | Path) -> CompileResult:
    """Load, check and compile a system file (YAML or SSP) into the IR."""
    from fmionnx.compile.compiler import compile_spec

    bag = DiagnosticBag()
    loaded = load_system(Path(path), bag)
    system = None
    if loaded.spec is not None:
        system = compile_spec(loaded, bag)
    diagnostics = tuple(bag.sorted())
    if any(d.severity is Severity.ERROR for d in diagnostics):
        system = None
    return CompileResult(system, diagnostics)
