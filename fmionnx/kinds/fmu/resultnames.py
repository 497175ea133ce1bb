"""A lone FMU's results named by its variables, as ``fmpy simulate`` names them."""

from __future__ import annotations

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
        prefix = f"{component.name}.{port.name}"
        if port.is_scalar:
            aliases[prefix] = port.name
            continue
        size = port.size or 1
        per_element = len(port.vrs) == size
        for i in range(size):
            fallback = f"{port.name}[{i}]"
            name = names.get(port.vrs[i], fallback) if per_element else fallback
            aliases[f"{prefix}[{i}]"] = name
    return aliases
