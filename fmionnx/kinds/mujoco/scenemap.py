"""The map of a MuJoCo scene: what a trajectory plot draws underneath, seen from above.

A map holds what stays where it is: named sites that never move (``A``, ``B``) and every
visible geom of a body that never moves (a sign board, a post, a wall) as its footprint on the
ground plane, in the colour the renderer gives it. Planes and height fields are the ground
itself and are left out; so are geoms in groups 3 to 5, which MuJoCo's viewer hides by
default (collision shapes, markers), and fully transparent ones. Anything on a body that can
move (the robot) is no landmark.

A scene says what a landmark means with a custom text named ``label:<geom name>``
(``<custom><text name="label:sign_left_board" data="turn left"/></custom>``, MuJoCo's own
element for user text): the shape carries it, and a trajectory plot's legend shows it in the
shape's colour.

Footprints are convex outlines of the geom's projection onto the ground plane, computed from
the geom's own shape at the initial configuration: a box's corners, the rims of a cylinder, the
ends of a capsule, a sphere's circle; a mesh by its bounding box. Coordinates are rounded to
the micrometre so that the compiled system stays short and stable.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from fmionnx.kinds.base import MapShape, MapSite, Rgba, SceneMap
from fmionnx.kinds.mujoco.interface import load_model
from fmionnx.kinds.mujoco.sites import moving_body

#: Geom groups MuJoCo renders by default; the others hold collision shapes and markers.
VISIBLE_GROUPS = range(3)
#: Points per circle when a round shape's outline is sampled.
CIRCLE_POINTS = 24
#: Decimal places kept (metres): micrometres.
DIGITS = 6
#: Most shapes a map keeps (the largest footprints): a map travels in the compiled system,
#: whose file size is bounded, and a scene of thousands of small static parts (a voxel
#: terrain) would not make a readable map anyway.
MAX_SHAPES = 2000
#: MuJoCo's default geom colour: a geom with a material and this colour shows the material's.
_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def read_scene_map(path: Path) -> SceneMap:
    """The sites and static visible shapes of the scene at ``path``."""
    import mujoco

    model, _ = load_model(path)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    sites = []
    for i in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i)
        if not name or moving_body(model, int(model.site_bodyid[i])) is not None:
            continue
        x, y = (round(float(v), DIGITS) for v in data.site_xpos[i][:2])
        sites.append(MapSite(name, x, y, _rgba(model.site_rgba[i])))
    labels = _labels(model, mujoco)
    shapes = []
    for i in range(model.ngeom):
        if not _is_landmark(model, i, mujoco):
            continue
        points = _surface_points(model, data, i, mujoco)
        if not points:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or f"geom {i}"
        outline = convex_hull([(round(x, DIGITS), round(y, DIGITS)) for x, y, _ in points])
        if len(outline) < 3:
            continue
        top = round(max(z for _, _, z in points), DIGITS)
        label = labels.get(name)
        shapes.append(MapShape(name, tuple(outline), _geom_rgba(model, i), top, label))
    if len(shapes) > MAX_SHAPES:
        largest = sorted(shapes, key=lambda shape: -area(shape.outline))[:MAX_SHAPES]
        shapes = [shape for shape in shapes if shape in largest]  # scene order kept
    shapes.sort(key=lambda shape: shape.top)  # stable: scene order among equal heights
    return SceneMap(tuple(sites), tuple(shapes))


#: Custom texts naming what a geom means on the map: ``label:<geom name>``.
LABEL_PREFIX = "label:"


def _labels(model: Any, mujoco: Any) -> dict[str, str]:
    """Geom name -> label, from the scene's ``<custom><text name="label:GEOM" data=...>``."""
    labels = {}
    for i in range(int(model.ntext)):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
        if not name.startswith(LABEL_PREFIX):
            continue
        start, size = int(model.text_adr[i]), int(model.text_size[i])
        text = bytes(model.text_data[start : start + size]).split(b"\0", 1)[0]
        label = text.decode("utf-8", errors="replace").strip()
        if label:
            labels[name.removeprefix(LABEL_PREFIX)] = label
    return labels


def _is_landmark(model: Any, geom: int, mujoco: Any) -> bool:
    """A visible geom, not the ground, on a body that never moves."""
    kind = int(model.geom_type[geom])
    if kind in (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD)):
        return False
    if int(model.geom_group[geom]) not in VISIBLE_GROUPS:
        return False
    if _geom_rgba(model, geom)[3] <= 0.0:
        return False
    return moving_body(model, int(model.geom_bodyid[geom])) is None


