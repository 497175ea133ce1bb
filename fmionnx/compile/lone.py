"""A lone model compiled without the system-file format (``fmionnx run model.fmu``).

A one-component system without connections, inputs, plots, checks or a ROS 2 section needs
only the steps of :func:`fmionnx.compile.compiler.compile_spec` that apply to one component:
read its interface, resolve the run settings, compile the component, order it. Going through
``compile_spec`` instead would build a :class:`~fmionnx.spec.model.SystemSpec`, whose
``components`` union imports every component kind's entry model, and import the checks',
plots', loops' and system inputs' compilers: about 40 ms of a lone FMU's start that produce
nothing (issue #14).

The result is the same :class:`CompiledSystem` as ``compile_spec`` gives for the
one-component system file (``tests/compile/test_lone_model.py`` compares the two, their
serialised form and their diagnostics, for FMUs and an ONNX model).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from fmionnx.compile.components import compile_component
from fmionnx.compile.graph import execution_order
from fmionnx.compile.ir import CompiledSystem, Origin
from fmionnx.compile.resolve import read_interface, resolve_run
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.signals import every_output
from fmionnx.core.specbase import ComponentSpecBase
from fmionnx.spec.runspec import RunSpec
from fmionnx.spec.sourcemap import SourceMap


def compile_lone(
    name: str, spec: ComponentSpecBase, run: RunSpec, path: Path, bag: DiagnosticBag
) -> CompiledSystem | None:
    """The system ``name`` of the one component ``spec`` (its model at ``path``) under ``run``.

    ``compile_spec`` of ``{fmionnx: 1, name: NAME, run: RUN, components: {NAME: SPEC}}``
    read from ``path``, without what such a system cannot have. Its warnings about unconnected
    inputs (W030) are not emitted: a model alone has nothing to connect them to; and a model
    alone has no algebraic loop (``run.algebraic_loops`` changes nothing). None when errors
    make a system impossible.
    """
    sources = SourceMap(path)
    interface = read_interface(name, spec, path, sources, bag)
    readable = {name: interface} if interface is not None else {}
    periods = {name: spec.period} if spec.period is not None else {}
    settings = resolve_run(run, readable, periods, sources, bag, fallback_step=False)
    if interface is None:
        return None
    component = compile_component(name, spec, interface, settings, path, sources, bag)
    if settings is None or bag.has_errors:
        return None
    # every output, as for a system file without `record:` (compiler.py)
    settings = dataclasses.replace(
        settings, origins=(*settings.origins, ("record", Origin.BUILTIN_DEFAULT))
    )
    return CompiledSystem(
        name=name,
        source=path,
        run=settings,
        components=(component,),
        connections=(),
        order=execution_order([component], []),
        plots=(),
        record=every_output((component,)),
        checks=(),
        ros2=None,
        description="",
        inputs=(),
        loops=(),
    )
