"""The ``signal`` kind object: stimuli without a model file (see the package docstring)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from fmionnx.core import codes
from fmionnx.core.types import Causality, Component, ComponentInterface, DType, Port
from fmionnx.core.units import builtin_unit
from fmionnx.kinds.base import FILE_HASHED, Display, KindProblem, RoleDefault, SettingInput
from fmionnx.kinds.cache import cached_interface, file_identity
from fmionnx.kinds.signal.names import NAME
from fmionnx.kinds.signal.table import read_table, table_interface
from fmionnx.kinds.signal.waveforms import SignalConfig, waveform

if TYPE_CHECKING:  # the runner contract brings numpy: loaded when a runner is made
    from fmionnx.core.runner import Runner, Wiring
    from fmionnx.core.specbase import ComponentSpecBase


class SignalKind:
    """Stimuli defined in the system file (``outputs:``) or read from a CSV table."""

    name = NAME
    config_type = SignalConfig
    suffixes = (".csv",)
    summary = "stimuli: constant, step, ramp, sine, or a CSV table (no model file needed)"
    mime_type = "application/x-fmionnx-signal"
    capabilities: frozenset[str] = frozenset({FILE_HASHED})
    libraries: tuple[str, ...] = ()
    display = Display(
        "Signal",
        'shape=cds, style="filled", fillcolor="#fef3c7", color="#b45309"',
        ("[/", "/]"),
        "#fef3c7",
    )
    ros2_defaults: Mapping[tuple[str, str], RoleDefault] = {}

    @property
    def spec_model(self) -> type[ComponentSpecBase]:
        """The entry's pydantic model (:mod:`.spec`), loaded on first use."""
        from fmionnx.kinds.signal.spec import SignalSpec

        return SignalSpec

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """The entry's outputs, or the table's columns (cached per file identity).

        Without a table ``path`` is the system file (the entry is the model); ``spec`` None
        (``fmionnx inspect``) means ``path`` is a table. Raises ModelError (E010/E011/E012).
        """
        if spec is not None and not spec.has_model_file:
            return _outputs_interface(spec, path)
        if not path.is_file():
            read_table(path)  # raises the missing or not-a-file error
        key = (NAME, *file_identity(path))
        return cached_interface(key, path, lambda: table_interface(path))

    def check(
        self, spec: ComponentSpecBase, interface: ComponentInterface
    ) -> tuple[KindProblem, ...]:
        """An entry has ``outputs`` or a table, not both, not neither.

        Checked here rather than in the pydantic model so that each problem points at the key
        it is about.
        """
        from fmionnx.kinds.signal.spec import SignalSpec  # pydantic: loaded with the entry

        assert isinstance(spec, SignalSpec)
        if spec.has_model_file and spec.outputs:
            message = "has both `outputs:` and a table at `path:`"
            hint = "use one of them; two components give both"
            return (KindProblem(codes.INVALID_VALUE, message, "outputs", hint),)
        if not spec.has_model_file and not spec.outputs:
            message = "needs `outputs:` (waveforms by port name) or `path:` (a CSV table)"
            hint = "e.g. `outputs: {v: {step: {time: 1, final: 2}}}`"
            return (KindProblem(codes.MISSING_KEY, message, "kind", hint),)
        if not spec.has_model_file and "interpolation" in spec.model_fields_set:
            message = "`interpolation` applies to a table (`path:`), not to `outputs:`"
            return (KindProblem(codes.INVALID_VALUE, message, "interpolation"),)
        return ()

    def validate_model(self, path: Path, interface: ComponentInterface) -> tuple[KindProblem, ...]:
        """Nothing more: reading the interface parsed and checked the whole table."""
        return ()

    def resolve(self, spec: ComponentSpecBase, interface: ComponentInterface) -> SignalConfig:
        """The outputs' waveforms, or the table's interpolation."""
        from fmionnx.kinds.signal.spec import SignalSpec  # pydantic: loaded with the entry

        assert isinstance(spec, SignalSpec)
        if spec.has_model_file:
            return SignalConfig(interpolation=spec.interpolation)
        return SignalConfig(outputs=tuple((n, waveform(o)) for n, o in spec.outputs.items()))

    def repeat_problem(self, component: Component) -> str | None:
        """None: a signal's values are computed from the time, never accumulated."""
        return None

    def settings(self, component: Component) -> tuple[str, ...]:
        """The waveforms' numbers (``amplitude``, ``v.frequency``): see
        :mod:`fmionnx.kinds.signal.settings`."""
        from fmionnx.kinds.signal.settings import signal_settings

        return signal_settings(component)

    def with_setting(self, component: Component, name: str, value: SettingInput) -> SignalConfig:
        """The config with one waveform number changed (SettingError when refused)."""
        from fmionnx.kinds.signal.settings import with_signal_setting

        return with_signal_setting(component, name, value)

    def setting_hint(self, component: Component, name: str) -> str | None:
        """A table's values are not settings (only waveforms written in the entry are)."""
        config = component.config
        if isinstance(config, SignalConfig) and config.interpolation is not None:
            return "a table's values are not settings: only `outputs:` waveforms have settings"
        return None

    def make_runner(self, component: Component, wiring: Wiring) -> Runner:
        """A :class:`~fmionnx.kinds.signal.runner.SignalRunner` (numpy loads only now)."""
        from fmionnx.kinds.signal.runner import SignalRunner

        return SignalRunner(component)


def _outputs_interface(spec: ComponentSpecBase, path: Path) -> ComponentInterface:
    """The ports of an entry's ``outputs:`` waveforms."""
    from fmionnx.kinds.signal.spec import SignalSpec  # pydantic: loaded with the entry

    assert isinstance(spec, SignalSpec)
    ports = tuple(
        Port(
            name,
            Causality.OUTPUT,
            DType.FLOAT64,
            unit=output.unit,
            unit_definition=builtin_unit(output.unit),
            depends_on=(),
            description=waveform(output).text(),
        )
        for name, output in spec.outputs.items()
    )
    return ComponentInterface(NAME, path, ports)


SIGNAL_KIND = SignalKind()
