"""How an isolated component's child process starts, and the handle the supervisor keeps of it.

A child is forked by this process's zygote (:mod:`.zygote`, started on first use, one per
process) when it can be: the imports a child needs are then paid once per process instead of
once per child (about 0.26 s of CPU each). Where the zygote cannot be had -- no ``pidfd`` in
this kernel, or the zygote failed to start or to answer -- the child starts as a new
interpreter, ``python -m fmionnx.runtime.isolated.child``, as it always could; the run does not
depend on the zygote. Either way the supervisor gets a :class:`ChildProcess`, and either way
its waits block on a descriptor (a status pipe, a pidfd) rather than polling with sleeps.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import traceback
from pathlib import Path
from typing import Protocol

from fmionnx.core.forking import (
    HELPER_ENVIRONMENT,
    ForkedProcess,
    forked_helper,
    may_fork_helpers,
    single_threaded,
)
from fmionnx.core.processlocal import ProcessLocal
from fmionnx.runtime.isolated import zygote
from fmionnx.runtime.isolated.channel import readable

#: Seconds the zygote may take to import what children need (a loaded machine is slow).
ZYGOTE_START_TIMEOUT = 30.0
#: Seconds the zygote may take to answer a request (a fork).
ZYGOTE_ANSWER_TIMEOUT = 10.0
#: Seconds the zygote has to exit once its socket closed.
ZYGOTE_EXIT_TIMEOUT = 5.0


class ChildProcess(Protocol):
    """What the supervisor does with a child process (the subset of ``Popen`` it uses)."""

    @property
    def pid(self) -> int: ...

    def poll(self) -> int | None:
        """The exit code if the child has ended (minus the signal number for a signal)."""

    def wait(self, timeout: float | None = None) -> int:
        """The exit code, once the child has ended; ``subprocess.TimeoutExpired`` if it has
        not within ``timeout`` seconds."""

    def kill(self) -> None:
        """``SIGKILL`` the child (nothing if it has ended)."""


class SpawnedChild:
    """A child started as a new interpreter: ``Popen``, with waits on a pidfd."""

    def __init__(self, process: subprocess.Popen[bytes]) -> None:
        self._process = process
        self._pidfd = -1
        with contextlib.suppress(OSError, AttributeError):
            self._pidfd = os.pidfd_open(process.pid)

    @property
    def pid(self) -> int:
        return self._process.pid

    def poll(self) -> int | None:
        return self._process.poll()

    def wait(self, timeout: float | None = None) -> int:
        # Popen's own wait with a timeout polls with sleeps of up to 50 ms: a pidfd is
        # readable the moment the child ends.
        if (
            timeout is not None
            and self._pidfd >= 0
            and self._process.returncode is None
            and not readable(self._pidfd, timeout)
        ):
            raise subprocess.TimeoutExpired(self._process.args, timeout)
        code = self._process.wait(timeout)
        self._release()
        return code

    def kill(self) -> None:
        self._process.kill()

    def _release(self) -> None:
        if self._pidfd >= 0:
            os.close(self._pidfd)
            self._pidfd = -1

    def __del__(self) -> None:
        self._release()


class ForkedChild:
    """A child forked by the zygote: signalled through its pidfd, its exit code read from its
    status pipe (the zygote, its parent, reaps it)."""

    def __init__(self, pid: int, pidfd: int, status: int) -> None:
        self._pid = pid
        self._pidfd = pidfd
        self._status = status
        self.returncode: int | None = None

    @property
    def pid(self) -> int:
        return self._pid

    def poll(self) -> int | None:
        if self.returncode is None and readable(self._status, 0.0):
            self._collect()
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        if self.returncode is None:
            if not readable(self._status, timeout):
                raise subprocess.TimeoutExpired(f"isolated child {self._pid}", timeout or 0.0)
            self._collect()
        assert self.returncode is not None
        return self.returncode

    def kill(self) -> None:
        if self.returncode is None and self._pidfd >= 0:
            with contextlib.suppress(ProcessLookupError):
                signal.pidfd_send_signal(self._pidfd, signal.SIGKILL)

    def _collect(self) -> None:
        data = b""
        with contextlib.suppress(OSError):
            data = os.read(self._status, zygote.STATUS.size)
        if len(data) == zygote.STATUS.size:
            self.returncode = zygote.STATUS.unpack(data)[0]
        else:
            # The zygote died before it could report: its children die with it (SIGKILL).
            readable(self._pidfd, None)
            self.returncode = -int(signal.SIGKILL)
        self._release()

    def _release(self) -> None:
        for fd in (self._pidfd, self._status):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._pidfd = self._status = -1

    def __del__(self) -> None:
        self._release()


class ZygoteError(Exception):
    """The zygote did not start or did not answer; children start as new interpreters."""


class ZygoteNotReadyError(ZygoteError):
    """The zygote did not finish its start: this process does without one from then on."""


class Zygote:
    """This process's end of its zygote (see :mod:`.zygote`)."""

    def __init__(self, *, forked: bool = False) -> None:
        """Start the zygote as a new interpreter, or (``forked``) as a fork of this process,
        which must be single-threaded (:func:`fork_zygote`). A fork has this process's
        imports and adds what children need that it lacks; an interpreter imports all of it,
        about half a second of CPU."""
        if forked and not single_threaded():
            raise ZygoteError("a zygote is forked only from a single-threaded process")
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._socket = ours
        self._lock = threading.Lock()
        self._process: subprocess.Popen[bytes] | ForkedProcess
        try:
            self._process = _forked(ours, theirs) if forked else _started(theirs)
        except OSError as exc:
            ours.close()
            raise ZygoteError(f"could not start: {exc}") from exc
        finally:
            theirs.close()
        #: Whether the zygote said ``ready``; its imports go on meanwhile (see :func:`prestart`).
        self._ready = False

    def _await_ready(self) -> None:
        """Wait (once) until the zygote has imported what children need."""
        if self._ready:
            return
        if self._receive(ZYGOTE_START_TIMEOUT)[0] != zygote.READY:
            raise ZygoteNotReadyError("did not get ready")
        self._ready = True

    def launch(
        self, fds: tuple[int, int, int], argv: list[str], env: dict[str, str]
    ) -> ForkedChild:
        """Fork a child that serves on ``fds`` (command pipe, reply pipe, shared memory),
        in this process's working folder, with ``env`` as its environment."""
        try:
            folder = str(Path.cwd())
        except OSError as exc:  # removed meanwhile: a new interpreter inherits it as it is
            raise ZygoteError(f"no working folder to give the child: {exc}") from exc
        request = {"argv": argv, "cwd": folder, "env": env}
        with self._lock:
            self._await_ready()
            try:
                socket.send_fds(self._socket, [json.dumps(request).encode()], list(fds))
                message, received = self._receive(ZYGOTE_ANSWER_TIMEOUT)
            except OSError as exc:
                raise ZygoteError(f"did not take the request: {exc}") from exc
        if not message or len(received) != 2:
            for fd in received:
                os.close(fd)
            raise ZygoteError("did not answer")
        pid = json.loads(message)["pid"]
        return ForkedChild(int(pid), received[0], received[1])

    @property
    def pid(self) -> int:
        """The zygote's process id."""
        return self._process.pid

    def close(self) -> None:
        """End the zygote (its children are killed with it): it exits when its socket
        closes; killed if it has not within a few seconds."""
        self._socket.close()
        try:
            self._process.wait(ZYGOTE_EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()

    def _receive(self, timeout: float) -> tuple[bytes, list[int]]:
        if not readable(self._socket.fileno(), timeout):
            return b"", []
        message, fds, _, _ = socket.recv_fds(self._socket, zygote.MAX_REQUEST, 2)
        return message, fds


def _started(theirs: socket.socket) -> subprocess.Popen[bytes]:
    argv = [sys.executable, "-m", "fmionnx.runtime.isolated.zygote", str(theirs.fileno())]
    return subprocess.Popen(
        argv,
        pass_fds=(theirs.fileno(),),
        stdin=subprocess.DEVNULL,
        env=dict(os.environ, **HELPER_ENVIRONMENT),
    )


def _forked(ours: socket.socket, theirs: socket.socket) -> ForkedProcess:
    with forked_helper() as pid:
        if pid == 0:  # the zygote: never return into the caller
            code = 1
            try:
                ours.close()
                os.environ.update(HELPER_ENVIRONMENT)  # as a started one has it
                code = zygote.forked(theirs)
            except BaseException:
                traceback.print_exc()
            finally:
                os._exit(code)
        return ForkedProcess(pid, "zygote")


def fork_zygote() -> bool:
    """Fork this process's zygote now, if it has none and may have one: only while it is
    single-threaded (a study's worker as it starts, a command's process before it loads its
    models). False when it could not (the zygote is then started as a new interpreter)."""
    if not zygote_wanted() or _no_zygote.get() is not None or _zygote.get() is not None:
        return False
    try:
        made = Zygote(forked=True)  # not under the slot's lock: the fork would copy it held
    except ZygoteError:
        return False
    if _zygote.get_or_make(lambda: made) is not made:  # another thread's meanwhile
        made.close()
    return True


#: This process's zygote; a forked process (the guardian's child) starts its own.
_zygote: ProcessLocal[Zygote] = ProcessLocal()
#: This process could not start a zygote: do not try at every child again.
_no_zygote: ProcessLocal[bool] = ProcessLocal()


def zygote_pid() -> int | None:
    """The process id of this process's zygote, if it has one running."""
    made = _zygote.get()
    return None if made is None else made.pid


@atexit.register
def _close_zygote() -> None:
    """At exit, end this process's zygote rather than leave it to notice on its own."""
    zygote = _zygote.clear()
    if zygote is not None:
        zygote.close()


@functools.cache
def zygote_wanted() -> bool:
    """Whether children may be forked by a zygote here: it needs pidfds (Linux 5.3+), which
    Python may offer on a kernel that lacks them, so one is opened to find out."""
    if not (hasattr(os, "pidfd_open") and hasattr(signal, "pidfd_send_signal")):
        return False
    try:
        os.close(os.pidfd_open(os.getpid()))
    except OSError:
        return False
    return True


def prestart(*, fork: bool = True) -> None:
    """Start this process's zygote now, without waiting for it.

    Its imports (numpy, fmpy, the kinds' runners: about half a second) then run on another
    core while this process loads the models that stay in it (a MuJoCo scene and its GL
    context, an ONNX session), instead of after them, when the first isolated child is
    launched. In a ``fmionnx run`` command's process that has one thread the zygote is a
    fork of it (:mod:`fmionnx.core.forking`), which has the interpreter, numpy and fmionnx's
    modules already, unless ``fork`` is False; otherwise a new interpreter. Sandboxed
    models are forked from a new interpreter: a fork of the command holds what it compiled
    (every component's configuration), which a sandboxed model is not to see. The pipeline
    calls it before the run starts other helpers or threads
    (:meth:`~fmionnx.runtime.backend.Backend.start_helpers`), and the backend again as its
    run starts. Does nothing where no zygote can be had, or one is already there.
    """
    if not zygote_wanted() or _no_zygote.get() is not None:
        return
    if fork and may_fork_helpers() and fork_zygote():
        return
    try:
        _zygote.get_or_make(Zygote)
    except ZygoteError:
        _no_zygote.get_or_make(lambda: True)


def launch(fds: tuple[int, int, int], argv: list[str], env: dict[str, str]) -> ChildProcess:
    """Start a child serving on ``fds``: forked by the zygote, else a new interpreter.

    ``argv`` are the child's arguments after the descriptors; ``env`` its environment.
    Raises ``OSError`` when no process can be started at all.
    """
    for _ in range(2):  # a zygote found dead or deaf is replaced once
        if not zygote_wanted() or _no_zygote.get() is not None:
            break
        try:
            made = _zygote.get_or_make(Zygote)
        except ZygoteError:
            _no_zygote.get_or_make(lambda: True)
            break
        try:
            return made.launch(fds, argv, env)
        except ZygoteError as exc:
            if _zygote.clear() is made:
                made.close()
            if isinstance(exc, ZygoteNotReadyError):
                _no_zygote.get_or_make(lambda: True)
                break
    command = [sys.executable, "-m", "fmionnx.runtime.isolated.child", *map(str, fds), *argv]
    process = subprocess.Popen(command, pass_fds=fds, stdin=subprocess.DEVNULL, env=env)
    return SpawnedChild(process)
