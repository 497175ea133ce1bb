"""``--sandbox`` confines what a model reads and which sockets it reaches, not only its writes.

The Probe test FMU (built from C) tries, in a system run the way a user runs a supplier's
models: reading an SSH key of the home folder (which is also the working folder), a secret
beside the system file and another component's model, listing the home folder, connecting to
a UNIX socket by path and by abstract name, forking. Each test runs the same system unconfined
first: the probe gets through there, so a sandbox that lets it through fails the test.
"""

from __future__ import annotations

import contextlib
import errno
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.security import probes

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="--sandbox confines on Linux")


@pytest.fixture
def home(tmp_path: Path) -> Path:
    """A home folder with an SSH key, as the attacker found one."""
    folder = tmp_path / "home"
    (folder / ".ssh").mkdir(parents=True)
    (folder / ".ssh" / "id_rsa").write_text("-----BEGIN OPENSSH PRIVATE KEY-----\n")
    return folder


def test_a_sandboxed_model_reads_nothing_outside_its_folder(
    fixture_fmu, tmp_path: Path, home: Path
) -> None:
    project = tmp_path / "project"
    project.mkdir()
    (project / "secret.txt").write_text("the secret beside the system file\n")
    gain = fixture_fmu("Gain")
    probe = fixture_fmu("Probe")
    targets = {
        "key": home / ".ssh" / "id_rsa",
        "beside": project / "secret.txt",
        "model": gain,  # another component's model
    }
    parameters = dict.fromkeys(targets, f"{{mode: {probes.READ}}}")
    parameters["home"] = f"{{mode: {probes.LIST}}}"
    parameters["own"] = f"{{mode: {probes.READ_OWN}}}"
    extra = f"  gain: {{kind: fmu, path: {gain}}}\n"
    system = probes.system(project, probe, parameters, extra=extra)
    env = {f"FMIONNX_PROBE_READ_{name}": str(path) for name, path in targets.items()}
    env["FMIONNX_PROBE_READ_home"] = str(home)
    env["HOME"] = str(home)
    free = probes.run(system, tmp_path / "free", env=env, cwd=home)
    assert free.code == 0, free.output
    assert all(free.outcomes[name] > 0 for name in parameters), free.outcomes  # the probe works
    confined = probes.run(system, tmp_path / "confined", "--sandbox", env=env, cwd=home)
    assert confined.code == 0, confined.output
    refused = {name: confined.outcomes[name] for name in [*targets, "home"]}
    assert refused == dict.fromkeys(refused, probes.REFUSED)
    assert confined.outcomes["own"] == free.outcomes["own"]  # its own folder stays readable


@contextlib.contextmanager
def _listener(address: str | bytes) -> Iterator[list[bytes]]:
    """A UNIX stream socket listening at ``address``; yields what clients sent."""
    received: list[bytes] = []
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(address)
    server.listen()
    server.settimeout(0.2)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                client, _ = server.accept()
            except TimeoutError:
                continue
            with client:
                received.append(client.recv(1024))

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield received
    finally:
        stop.set()
        thread.join()
        server.close()


@pytest.mark.parametrize("kind", ["path", "abstract"])
def test_a_sandboxed_model_reaches_no_unix_socket(fixture_fmu, tmp_path: Path, kind: str) -> None:
    """An SSH agent, Docker or X11 listen on UNIX sockets: none is reachable by path or by
    abstract name (the attacker's listener received its message)."""
    name = str(tmp_path / "agent.sock") if kind == "path" else f"fmionnx-probe-{tmp_path.name}"
    mode = probes.UNIX_CONNECT if kind == "path" else probes.ABSTRACT_CONNECT
    system = probes.system(tmp_path, fixture_fmu("Probe"), {"p": f"{{mode: {mode}}}"})
    env = {"FMIONNX_PROBE_SOCKET": name}
    with _listener(name if kind == "path" else b"\0" + name.encode()) as received:
        free = probes.run(system, tmp_path / "free", env=env)
        assert free.code == 0, free.output
        assert free.outcomes["p"] == 1.0
        confined = probes.run(system, tmp_path / "confined", "--sandbox", env=env)
    assert confined.code == 0, confined.output
    assert confined.outcomes["p"] == probes.REFUSED
    assert received == [b"reached by the Probe test FMU\n"]  # the unconfined run's only


def test_a_sandboxed_model_starts_no_process(fixture_fmu, tmp_path: Path) -> None:
    token = probes.Token()
    system = probes.system(tmp_path, fixture_fmu("Probe"), {"p": f"{{mode: {probes.FORK}}}"})
    try:
        confined = probes.run(system, tmp_path / "confined", "--sandbox", env=token.env)
        assert confined.code == 0, confined.output
        assert confined.outcomes["p"] == -float(errno.EPERM)
        assert token.processes() == []
    finally:
        token.end_all()
