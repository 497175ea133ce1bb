"""Scene values a study can vary: positions of fixed bodies, a scene's ``<numeric>`` fields.

What a scene exposes is deliberately small and safe:

- ``body.NAME.pos`` (three numbers) and ``body.NAME.pos.x`` / ``.y`` / ``.z`` (one number):
  the position of a named body that is fixed to the world (no joint between it and the
  world, not a mocap body), relative to its parent as the scene's XML writes it. Moving a
  sign moves everything on it. A body that moves (the robot) is not offered: its position
  is the state of its joints, not a setting.
- ``numeric.NAME``: the numbers of a ``<custom><numeric name="NAME" .../>`` field, as many
  as its ``size``.

Sites are not offered on their own: a check's ``distance(..., to=world.site.B)`` uses the
site's position at compile time. The runner applies the values to the loaded ``MjModel``
before the first forward kinematics (:func:`apply_scene_values`), so the first step already
sees the moved bodies.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from fmionnx.core.diagnostics import did_you_mean, one_of
from fmionnx.kinds.base import SettingError, SettingInput

AXES = "xyz"


def scene_values(path: Path) -> dict[str, int]:
    """Every value the scene at ``path`` exposes, with how many numbers it takes (ModelError
    when the scene is unreadable)."""
    import mujoco

    from fmionnx.kinds.mujoco.interface import load_model
    from fmionnx.kinds.mujoco.sites import moving_body

    model, _ = load_model(path)  # shared and cached: read only
    values: dict[str, int] = {}
    for body in range(1, model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body)
        if name and moving_body(model, body) is None:
            values[f"body.{name}.pos"] = 3
            values.update({f"body.{name}.pos.{a}": 1 for a in AXES})
    for i in range(model.nnumeric):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_NUMERIC, i)
        if name:
            values[f"numeric.{name}"] = int(model.numeric_size[i])
    return values


def moving_body_hint(path: Path, name: str) -> str | None:
    """When ``name`` is ``body.NAME.pos...`` of a body that moves: why it is not a setting."""
    import mujoco

    from fmionnx.kinds.mujoco.interface import load_model
    from fmionnx.kinds.mujoco.sites import moving_body

    kind, _, rest = name.partition(".")
    body_name = rest.split(".pos", 1)[0]
    if kind != "body" or not body_name:
        return None
    model, _ = load_model(path)
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body_name)
    if body <= 0 or moving_body(model, body) is None:
        return None
    return (
        f"body `{body_name}` moves (a joint or mocap between it and the world): only bodies "
        "fixed to the world are scene values"
    )


def checked_value(path: Path, component: str, name: str, value: SettingInput) -> tuple[float, ...]:
    """``value`` as the numbers scene value ``name`` takes (SettingError when it does not fit)."""
    exposed = scene_values(path)
    size = exposed.get(name)
    if size is None:
        hint = moving_body_hint(path, name) or did_you_mean(name, exposed) or one_of(exposed)
        raise SettingError(f"the scene of `{component}` has no value `{name}`; {hint}")
    flat = value if isinstance(value, tuple) else (value,)
    numbers = tuple(
        float(v) for v in flat if isinstance(v, int | float) and not isinstance(v, bool)
    )
    if len(numbers) != len(flat) or len(numbers) != size:
        what = "one number" if size == 1 else f"{size} numbers"
        raise SettingError(f"`{name}` takes {what}, got `{_text(value)}`")
    if not all(math.isfinite(v) for v in numbers):
        raise SettingError(f"`{name}` takes finite numbers, got `{_text(value)}`")
    return numbers


def _text(value: SettingInput) -> str:
    return f"[{', '.join(str(v) for v in value)}]" if isinstance(value, tuple) else str(value)


def apply_scene_values(model: Any, values: tuple[tuple[str, tuple[float, ...]], ...]) -> None:
    """Write ``values`` into a freshly loaded ``model`` (this runner's own copy), in order.

    Raises KeyError naming a value the scene no longer has (the file changed since compiling).
    """
    import mujoco

    for name, numbers in values:
        kind, _, rest = name.partition(".")
        if kind == "numeric":
            index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, rest)
            if index < 0:
                raise KeyError(name)
            start = int(model.numeric_adr[index])
            model.numeric_data[start : start + len(numbers)] = numbers
            continue
        body_name, _, field = rest.rpartition(".pos")
        body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, body_name)
        if kind != "body" or body < 0:
            raise KeyError(name)
        if field:
            model.body_pos[body, AXES.index(field[1:])] = numbers[0]
        else:
            model.body_pos[body] = numbers
