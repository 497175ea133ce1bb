"""MuJoCo runner: physics at the model's timestep, sensors out, actuators in, cameras rendered.

One component step of period ``h`` is ``k = h / timestep`` physics steps (checked at setup).
Stepping uses MuJoCo's split ``mj_step2`` (actuation, acceleration, integration) then
``mj_step1`` (kinematics, position/velocity sensors of the *new* state), so sensor outputs
after a step belong to time ``t + h`` at no extra cost. Sensor outputs are zero-copy views of
``MjData.sensordata``. Cameras are lazy outputs: rendered offscreen only when a consumer is
due. A NaN/Inf state or one of MuJoCo's bad-state warnings (which MuJoCo answers by silently
resetting the simulation) stops the run.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fmionnx.core.errors import RunError
from fmionnx.core.runner import Buffer, fault
from fmionnx.core.types import Causality, Component, is_whole_multiple
from fmionnx.kinds.kept import Kept
from fmionnx.kinds.mujoco.gl import choose_gl, forget_probe
from fmionnx.kinds.mujoco.kind import CameraConfig, MujocoConfig


@dataclass
class _Scene:
    """A loaded scene and its cameras' offscreen renderers (GL contexts with the scene's
    textures and meshes), kept between runs of a study's worker (:mod:`fmionnx.kinds.kept`).
    Each run makes its own ``MjData``: the state starts from the model as loaded."""

    model: Any
    renderers: dict[str, Any] = field(default_factory=dict)

    def close(self) -> None:
        for renderer in self.renderers.values():
            with contextlib.suppress(Exception):
                renderer.close()
        self.renderers.clear()


def _close_scene(scene: _Scene) -> None:
    scene.close()


#: Scenes kept by a study's worker, by file and cameras (:func:`keep_scenes`).
SCENES: Kept[tuple[object, ...], _Scene] = Kept(_close_scene)


def keep_scenes() -> None:
    """From now on, this process keeps a cleanly ended run's scene and GL contexts for the
    next run of the same scene (a study's worker)."""
    SCENES.enable()


class MujocoRunner:
    """Runs one MuJoCo scene."""

    def __init__(self, component: Component) -> None:
        self.component = component
        assert isinstance(component.config, MujocoConfig)
        self.config = component.config
        self._camera_specs: dict[str, CameraConfig] = {c.name: c for c in self.config.cameras}
        self.lazy_outputs: frozenset[str] = frozenset(self._camera_specs)
        self._mj: Any = None
        self._model: Any = None
        self._data: Any = None
        self._inputs: dict[str, Buffer] = {}
        self._outputs: dict[str, Buffer] = {}
        self._renderers: dict[str, Any] = {}
        self._frames: dict[str, Buffer] = {}
        self._ctrl_ids: list[tuple[int, Buffer]] = []
        self._substeps = 1
        self._split = True
        self._time = 0.0
        #: The scene kept from an earlier run (or to be kept after this one), and its key.
        self._scene: _Scene | None = None
        self._key: tuple[object, ...] | None = None
        self._broken = False

    def _scene_key(self) -> tuple[object, ...] | None:
        """What a kept scene must be to serve this run (None: never one): the same file, as
        compiled, with the same cameras, and no scene values set by the run (they change the
        loaded model)."""
        if not SCENES.enabled or self.config.scene_values:
            return None
        path = self.component.path
        try:
            info = path.stat()
        except OSError:
            return None
        cameras = tuple((c.name, int(c.width), int(c.height)) for c in self.config.cameras)
        identity = (str(path.resolve()), info.st_mtime_ns, info.st_size)
        return (*identity, self.component.interface.content_hash, self.config.gl, cameras)

    def instantiate(self) -> None:
        """Choose the GL backend (only when cameras are used), load the scene (or take the
        one a study's worker kept from an earlier run of it)."""
        if self._camera_specs:
            try:
                choose_gl(self.config.gl)
            except RuntimeError as exc:
                raise fault(self.component.name, str(exc), time=0.0) from None
        from fmionnx.core.errors import ModelError
        from fmionnx.kinds.mujoco.budget import check_compiled_memory
        from fmionnx.kinds.mujoco.interface import check_scene_before_loading
        from fmionnx.kinds.mujoco.library import mujoco_module

        mujoco = mujoco_module()
        self._mj = mujoco
        self._key = self._scene_key()
        self._scene = SCENES.take(self._key) if self._key is not None else None
        if self._scene is not None:
            self._model = self._scene.model
            self._data = mujoco.MjData(self._model)
            return
        path = str(self.component.path)
        try:  # the file may have changed since it was compiled
            check_scene_before_loading(self.component.path)
        except (ModelError, OSError) as exc:
            hint = f" ({exc.hint})" if isinstance(exc, ModelError) and exc.hint else ""
            msg = f"cannot load the scene: {exc}{hint}"
            raise fault(self.component.name, msg, time=0.0) from None
        try:
            if path.endswith(".mjb"):
                self._model = mujoco.MjModel.from_binary_path(path)
            else:
                self._model = mujoco.MjModel.from_xml_path(path)
        except Exception as exc:
            raise fault(self.component.name, f"cannot load the scene: {exc}", time=0.0) from None
        if self._key is not None:
            self._scene = _Scene(self._model)
        if self.config.scene_values:
            from fmionnx.kinds.mujoco.scenevalues import apply_scene_values

            try:
                apply_scene_values(self._model, self.config.scene_values)
            except KeyError as exc:
                msg = f"the scene has no value {exc} any more (it changed since compiling)"
                raise fault(self.component.name, msg, time=0.0) from None
        try:
            check_compiled_memory(self._model, self.component.path)
        except ModelError as exc:
            raise fault(self.component.name, f"{exc} ({exc.hint})", time=0.0) from None
        self._data = mujoco.MjData(self._model)

    def setup(self, start: float, stop: float) -> None:
        """Bind ports to actuators/sensors/cameras, apply start values, compute the first state."""
        mj, model, data = self._mj, self._model, self._data
        name = self.component.name
        timestep = float(model.opt.timestep)
        substeps = is_whole_multiple(self.component.period, timestep)
        if substeps is None:
            msg = (
                f"period {self.component.period} s is not a whole multiple of the scene's "
                f"timestep {timestep} s"
            )
            raise fault(name, msg, time=start)
        self._substeps = substeps
        self._split = int(model.opt.integrator) != int(mj.mjtIntegrator.mjINT_RK4)
        data.time = start
        explicit = {p.port: p.value for p in self.component.parameters}
        for port in self.component.interface.with_causality(Causality.INPUT):
            actuator = mj.mj_name2id(model, mj.mjtObj.mjOBJ_ACTUATOR, port.name)
            if actuator < 0:
                raise fault(
                    name, "no actuator of this name in the scene", time=start, port=port.name
                )
            buffer = np.zeros(1, dtype=np.float64)
            value = explicit.get(port.name, port.start)
            if value is not None:
                buffer[:] = np.asarray(value, dtype=np.float64).reshape(-1)[:1]
            self._inputs[port.name] = buffer
            self._ctrl_ids.append((actuator, buffer))
        for port in self.component.interface.with_causality(Causality.OUTPUT):
            if port.name in self._camera_specs:
                self._add_camera(port.name, start)
                continue
            if port.name.endswith(".pos"):
                site = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SITE, port.name.removesuffix(".pos"))
                if site >= 0:
                    # A row view of site_xpos: MuJoCo updates it in place at every step.
                    self._outputs[port.name] = data.site_xpos[site]
                    continue
            sensor = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SENSOR, port.name)
            if sensor < 0:
                raise fault(
                    name, "no sensor, site or camera of this name", time=start, port=port.name
                )
            adr, dim = int(model.sensor_adr[sensor]), int(model.sensor_dim[sensor])
            self._outputs[port.name] = data.sensordata[adr : adr + dim]
        self._apply_ctrl()
        try:
            mj.mj_forward(model, data)
        except mj.FatalError as exc:
            raise self._stopped(exc, start) from None
        self._warnings = self._warning_count()

    def _stopped(self, error: Exception, t: float) -> RunError:
        """The fault of a MuJoCo call that stopped with a fatal error (its arena too small
        for the model: ``<size memory>``; found by fuzzing: it was a traceback)."""
        text = " ".join(str(error).split())
        hint = " (raise the scene's `<size memory>`)" if "out of memory" in text else ""
        return fault(self.component.name, f"MuJoCo stopped: {text}{hint}", time=t)

    def _add_camera(self, port: str, start: float) -> None:
        mj, model = self._mj, self._model
        camera = self._camera_specs[port]
        width, height = int(camera.width), int(camera.height)
        if mj.mj_name2id(model, mj.mjtObj.mjOBJ_CAMERA, port) < 0:
            raise fault(self.component.name, "no camera of this name", time=start, port=port)
        model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
        model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
        renderer = self._scene.renderers.get(port) if self._scene is not None else None
        if renderer is None:
            try:
                renderer = mj.Renderer(model, height, width)
            except Exception as exc:
                forget_probe(self.config.gl)  # a kept answer may be stale: probe next time
                raise fault(
                    self.component.name, f"offscreen rendering failed: {exc}", time=start, port=port
                ) from None
            if self._scene is not None:
                self._scene.renderers[port] = renderer
        self._renderers[port] = renderer
        frame = np.zeros((height, width, 3), dtype=np.uint8)
        self._frames[port] = frame
        self._outputs[port] = frame.reshape(-1)

    def input_buffer(self, port: str) -> Buffer:
        """Flat one-element buffer of an actuator's control."""
        return self._inputs[port]

    def output_buffer(self, port: str) -> Buffer:
        """A sensor's slice of ``sensordata`` or a camera's flat frame."""
        return self._outputs[port]

    def _apply_ctrl(self) -> None:
        ctrl = self._data.ctrl
        for index, buffer in self._ctrl_ids:
            ctrl[index] = buffer[0]

    def _warning_count(self) -> int:
        warning = self._data.warning
        mjw = self._mj.mjtWarning
        return int(
            warning[mjw.mjWARN_BADQACC].number
            + warning[mjw.mjWARN_BADQPOS].number
            + warning[mjw.mjWARN_BADQVEL].number
        )

    def step(self, t: float, h: float) -> None:
        """``k`` physics steps with the held controls; then check the state is sane."""
        mj, model, data = self._mj, self._model, self._data
        self._apply_ctrl()
        try:
            if self._split:
                for _ in range(self._substeps):
                    mj.mj_step2(model, data)
                    mj.mj_step1(model, data)
            else:
                for _ in range(self._substeps):
                    mj.mj_step(model, data)
                mj.mj_forward(model, data)
        except mj.FatalError as exc:
            raise self._stopped(exc, t) from None
        count = self._warning_count()
        if count != self._warnings or not np.isfinite(data.qpos).all():
            self._warnings = count
            raise fault(
                self.component.name,
                "the physics became unstable (NaN/Inf or bad qpos/qvel/qacc; MuJoCo reset the "
                "state); check masses, gains and the timestep",
                time=t + h,
            )

    def produce(self, port: str) -> None:
        """Render camera ``port`` for the current state into its frame buffer."""
        renderer = self._renderers[port]
        self._broken = True  # until the frame is done: a failed render keeps nothing
        renderer.update_scene(self._data, camera=port)
        renderer.render(out=self._frames[port])
        self._broken = False

    def terminate(self) -> None:
        """Free the renderers' GL contexts, or give the scene and its renderers back for the
        next run of the scene (a study's worker; only when every frame was rendered)."""
        scene, self._scene = self._scene, None
        if scene is not None and self._key is not None and not self._broken:
            self._renderers.clear()
            SCENES.give(self._key, scene)
            return
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
        if scene is not None:
            scene.renderers.clear()  # closed just now (the same objects)
