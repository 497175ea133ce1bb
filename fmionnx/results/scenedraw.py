"""A compiled scene map drawn under a trajectory: shapes in their colours, sites named.

The map was read through the component's kind at compile time (:class:`SceneMap`: plain
numbers), so nothing here knows which simulator made it. Shapes are drawn lowest first, as
seen from above, under everything else; a site is a marker in its own colour with its name
beside it; a shape the scene labels (a sign board's "turn left") is named in the legend, in its
colour. Every artist carries the landmark's name as its ``gid``, which keeps an SVG
readable and lets tests find what was drawn.
"""

from __future__ import annotations

from typing import Any

from fmionnx.kinds.base import Rgba, SceneMap

#: Layers, bottom to top: the map's shapes, the expected path, the run, then the sites' names.
SHAPE_LAYER = 1.0
SITE_LAYER = 4.0


def draw_scene(axes: Any, scene: SceneMap) -> None:
    """Draw ``scene`` on matplotlib ``axes`` (an xy plot in the scene's metres)."""
    from matplotlib.patches import Polygon

    legend: set[tuple[str, Rgba]] = set()
    for shape in scene.shapes:
        # a labelled landmark says what it means in the legend, once per label and colour
        key = (shape.label, shape.rgba) if shape.label else None
        label = shape.label if key is not None and key not in legend else None
        if key is not None:
            legend.add(key)
        patch = Polygon(
            shape.outline,
            closed=True,
            facecolor=_opaque(shape.rgba),
            edgecolor=_darker(shape.rgba),
            linewidth=1.2,  # a 4 cm sign board stays visible on a 10 m map
            zorder=SHAPE_LAYER,
            gid=shape.name,
            label=label if label is not None else "_nolegend_",
        )
        axes.add_patch(patch)
    for site in scene.sites:
        axes.plot(
            [site.x],
            [site.y],
            marker="o",
            markersize=9,
            markerfacecolor=_opaque(site.rgba),
            markeredgecolor="black",
            linestyle="none",
            zorder=SITE_LAYER,
            gid=f"site {site.name}",
        )
        axes.annotate(
            site.name,
            (site.x, site.y),
            xytext=(7, 7),
            textcoords="offset points",
            fontsize=12,
            fontweight="bold",
            zorder=SITE_LAYER,
            gid=f"site {site.name}",
        )


def _opaque(rgba: Rgba) -> Rgba:
    """The colour at least half opaque: a see-through landmark still reads on the map."""
    red, green, blue, alpha = rgba
    return (red, green, blue, max(alpha, 0.5))


def _darker(rgba: Rgba) -> Rgba:
    red, green, blue, _ = rgba
    return (red * 0.6, green * 0.6, blue * 0.6, 1.0)
