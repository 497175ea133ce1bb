"""Read a MuJoCo scene's ports: named sensors, actuators, sites and the requested cameras.

Sensors, sites and cameras depend on no input within a step (actuators act through the
physics step), which is what lets a robot's feedback loop through the simulator be ordered
without an algebraic loop. Nothing is rendered here: validation needs no OpenGL.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from fmionnx.core import codes
from fmionnx.core.diagnostics import Span, did_you_mean, one_of, with_article
from fmionnx.core.errors import ModelError
from fmionnx.core.regularfile import regular_size
from fmionnx.core.resources import MODEL_FILE_BYTES
from fmionnx.core.types import Causality, ComponentInterface, DType, Port
from fmionnx.core.units import builtin_unit
from fmionnx.kinds.mujoco.budget import check_compiled_memory, check_scene_budget
from fmionnx.kinds.mujoco.files import check_scene_files, scene_files
from fmionnx.kinds.mujoco.library import mujoco_module
from fmionnx.kinds.mujoco.scenememo import SceneMemo, stamped_now

#: Units of sensor types whose quantity is unambiguous (mjtSensor names, lower case); every
#: name is a built-in unit (:data:`fmionnx.core.units.BUILTIN_UNITS`), so it has a definition.
_SENSOR_UNITS = {
    "framepos": "m",
    "jointpos": None,  # slide joints in m, hinges in rad: depends on the joint
    "velocimeter": "m/s",
    "gyro": "rad/s",
    "accelerometer": "m/s2",
    "framelinvel": "m/s",
    "frameangvel": "rad/s",
    "subtreecom": "m",
    "rangefinder": "m",
    "touch": "N",
    "force": "N",
    "torque": "N.m",
    "clock": "s",
}

#: Joint sensors whose unit follows the joint type: (sensor, mjtJoint name) -> unit.
_JOINT_UNITS = {
    ("jointpos", "hinge"): "rad",
    ("jointpos", "slide"): "m",
    ("jointvel", "hinge"): "rad/s",
    ("jointvel", "slide"): "m/s",
}


def _sensor_unit(model: Any, sensor: int, kind: str) -> str | None:
    """The unit of a sensor's value, when its type (and for joints, the joint type) fixes it."""
    if kind in ("jointpos", "jointvel"):
        import mujoco

        joint = int(model.sensor_objid[sensor])
        joint_type = mujoco.mjtJoint(int(model.jnt_type[joint])).name.removeprefix("mjJNT_")
        return _JOINT_UNITS.get((kind, joint_type.lower()))
    return _SENSOR_UNITS.get(kind)


#: This process's loaded scenes, while their files are unchanged (:mod:`.scenememo`).
_MODELS: SceneMemo[tuple[Any, str]] = SceneMemo()


def load_model(path: Path) -> tuple[Any, str]:
    """The compiled MjModel of the scene at ``path`` and the scene's content hash (cached)."""
    if not path.exists():
        msg = f"`{path}` does not exist"
        raise ModelError(codes.FILE_NOT_FOUND, msg)
    if not path.is_file():
        msg = f"`{path}` is a directory or special file, not a MuJoCo scene"
        raise ModelError(codes.NOT_A_FILE, msg)
    loaded = _MODELS.get(path)
    if loaded is None:
        stamps, stamped_at = stamped_now(path)  # before reading (:mod:`.scenememo`)
        mujoco = mujoco_module()
        check_scene_before_loading(path)  # right before MuJoCo reads it, MuJoCo imported
        try:
            if path.suffix == ".mjb":
                model = mujoco.MjModel.from_binary_path(str(path))
            else:
                model = mujoco.MjModel.from_xml_path(str(path))
        except ValueError as exc:
            text = " ".join(str(exc).split())
            msg = f"`{path}` is not a valid MuJoCo scene: {text}"
            raise ModelError(codes.BAD_MODEL, msg) from None
        check_compiled_memory(model, path)
        loaded = (model, _compiled_digest(model, path))
        _MODELS.put(stamps, loaded, stamped_at)
    return loaded


def check_scene_before_loading(path: Path) -> None:
    """Everything checked before MuJoCo reads the scene at ``path``: the files it names stay
    in its folder (E017) and are regular files, and what it would cost is bounded (E008,
    E011; :mod:`.budget`). A compiled ``.mjb`` is bounded by its file's size."""
    if path.suffix == ".mjb":
        regular_size(path, MODEL_FILE_BYTES, f"the MuJoCo model `{path.name}`")
        return
    check_scene_files(path)  # before anything the scene names is read
    check_scene_budget(path)


def _compiled_digest(model: Any, path: Path) -> str:
    """sha256 of the compiled model, so included files, meshes and textures count too.

    Hashing the XML alone would miss a changed ``<include>``d file or mesh; the compiled
    model holds all of it. (A MuJoCo upgrade may change the bytes: the lock then reports
    "model changed, same interface", which is true.) A model that read asset files also
    keeps their paths, which say where the scene's folder lies: such a scene is hashed as
    compiled from its files by their names inside the folder (:func:`_relocatable`), so that
    a copy elsewhere (``compile --models``, a sweep worker's store) has the same hash.
    """
    import mujoco
    import numpy as np

    if int(getattr(model, "npaths", 0)) > 0 and path.suffix != ".mjb":
        model = _relocatable(path)
    buffer = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()