def _rgba(values: Any) -> Rgba:
    red, green, blue, alpha = (round(float(v), DIGITS) for v in values)
    return (red, green, blue, alpha)


def _geom_rgba(model: Any, geom: int) -> Rgba:
    """The colour the renderer shows: the geom's own, else its material's."""
    own = _rgba(model.geom_rgba[geom])
    material = int(model.geom_matid[geom])
    if material >= 0 and own == _DEFAULT_RGBA:
        return _rgba(model.mat_rgba[material])
    return own


def _surface_points(
    model: Any, data: Any, geom: int, mujoco: Any
) -> list[tuple[float, float, float]]:
    """Points of the geom's surface in world coordinates whose hull is its outline."""
    size = [float(v) for v in model.geom_size[geom]]
    kind = int(model.geom_type[geom])
    local: list[tuple[float, float, float]]
    ring = [
        (math.cos(2 * math.pi * k / CIRCLE_POINTS), math.sin(2 * math.pi * k / CIRCLE_POINTS))
        for k in range(CIRCLE_POINTS)
    ]
    if kind == int(mujoco.mjtGeom.mjGEOM_BOX):
        local = _corners(size[0], size[1], size[2], (0.0, 0.0, 0.0))
    elif kind == int(mujoco.mjtGeom.mjGEOM_CYLINDER):
        local = [(size[0] * c, size[0] * s, z) for z in (-size[1], size[1]) for c, s in ring]
    elif kind in (int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CAPSULE)):
        half = size[1] if kind == int(mujoco.mjtGeom.mjGEOM_CAPSULE) else 0.0
        return _rounded(data, geom, size[0], half, ring)
    elif kind == int(mujoco.mjtGeom.mjGEOM_ELLIPSOID):
        local = [
            (size[0] * math.sin(t) * c, size[1] * math.sin(t) * s, size[2] * math.cos(t))
            for t in (k * math.pi / 8 for k in range(9))
            for c, s in ring
        ]
    else:  # meshes and anything else: the geom's bounding box in its own frame
        box = [float(v) for v in model.geom_aabb[geom]]
        local = _corners(box[3], box[4], box[5], (box[0], box[1], box[2]))
    return [_to_world(data, geom, point) for point in local]


def _rounded(
    data: Any, geom: int, radius: float, half: float, ring: list[tuple[float, float]]
) -> list[tuple[float, float, float]]:
    """A sphere (``half`` 0) or capsule: a circle around each end point, seen from above."""
    points: list[tuple[float, float, float]] = []
    for end in (-half, half):
        x, y, z = _to_world(data, geom, (0.0, 0.0, end))
        points.extend((x + radius * c, y + radius * s, z + radius) for c, s in ring)
    return points


def _corners(
    sx: float, sy: float, sz: float, centre: tuple[float, float, float]
) -> list[tuple[float, float, float]]:
    cx, cy, cz = centre
    return [
        (cx + a * sx, cy + b * sy, cz + c * sz) for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)
    ]


def _to_world(
    data: Any, geom: int, point: tuple[float, float, float]
) -> tuple[float, float, float]:
    rotation = data.geom_xmat[geom].reshape(3, 3)
    position = data.geom_xpos[geom]
    x, y, z = (
        float(position[r] + sum(rotation[r][c] * point[c] for c in range(3))) for r in range(3)
    )
    return (x, y, z)


def convex_hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The convex hull of ``points``, counter-clockwise from the lowest-leftmost point
    (Andrew's monotone chain); collinear points are dropped."""
    unique = sorted(set(points))
    if len(unique) < 3:
        return unique

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    upper: list[tuple[float, float]] = []
    for point in unique:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], point) <= 0:
            lower.pop()
        lower.append(point)
    for point in reversed(unique):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], point) <= 0:
            upper.pop()
        upper.append(point)
    return lower[:-1] + upper[:-1]


def area(outline: tuple[tuple[float, float], ...]) -> float:
    """The area enclosed by a polygon (shoelace formula), in square metres."""
    total = 0.0
    for (x1, y1), (x2, y2) in zip(outline, outline[1:] + outline[:1], strict=True):
        total += x1 * y2 - x2 * y1
    return abs(total) / 2
