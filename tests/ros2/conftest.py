"""ROS 2 test helpers: a hand-built compiled system shaped like the reference scenario, and a
loopback-only DDS environment on a random domain so parallel runs never see each other."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from fmionnx.backends.ros2.env import DdsEnvironment, from_environment
from fmionnx.compile.ir import CompiledSystem, Connection, RunSettings
from fmionnx.compile.ros2.messages import RosDistro
from fmionnx.compile.ros2.settings import ros2_settings
from fmionnx.core.types import Causality, Component, ComponentInterface, DType, Port, PortRef
from fmionnx.kinds.fmu.kind import FmuConfig
from fmionnx.kinds.mujoco.kind import MujocoConfig
from fmionnx.kinds.onnx.kind import OnnxConfig
from fmionnx.spec.model import Ros2Spec

SOURCE = Path("sign_follower.yaml")

#: One random domain per test session: parallel runs on this host do not cross-talk. Tests
#: also use the next one; in-process benchmark smoke tests use 210 and up (one process keeps
#: one Cyclone configuration per domain, so their ranges must not meet).
SESSION_DOMAIN = random.SystemRandom().randint(100, 199)


def _out(name: str, dtype: DType = DType.FLOAT64, shape: tuple[int | str, ...] = ()) -> Port:
    return Port(name, Causality.OUTPUT, dtype, shape)


def _in(name: str, dtype: DType = DType.FLOAT64, shape: tuple[int | str, ...] = ()) -> Port:
    return Port(name, Causality.INPUT, dtype, shape)


def _component(
    name: str, kind: str, ports: tuple[Port, ...], *, external: bool = False
) -> Component:
    configs = {"fmu": FmuConfig(), "onnx": OnnxConfig(), "mujoco": MujocoConfig()}
    path = Path(f"{name}.{kind}")
    interface = ComponentInterface(kind=kind, path=path, ports=ports)
    return Component(name, kind, path, interface, configs[kind], 0.01, 1, external=external)


def _connect(system_components: dict[str, Component], text: str, line: int) -> Connection:
    left, right = (part.strip() for part in text.split("->"))

    def ref(endpoint: str) -> tuple[PortRef, Port]:
        component, _, rest = endpoint.partition(".")
        port_name, _, index = rest.partition("[")
        port = system_components[component].port(port_name)
        idx = (int(index.rstrip("]")),) if index else None
        return PortRef(component, port_name, idx), port

    src, src_port = ref(left)
    dst, dst_port = ref(right)
    size = 1 if src.index is not None or dst.index is not None else (src_port.size or 1)
    from fmionnx.core.diagnostics import Span

    return Connection(src, dst, src_port, dst_port, size, span=Span(SOURCE, line, 5))


CONNECTIONS = (
    "world.base_quat[0] -> odometry.qw",
    "world.base_quat[1] -> odometry.qx",
    "world.base_quat[2] -> odometry.qy",
    "world.base_quat[3] -> odometry.qz",
    "world.base_pos[0] -> odometry.x",
    "world.base_pos[1] -> odometry.y",
    "world.front -> detector.image",
    "detector.blobX -> tracker.blobX",
    "detector.blobSize -> tracker.blobSize",
    "odometry.posX -> tracker.posX",
    "odometry.posY -> tracker.posY",
    "odometry.theta -> tracker.theta",
    "tracker.v -> world.cmd_v",
    "tracker.w -> world.cmd_w",
)


def make_system(ros2: Ros2Spec | None = None, *, world_external: bool = False) -> CompiledSystem:
    """The reference scenario's interfaces, built by hand (no model files needed)."""
    components = {
        "world": _component(
            "world",
            "mujoco",
            (
                _in("cmd_v"),
                _in("cmd_w"),
                _out("base_pos", shape=(3,)),
                _out("base_quat", shape=(4,)),
                _out("front", DType.UINT8, (480, 640, 3)),
            ),
            external=world_external,
        ),
        "odometry": _component(
            "odometry",
            "fmu",
            (
                *(_in(n) for n in ("qw", "qx", "qy", "qz", "x", "y")),
                _out("posX"),
                _out("posY"),
                _out("theta"),
            ),
        ),
        "detector": _component(
            "detector",
            "onnx",
            (
                _in("image", DType.UINT8, (1, 480, 640, 3)),
                _out("blobX", DType.FLOAT32, (1, 3)),
                _out("blobSize", DType.FLOAT32, (1, 3)),
            ),
        ),
        "tracker": _component(
            "tracker",
            "fmu",
            (
                _in("blobX", shape=(3,)),
                _in("blobSize", shape=(3,)),
                _in("posX"),
                _in("posY"),
                _in("theta"),
                _out("v"),
                _out("w"),
                _out("stopRobot", DType.BOOL),
            ),
        ),
    }
    connections = tuple(_connect(components, text, 20 + i) for i, text in enumerate(CONNECTIONS))
    return CompiledSystem(
        name="sign_follower",
        source=SOURCE,
        run=RunSettings(0.0, 1.0, 0.01),
        components=tuple(components.values()),
        connections=connections,
        order=("world", "odometry", "detector", "tracker"),
        ros2=ros2_settings(ros2) if ros2 is not None else None,
    )


@pytest.fixture
def reference_system() -> CompiledSystem:
    """The hand-built reference system without a ``ros2:`` section."""
    return make_system()


@pytest.fixture
def loopback_env(monkeypatch: pytest.MonkeyPatch) -> DdsEnvironment:
    """ROS_LOCALHOST_ONLY=1 on this session's random domain, also for child processes."""
    monkeypatch.setenv("ROS_DOMAIN_ID", str(SESSION_DOMAIN))
    monkeypatch.setenv("ROS_LOCALHOST_ONLY", "1")
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    monkeypatch.delenv("ROS_AUTOMATIC_DISCOVERY_RANGE", raising=False)
    return from_environment(RosDistro.HUMBLE)


#: A signal feeding the Gain test FMU (compiled from C): two nodes, no simulator.
NO_SIMULATOR = """
fmionnx: 1
name: hy
run: {{stop: 0.1, step: 0.01}}
components:
  my-src: {{kind: signal, outputs: {{v: {{constant: 2}}}}}}
  gain: {{kind: fmu, path: {gain}}}
connections:
  - my-src.v -> gain.u
"""


@pytest.fixture
def system(tmp_path: Path) -> Path:
    """:data:`NO_SIMULATOR` written to a file of the test's own."""
    from tests.conftest import build_fixture_fmu

    path = tmp_path / "hy.yaml"
    path.write_text(NO_SIMULATOR.format(gain=build_fixture_fmu("Gain")), encoding="utf-8")
    return path
