"""A signal's waveform numbers as settings a study can vary (``source.amplitude``).

Each output's waveform exposes its numbers under ``OUTPUT.FIELD`` (``v.amplitude``,
``v.frequency``; a constant's number is ``v.value``); a signal with one output also takes the
bare ``FIELD``. A new value goes through the same pydantic model the system file's entry went
through (finite numbers, a frequency from 0 to 10^12, a positive ramp duration), so a value
the system file would refuse is refused here with the same reason.
"""

from __future__ import annotations

import dataclasses

from pydantic import ValidationError

from fmionnx.core.diagnostics import did_you_mean, one_of
from fmionnx.core.types import Component, is_number
from fmionnx.kinds.base import SettingError, SettingInput
from fmionnx.kinds.signal.spec import OutputSpec
from fmionnx.kinds.signal.waveforms import (
    Constant,
    Ramp,
    RampTo,
    SignalConfig,
    Sine,
    Step,
    Waveform,
    waveform,
)

#: The system-file key of each waveform type (``ramp`` has two forms).
_KEYS: dict[type, str] = {
    Constant: "constant",
    Step: "step",
    Ramp: "ramp",
    RampTo: "ramp",
    Sine: "sine",
}


def _fields(wave: Waveform) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(wave))


def _config(component: Component) -> SignalConfig:
    config = component.config
    assert isinstance(config, SignalConfig)
    return config


def signal_settings(component: Component) -> tuple[str, ...]:
    """``OUTPUT.FIELD`` of every output's waveform, and bare ``FIELD`` for a lone output."""
    outputs = _config(component).outputs
    names = [f"{port}.{field}" for port, wave in outputs for field in _fields(wave)]
    if len(outputs) == 1:
        names = [*_fields(outputs[0][1]), *names]
    return tuple(names)


def _entry(wave: Waveform, field: str, value: float) -> dict[str, object]:
    """The system-file entry of ``wave`` with ``field`` at ``value``."""
    numbers = {f: getattr(wave, f) for f in _fields(wave)}
    numbers[field] = value
    key = _KEYS[type(wave)]
    if isinstance(wave, Constant):
        return {key: numbers["value"]}
    return {key: numbers}


def with_signal_setting(component: Component, name: str, value: SettingInput) -> SignalConfig:
    """The config with one waveform number changed, checked like the system file's entry."""
    config = _config(component)
    names = signal_settings(component)
    if name not in names:
        hint = did_you_mean(name, names) or one_of(names)
        if config.interpolation is not None:
            hint = "a table's values are not settings: only `outputs:` waveforms have settings"
        raise SettingError(f"`{component.name}` has no setting `{name}`; {hint}")
    port, _, field = name.rpartition(".")
    if not port:
        port = config.outputs[0][0]
    if not is_number(value):
        raise SettingError(f"`{name}` takes a number, got `{value}`")
    outputs = dict(config.outputs)
    try:
        spec = OutputSpec.model_validate(_entry(outputs[port], field, float(value)))
    except ValidationError as exc:
        first = exc.errors()[0]
        raise SettingError(f"{field} {value}: {first['msg']}") from None
    outputs[port] = waveform(spec)
    return dataclasses.replace(config, outputs=tuple(outputs.items()))
