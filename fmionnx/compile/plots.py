"""The ``plots:`` of a system file, checked and resolved into the compiled system.

Every plotted signal is drawn or refused here, never dropped when the picture is made: a
signal that does not resolve is E045 at its place; one that resolves to something a plot
cannot draw (a camera image, a string, a parameter, an array on an xy axis) is E046 saying
why. What an xy plot draws underneath (``over``) is read now, through the owning component's
kind, into plain numbers: the expected path's points and the map of its world. Each plot's
file name is settled too (:mod:`fmionnx.compile.plotfiles`), so the results writer needs
neither a model file nor the system file.
"""

from __future__ import annotations

from collections.abc import Mapping

from fmionnx.compile.endpoints import ResolvedEndpoint, resolve_endpoint, without_spaces
from fmionnx.compile.expected_path import (
    EXPECTED_PATH,
    PathFileError,
    expected_path_file,
    read_expected_path,
)
from fmionnx.compile.ir import Marks, Plot, Series, plot_file_problem
from fmionnx.compile.plotfiles import derived_stem, slug, unique_name, with_suffix
from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.errors import ModelError
from fmionnx.core.signals import column_names, is_image
from fmionnx.core.types import Causality, Component, ComponentInterface, DType, PortRef
from fmionnx.kinds.base import MAP, MapSource, SceneMap
from fmionnx.kinds.registry import COMPONENT_KINDS
from fmionnx.spec.model import PlotSpec, SystemSpec
from fmionnx.spec.sourcemap import SourceMap

#: What ``over`` may name after a component: its expected path (drawn over its map, when it
#: has one) or its map alone.
MAP_REFERENCE = "map"
#: Most lines one time plot draws (an array port is a line per element).
MAX_LINES = 64


def compile_plots(
    spec: SystemSpec,
    components: Mapping[str, Component],
    sources: SourceMap,
    bag: DiagnosticBag,
    *,
    unreadable: frozenset[str] = frozenset(),
) -> tuple[Plot, ...]:
    """Check and resolve every plot entry, in order; problems go to ``bag``.

    ``unreadable``: declared components whose model could not be read (reported already);
    a signal or ``over`` naming one is left out without a further diagnostic.
    """
    interfaces: dict[str, ComponentInterface | None] = {
        **dict.fromkeys(unreadable),
        **{n: c.interface for n, c in components.items()},
    }
    taken = {with_suffix(p.file) for p in spec.plots if p.file is not None}
    given: set[str] = set()
    plots = []
    for index, plot in enumerate(spec.plots):
        key = "xy" if plot.xy is not None else "y"
        texts = tuple(without_spaces(t) for t in (plot.xy or plot.y or ()))
        refs: list[PortRef] = []
        series: list[Series] = []
        for position, text in enumerate(texts):
            span = sources.value(("plots", index, key, position))
            scratch = DiagnosticBag()
            resolved = resolve_endpoint(text, span, interfaces, scratch)
            if resolved is None:
                for diagnostic in scratch:
                    bag.emit(codes.PLOT, f"plot: {diagnostic.message}", span, hint=diagnostic.hint)
                continue
            if _drawable(resolved, text, on_xy=plot.xy is not None, span=span, bag=bag):
                refs.append(resolved.ref)
                columns = column_names(resolved.ref.component, resolved.port, resolved.ref.index)
                series.append(Series(text, tuple(columns), resolved.port.unit))
        path, scene = _over(plot, index, components, unreadable, sources, bag)
        marks = _marks(plot, index, interfaces, sources, bag)
        if marks is not None:
            refs.append(marks[1])
        plots.append(
            Plot(
                xy=(texts[0], texts[1]) if plot.xy is not None else None,
                y=texts if plot.xy is None else (),
                refs=tuple(refs),
                series=tuple(series),
                path=path,
                scene=scene,
                title=plot.title,
                file=_file(plot, index, texts, taken, given, sources, bag),
                marks=None if marks is None else marks[0],
            )
        )
    return tuple(plots)


