"""The named sites of a MuJoCo scene, as landmarks that checks measure distances to.

A site on the world body, or on a body welded to it with no joint in between, never moves:
its position after forward kinematics at the initial configuration is where it stays. A site
carried by a body that can move (a joint on the way to the world, or a mocap body) has no
fixed position; it is reported with the body's name, so the compiler can say why it cannot
serve as a fixed target.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fmionnx.kinds.base import Site
from fmionnx.kinds.mujoco.interface import load_model


def read_sites(path: Path) -> dict[str, Site]:
    """Every named site of the scene at ``path``, by name."""
    import mujoco

    model, _ = load_model(path)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    sites = {}
    for i in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i)
        if not name:
            continue
        x, y, z = (float(v) for v in data.site_xpos[i])
        body = int(model.site_bodyid[i])
        mover = moving_body(model, body)
        moves_with = None
        if mover is not None:
            moves_with = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, mover) or f"#{mover}"
        sites[name] = Site((x, y, z), moves_with)
    return sites


def moving_body(model: Any, body: int) -> int | None:
    """The body that makes ``body`` move (itself or an ancestor), or None when it is fixed."""
    if int(model.body_weldid[body]) != 0:  # a joint between it and the world
        return body
    current = body
    while current != 0:  # mocap bodies move without joints
        if int(model.body_mocapid[current]) != -1:
            return current
        current = int(model.body_parentid[current])
    return None
