"""What a compile reads from a MuJoCo scene, kept between processes (``<cache>/mujoco-scenes``).

A compile asks a scene for its ports (:mod:`.interface`), its sites (a check's distance to
``world.site.B``) and its map (a plot drawn over the scene). Each answer needs MuJoCo to
compile the scene, and importing MuJoCo alone takes about a third of a second: most of a
``validate`` that the compile cache cannot serve (a system file just edited). Those answers
depend only on the scene's files, the MuJoCo install, the code that reads them and the limits
in force, so they are kept under a key of exactly those: the bytes of every file the scene is
shipped with (:func:`~.files.scene_files`, by their names in its folder), MuJoCo's installed
package (path, size and modification time of its files), fmionnx's reading modules, and the
``FMIONNX_*`` environment. A compile of an unchanged scene then reads them back without
importing MuJoCo. A run still loads the scene as before: it steps and renders it.

The checks made before MuJoCo reads a scene (its files stay in its folder, its cost is
bounded: :func:`~.interface.check_scene_before_loading`) run every time, kept or not. Only a
scene that loaded is kept; a failing one is read, and fails, every time. A site or map that
could not be read is not kept either: asked for, it is read from the scene again, and fails
as it did. Entries are kept as every kept answer is (:mod:`fmionnx.core.keptentries`): private,
signed with this user's key, ignored when they do not check out or do not decode, and bounded
in size and age as the compile cache is. ``FMIONNX_MUJOCO_FACTS=0`` turns the keeping off.
"""

from __future__ import annotations

import contextlib
import functools
from dataclasses import dataclass
from pathlib import Path

from fmionnx.core.datacodec import Codec
from fmionnx.core.keptentries import Entry, KeptAnswers, installed_package
from fmionnx.core.types import Port
from fmionnx.kinds.base import SceneMap, Site
from fmionnx.kinds.cache import code_stamps, module_files, sha256_file
from fmionnx.kinds.mujoco.scenememo import SceneMemo, stamped_now

#: The store: ``FMIONNX_MUJOCO_FACTS=0`` turns it off.
STORE = KeptAnswers(
    switch="FMIONNX_MUJOCO_FACTS",
    folder="mujoco-scenes",
    format="fmionnx-mujoco-scene-facts-1",
    max_bytes=16 << 20,
    file_name="facts.json",
)


@dataclass(frozen=True)
class SceneFacts:
    """What a compile reads from a scene: its ports without cameras, its named cameras, its
    facts, the compiled model's digest, its sites and its map (None: not readable, asked of
    the scene itself)."""

    ports: tuple[Port, ...]
    cameras: tuple[str, ...]
    facts: tuple[tuple[str, str], ...]
    digest: str
    sites: tuple[tuple[str, Site], ...] | None
    scene_map: SceneMap | None


#: How facts are written and read back (:mod:`fmionnx.core.datacodec`).
_CODEC = Codec("kept scene facts")

#: This process's answers, while the scene's files are unchanged (:mod:`.scenememo`, as
#: :func:`~.interface.load_model` keeps the loaded model): a compile asks for ports, sites
#: and map in turn.
_FACTS: SceneMemo[SceneFacts] = SceneMemo()


def scene_facts(path: Path) -> SceneFacts:
    """The facts of the scene at ``path``: kept ones when an entry checks out, else read with
    MuJoCo (and kept). Raises ModelError as loading the scene does."""
    if not path.is_file():
        return _read_scene(path)  # the error loading it gives
    found = _FACTS.get(path)
    if found is None:
        stamps, stamped_at = stamped_now(path)  # before reading (:mod:`.scenememo`)
        found = _kept_or_read(path)
        _FACTS.put(stamps, found, stamped_at)
    return found


def _kept_or_read(path: Path) -> SceneFacts:
    from fmionnx.kinds.mujoco.interface import check_scene_before_loading

    if not STORE.enabled() or path.suffix == ".mjb":
        return _read_scene(path)
    check_scene_before_loading(path)
    entry = _entry(path)
    if entry is not None:
        found = STORE.read_value(entry, _CODEC, SceneFacts)
        if found is not None:
            return found
    facts = _read_scene(path)
    if entry is not None:
        STORE.write_value(entry, _CODEC, facts)
    return facts


def _read_scene(path: Path) -> SceneFacts:
    """The facts, read from the scene with MuJoCo (errors as loading it raises them)."""
    from fmionnx.kinds.mujoco.interface import load_model, scene_ports
    from fmionnx.kinds.mujoco.scenemap import read_scene_map
    from fmionnx.kinds.mujoco.sites import read_sites

    model, digest = load_model(path)
    ports, cameras, facts = scene_ports(model)
    sites: tuple[tuple[str, Site], ...] | None = None
    scene_map: SceneMap | None = None
    with contextlib.suppress(Exception):  # asked for later, they are read (and fail) again
        sites = tuple(read_sites(path).items())
    with contextlib.suppress(Exception):
        scene_map = read_scene_map(path)
    return SceneFacts(tuple(ports), tuple(cameras), facts, digest, sites, scene_map)


def _entry(path: Path) -> Entry | None:
    """The scene's entry; None when its files or MuJoCo cannot be stamped."""
    from fmionnx.core.modelfiles import ShippingError
    from fmionnx.kinds.mujoco.files import scene_files

    code = _code_stamps()
    if code is None:
        return None
    try:
        files = [f"{f.name}:{sha256_file(f.source)}" for f in scene_files(path)]
    except (OSError, ShippingError, ValueError):
        return None
    return STORE.entry([path.name, *code, *files])


@functools.cache
def _code_stamps() -> tuple[str, ...] | None:
    """MuJoCo's installed package (found without importing it: that import is what an entry
    saves), and fmionnx's modules that read a scene and define what an entry holds."""
    from fmionnx.core import datacodec, keptentries, types, units
    from fmionnx.kinds import base
    from fmionnx.kinds.mujoco import interface, scenemap, sites

    package = installed_package("mujoco")
    if package is None:
        return None
    installed = [*sorted(package.glob("*.so")), package / "__init__.py"]
    # the readers, and the classes (and codec) an entry is written as: a field added to a
    # port must not be read back from an older entry as its default
    modules = (interface, scenemap, sites, types, units, base, datacodec, keptentries)
    return code_stamps(installed, [*module_files(*modules), Path(__file__)])