def _marks(
    plot: PlotSpec,
    index: int,
    interfaces: Mapping[str, ComponentInterface | None],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[Marks, PortRef] | None:
    """The plot's ``marks`` resolved to one recorded column; None (E045/E046 when wrong)."""
    if plot.marks is None:
        return None
    span = sources.value(("plots", index, "marks", "of"))
    if plot.xy is not None:
        bag.emit(
            codes.PLOT,
            "`marks` are drawn on a plot over time; this is an xy plot",
            sources.key(("plots", index, "marks")),
            hint="move `marks` to a plot with `y: [...]`",
        )
        return None
    text = without_spaces(plot.marks.of)
    scratch = DiagnosticBag()
    resolved = resolve_endpoint(text, span, interfaces, scratch)
    if resolved is None:
        for diagnostic in scratch:
            bag.emit(codes.PLOT, f"plot marks: {diagnostic.message}", span, hint=diagnostic.hint)
        return None
    count = 1 if resolved.ref.index is not None else resolved.port.size
    if count != 1:
        has = "a size known only at run time" if count is None else f"{count} elements"
        bag.emit(
            codes.PLOT_SIGNAL,
            f"plot marks: follow one signal; `{text}` has {has}",
            span,
            hint=f"select one element, e.g. `{text}[0]`" if count else "follow another signal",
        )
        return None
    if not _drawable(resolved, text, on_xy=False, span=span, bag=bag):
        return None
    (column,) = column_names(resolved.ref.component, resolved.port, resolved.ref.index)
    labels = tuple((float(value), label) for value, label in plot.marks.labels.items())
    return Marks(text, column, labels), resolved.ref


def _drawable(
    resolved: ResolvedEndpoint, text: str, *, on_xy: bool, span: Span, bag: DiagnosticBag
) -> bool:
    """Whether the signal can be drawn; E046 at ``span`` saying why not."""
    port = resolved.port
    problem, hint = None, None
    if port.causality not in (Causality.INPUT, Causality.OUTPUT):
        problem = (
            f"`{text}` is a {port.causality.value}: it does not change during a run and is "
            "not recorded"
        )
        hint = "plot an input or an output; a parameter's value is set under `parameters`"
    elif is_image(port):
        problem = (
            f"`{text}` is an image ({port.dtype.value}{port.shape_text()}): a plot draws numbers"
        )
        hint = "`--record run.mcap` keeps the frames (Foxglove shows them); plot what a model computes from them"
    elif port.dtype in (DType.STRING, DType.BINARY):
        problem = f"`{text}` holds {port.dtype.value} values: a plot draws numbers"
        hint = "plot a numeric signal"
    elif port.size is None:
        problem = f"`{text}` has a size known only at run time ({port.shape_text()})"
        hint = "plot a port of fixed shape"
    else:
        count = 1 if resolved.ref.index is not None else port.size
        if on_xy and count > 1:
            problem = f"an xy axis is one signal; `{text}` has {count} elements"
            hint = f"select one element, e.g. `{text}[0]`"
        elif count > MAX_LINES:
            problem = f"`{text}` has {count} elements; a time plot draws at most {MAX_LINES} lines"
            hint = f"select elements, e.g. `{text}[0]`, each a signal of its own"
    if problem is None:
        return True
    bag.emit(codes.PLOT_SIGNAL, f"plot: {problem}", span, hint=hint)
    return False


def _over(
    plot: PlotSpec,
    index: int,
    components: Mapping[str, Component],
    unreadable: frozenset[str],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> tuple[tuple[tuple[float, float], ...], SceneMap | None]:
    """The expected path's points and the map ``over`` names (empty and None when it names
    nothing usable, with a diagnostic unless its component's model could not be read)."""
    if plot.over is None:
        return (), None
    span = sources.value(("plots", index, "over"))
    owner, _, what = plot.over.strip().rpartition(".")
    if owner in unreadable:
        return (), None
    choices = f"`<component>.{EXPECTED_PATH}` or `<component>.{MAP_REFERENCE}`"
    if plot.xy is None:
        bag.emit(
            codes.PLOT,
            "`over` draws under an xy plot; this plot is over time",
            span,
            hint="remove `over`, or plot `xy: [x, y]`",
        )
        return (), None
    if owner not in components:
        bag.emit(
            codes.PLOT,
            f"plot reference `{plot.over}` names no component",
            span,
            hint=f"write {choices}",
        )
        return (), None
    if what not in (EXPECTED_PATH, MAP_REFERENCE):
        bag.emit(
            codes.PLOT,
            f"plot reference `{plot.over}`: `{what}` is neither the expected path nor the map",
            span,
            hint=f"write {choices}",
        )
        return (), None
    component = components[owner]
    scene = _scene_map(component, plot.over, span, bag, required=what == MAP_REFERENCE)
    if what == MAP_REFERENCE:
        return (), scene
    file = expected_path_file(component.path)
    if not file.is_file():
        bag.emit(
            codes.PLOT,
            f"component `{owner}` has no expected path: `{file.name}` is not next to "
            f"`{component.path.name}`",
            span,
            hint=f"write the path as a CSV with columns `x,y`, or draw `{owner}.{MAP_REFERENCE}`",
        )
        return (), scene
    try:
        points = read_expected_path(file)
    except PathFileError as exc:
        bag.emit(codes.PLOT, f"plot reference `{plot.over}`: {exc}", span)
        return (), scene
    return tuple((x, y) for x, y in points), scene


def _scene_map(
    component: Component, over: str, span: Span, bag: DiagnosticBag, *, required: bool
) -> SceneMap | None:
    """The map of ``component``'s world through its kind; None (E045 when ``required``) for
    a kind without one."""
    kind = COMPONENT_KINDS[component.kind]
    if MAP not in kind.capabilities or not isinstance(kind, MapSource):
        if required:
            bag.emit(
                codes.PLOT,
                f"component `{component.name}` ({component.kind}) has no map",
                span,
                hint="a map is the fixed landmarks of a simulator's scene",
            )
        return None
    try:
        return kind.scene_map(component.path)
    except ModelError as exc:
        bag.emit(codes.PLOT, f"plot reference `{over}`: the map cannot be read: {exc}", span)
        return None


def _file(
    plot: PlotSpec,
    index: int,
    texts: tuple[str, ...],
    taken: set[str],
    given: set[str],
    sources: SourceMap,
    bag: DiagnosticBag,
) -> str:
    """The plot's file name: ``file`` when given (checked: plain, once), else derived."""
    if plot.file is not None:
        span = sources.value(("plots", index, "file"))
        if (problem := plot_file_problem(plot.file)) is not None:
            bag.emit(
                codes.PLOT,
                f"plot file `{plot.file}`: {problem}",
                span,
                hint="give a name such as `trajectory.png`; `--out` chooses the folder",
            )
            return slug(plot.file) + ".png"
        name = with_suffix(plot.file)
        if name in given:
            bag.emit(
                codes.PLOT,
                f"plot file `{name}` is written by an earlier plot too",
                span,
                hint="give each plot a file of its own, or none (derived from the title)",
            )
        given.add(name)
        return name
    xy = (texts[0], texts[1]) if plot.xy is not None and len(texts) == 2 else None
    stem = derived_stem(plot.title, xy, texts, over=plot.over is not None)
    return unique_name(stem, taken)
