"""A lone FMU's results named by its variables, as ``fmpy simulate`` names them."""

from __future__ import annotations

from fmionnx.core.signals import column_names
from fmionnx.core.types import Causality, Component


def result_aliases(component: Component) -> dict[str, str]:
    """Results column -> FMU variable name (FMI 2 arrays keep their scalar names ``x[1]``)."""
    names: dict[int, str] = {}
    try:
        from fmionnx.kinds.fmu.description import component_description
        from fmionnx.kinds.fmu.files import read_fmu_files

        md = component_description(
            component, lambda: read_fmu_files(component.path).model_description
        )
        names = {
            int(v.valueReference): str(v.name) for v in md.modelVariables if v.causality == "output"
        }
    except Exception:  # aliases are cosmetic; fall back to port names
        names = {}
    aliases = {}
    for port in component.interface.with_causality(Causality.OUTPUT):
        columns = column_names(component.name, port)  # results.csv's names, tensors included
        if port.is_scalar:
            aliases[columns[0]] = port.name
            continue
        per_element = len(port.vrs) == len(columns)
        for i, column in enumerate(columns):
            fallback = column.split(".", 1)[1]  # the port and its element, without the component
            aliases[column] = names.get(port.vrs[i], fallback) if per_element else fallback
    return aliases
