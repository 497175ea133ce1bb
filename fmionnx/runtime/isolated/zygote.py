"""The zygote: one warm process per supervisor that forks isolated components' children.

``python -m fmionnx.runtime.isolated.zygote SOCKET``. Starting a child as a new Python
interpreter costs about 0.26 s of CPU (the interpreter, then numpy, pydantic, fmpy and the
kind's runner imported again) before the model is even loaded: in a sweep whose case runs two
isolated FMUs for 2 s, that was a fifth of the case's CPU. The zygote imports all of that once,
then forks a child per request: the child is the same code, already imported, in a process of
its own, as single-threaded as a fresh interpreter.

The protocol, on a ``SOCK_SEQPACKET`` socket pair with the supervisor (``launcher.py``):

- the zygote sends ``ready`` once its imports are done;
- a request is a JSON object ``{"argv", "cwd", "env"}`` with three descriptors attached (the
  child's command pipe, reply pipe and shared memory); the zygote forks, and answers
  ``{"pid": N}`` with two descriptors: a pidfd of the child (to signal it without any risk of
  hitting a reused pid) and the read end of a *status pipe*;
- when a child ends, the zygote reaps it and writes its exit code (``Popen`` convention: minus
  the signal number for a signal) as four bytes into that child's status pipe.

The zygote ends when the supervisor's end of the socket closes (the supervisor exited, or was
killed); its children then die with it (each asks Linux for ``SIGKILL`` when its parent dies,
as a directly started child does). It never runs a model itself.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import socket
import struct
import sys
import tempfile
import traceback
from typing import Any

from fmionnx.core.forking import close_all_but, flush_all
from fmionnx.runtime import lifetime

#: Largest request (JSON with the supervisor's environment) the zygote reads.
MAX_REQUEST = 1 << 20
#: The first message on the socket: the zygote has imported what children need.
READY = b"ready"
#: An exit code in a status pipe.
STATUS = struct.Struct("<i")


def warm_up() -> None:
    """Import what a child needs before it loads a model (the expensive part of its start)."""
    import fmionnx.runtime.isolated.server  # noqa: F401
    from fmionnx.kinds.registry import warm_up
    from fmionnx.runtime.isolated.handover import native_kernel

    warm_up()
    native_kernel()  # loaded and checked once, not in every child


def _be_child(request: dict[str, Any], fds: list[int]) -> int:
    """In the forked process: become an isolated child as ``python -m ...child`` would."""
    from fmionnx.runtime.isolated import child

    close_all_but(set(fds))
    signal.set_wakeup_fd(-1)
    signal.signal(signal.SIGCHLD, signal.SIG_DFL)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    tempfile.tempdir = None  # TMPDIR is the child's own scratch folder
    return child.main([*(str(fd) for fd in fds), *request["argv"]])


def _spawn(server: socket.socket, request: dict[str, Any], fds: list[int]) -> tuple[int, int]:
    """Fork a child for ``request``; answer its pid, pidfd and status pipe. Returns the pid
    and the status pipe's write end."""
    status_read, status_write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never return into the zygote's loop
        code = 1
        try:
            os.close(status_read)
            os.close(status_write)
            code = _be_child(request, fds)
        except BaseException:
            traceback.print_exc()
        finally:
            flush_all()
            os._exit(code)
    for fd in fds:
        os.close(fd)
    pidfd = os.pidfd_open(pid)
    try:
        socket.send_fds(server, [json.dumps({"pid": pid}).encode()], [pidfd, status_read])
    finally:
        os.close(pidfd)
        os.close(status_read)
    return pid, status_write


def _reap(statuses: dict[int, int]) -> None:
    """Write the exit code of every ended child into its status pipe.

    A child that ended before it could end the processes its model started left them to
    this process (a subreaper): they are ended first, so that a child reported ended has
    nothing left running (:mod:`fmionnx.runtime.lifetime`).
    """
    ended: list[tuple[int, int]] = []
    while True:
        try:
            pid, status = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            break
        if pid == 0:
            break
        ended.append((pid, status))
    if not ended:
        return
    lifetime.end_adopted(statuses)
    for pid, status in ended:
        write = statuses.pop(pid, None)
        if write is None:
            continue  # an adopted orphan, reaped
        try:
            os.write(write, STATUS.pack(os.waitstatus_to_exitcode(status)))
        except OSError:
            pass  # the supervisor no longer listens for it
        finally:
            os.close(write)


def serve(server: socket.socket) -> None:
    """Fork children on request until the supervisor's end of ``server`` closes."""
    wake_read, wake_write = os.pipe()
    os.set_blocking(wake_read, False)
    os.set_blocking(wake_write, False)
    signal.set_wakeup_fd(wake_write)
    signal.signal(signal.SIGCHLD, lambda signum, frame: None)  # the wake-up byte is the news
    statuses: dict[int, int] = {}
    poller = select.poll()
    poller.register(server, select.POLLIN)
    poller.register(wake_read, select.POLLIN)
    server.send(READY)
    while True:
        events = dict(poller.poll())
        if wake_read in events:
            while True:
                try:
                    if not os.read(wake_read, 512):
                        break
                except BlockingIOError:
                    break
            _reap(statuses)
        if server.fileno() not in events:
            continue
        message, fds, _, _ = socket.recv_fds(server, MAX_REQUEST, 3)
        if not message:
            return  # the supervisor is gone
        if len(fds) != 3:
            for fd in fds:
                os.close(fd)
            continue
        pid, status_write = _spawn(server, json.loads(message), fds)
        statuses[pid] = status_write


def main(argv: list[str]) -> int:
    """``zygote SOCKET`` (an inherited descriptor)."""
    return _run(socket.socket(fileno=int(argv[0])))


def forked(server: socket.socket) -> int:
    """Be the zygote in a process just forked from its supervisor (``launcher``'s
    ``Zygote(forked=True)``), which was single-threaded (its numpy with one BLAS thread): a
    study's worker forked by the fork server, :mod:`..sweep.workerboot`, with :func:`warm_up`
    done; or a command's process before it loads its models, whose imports :func:`warm_up`
    completes here.

    A forked zygote holds copies of its supervisor's descriptors: it keeps only ``server``
    and the standard three (a pipe end kept open here would hide the supervisor's death from
    whoever watches that pipe). It ends as a started one does, when the supervisor's end of
    the socket closes (the supervisor exited or was killed), ending its children and what
    their models started on the way out; no death signal, which would kill it before that.
    """
    close_all_but({server.fileno()})
    _no_input()
    return _run(server)


def _no_input() -> None:
    """Standard input from ``/dev/null``, as a started zygote has it: a model must not read
    the command's (a terminal, or the input of a shell loop that runs fmionnx)."""
    nothing = os.open(os.devnull, os.O_RDONLY)
    if nothing != 0:
        os.dup2(nothing, 0)
        os.close(nothing)


def _run(server: socket.socket) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the supervisor's to handle
    lifetime.set_subreaper(True)  # adopts what a child's model leaves when the child dies
    warm_up()
    try:
        with contextlib.suppress(BrokenPipeError, ConnectionResetError):
            serve(server)  # either way it ends when the supervisor goes away
    finally:
        lifetime.end_descendants()  # its children, and whatever their models started
    return 0


if __name__ == "__main__":
    code = main(sys.argv[1:])
    # The supervisor waits for this exit at the end of every run; tearing down the
    # interpreter (numpy, pydantic, the kinds) would add about a tenth of a second to it, and
    # nothing is left to flush or free: the children have ended and been reaped.
    flush_all()
    os._exit(code)