def _relocatable(path: Path) -> Any:
    """The scene compiled from its text, with every file it names handed to MuJoCo by its
    name inside the scene's folder (MuJoCo's virtual file system): the asset paths the model
    keeps are then those names, the same wherever the folder lies."""
    import mujoco

    from fmionnx.core.modelfiles import ShippingError

    try:
        files = scene_files(path)
        assets = {f.name: f.source.read_bytes() for f in files if f.name != path.name}
        return mujoco.MjModel.from_xml_string(path.read_text(encoding="utf-8"), assets)
    except (OSError, UnicodeDecodeError, ValueError, ShippingError) as exc:
        msg = f"`{path}` cannot be read with the files it names: {exc}"
        raise ModelError(codes.BAD_MODEL, msg) from None


def read_mujoco_interface(
    path: Path, cameras: Mapping[str, tuple[int, int]] | None
) -> ComponentInterface:
    """Ports of the scene; ``cameras`` maps camera name -> (width, height) (None: all, 640x480).

    The scene's own ports and facts come from :func:`~.keptfacts.scene_facts` (kept in the
    cache folder: a compile of an unchanged scene does not import MuJoCo).
    """
    from fmionnx.kinds.mujoco.keptfacts import scene_facts

    facts = scene_facts(path)
    return interface_from(facts.ports, facts.cameras, facts.facts, facts.digest, path, cameras)


def scene_ports(model: Any) -> tuple[list[Port], list[str], tuple[tuple[str, str], ...]]:
    """The loaded scene's sensor, actuator and site ports, its named cameras and its facts."""
    import mujoco

    ports: list[Port] = []
    for i in range(model.nsensor):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SENSOR, i)
        if not name:
            continue
        dim = int(model.sensor_dim[i])
        kind = mujoco.mjtSensor(int(model.sensor_type[i])).name.removeprefix("mjSENS_").lower()
        unit = _sensor_unit(model, i, kind)
        ports.append(
            Port(
                name=name,
                causality=Causality.OUTPUT,
                dtype=DType.FLOAT64,
                shape=() if dim == 1 else (dim,),
                unit=unit,
                description=f"{kind} sensor",
                depends_on=(),
                unit_definition=builtin_unit(unit),
            )
        )
    for i in range(model.nu):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, i)
        if name:
            ports.append(_actuator_port(model, i, name))
    for i in range(model.nsite):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, i)
        if name:
            ports.append(
                Port(
                    f"{name}.pos",
                    Causality.OUTPUT,
                    DType.FLOAT64,
                    (3,),
                    unit="m",
                    description=f"world position of site {name}",
                    depends_on=(),
                    unit_definition=builtin_unit("m"),
                )
            )
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, i) for i in range(model.ncam)]
    names = [n for n in names if n]
    facts = (
        ("timestep", repr(float(model.opt.timestep))),
        ("nbody", str(model.nbody)),
        ("ngeom", str(model.ngeom)),
        ("cameras", ",".join(names)),
    )
    return ports, names, facts


def _actuator_port(model: Any, actuator: int, name: str) -> Port:
    """The input port of actuator ``actuator``, bounded by its ``ctrlrange`` where MuJoCo
    clamps to it.

    MuJoCo clamps a limited actuator's control (``ctrllimited``, or ``autolimits`` with a
    ``ctrlrange``: the compiled flag says which) to ``ctrlrange`` without a word, unless the
    scene disables ``clampctrl``. As the port's min/max, a value set outside it
    (``parameters:``, ``-p``, a study's values) is E043 as an FMU's is, not run as another
    value. Values arriving through connections at run time are clamped, as MuJoCo does.
    """
    import mujoco

    limited = bool(model.actuator_ctrllimited[actuator])
    low, high = (float(b) for b in model.actuator_ctrlrange[actuator])
    if not limited:
        return Port(name, Causality.INPUT, DType.FLOAT64, (), start=(0.0,), description="actuator")
    description = f"actuator, ctrlrange [{low:g}, {high:g}]"
    clamped = not int(model.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_CLAMPCTRL)
    if not clamped:
        description += " (not clamped: clampctrl is disabled)"
    return Port(
        name,
        Causality.INPUT,
        DType.FLOAT64,
        (),
        start=(0.0,),
        description=description,
        bounds=(low, high) if clamped else (None, None),
    )


def interface_from(
    scene: Sequence[Port],
    names: Sequence[str],
    facts: tuple[tuple[str, str], ...],
    digest: str,
    path: Path,
    cameras: Mapping[str, tuple[int, int]] | None,
) -> ComponentInterface:
    """The interface of the scene at ``path`` from its ports, camera names, facts and digest
    (:func:`scene_ports`), with a port per camera of ``cameras`` (None: each, 640x480)."""
    ports = list(scene)
    wanted = cameras if cameras is not None else dict.fromkeys(names, (640, 480))
    for camera, (width, height) in wanted.items():
        if camera not in names:
            hint = did_you_mean(camera, names) or one_of(names)
            msg = f"camera `{camera}` is not in the scene `{path.name}`"
            raise ModelError(codes.UNKNOWN_OPTION, msg, hint=hint)
        ports.append(
            Port(
                camera,
                Causality.OUTPUT,
                DType.UINT8,
                (height, width, 3),
                description=f"RGB image of camera {camera}",
                depends_on=(),
            )
        )
    _check_unique(ports, path)
    origin = Span(Path(path.name))
    ports = [dataclasses.replace(p, origin=origin) for p in ports]
    return ComponentInterface("mujoco", path, tuple(ports), facts, None, digest)


def _check_unique(ports: list[Port], path: Path) -> None:
    """MuJoCo names are unique per object type only; as ports they share one namespace."""
    seen: dict[str, str] = {}
    for port in ports:
        if port.name in seen:
            msg = (
                f"`{path.name}`: the name `{port.name}` is used by {with_article(seen[port.name])} and "
                f"{with_article(port.description)}; port names must be unique"
            )
            raise ModelError(codes.UNSUPPORTED_MODEL, msg, hint="rename one of them in the scene")
        seen[port.name] = port.description
