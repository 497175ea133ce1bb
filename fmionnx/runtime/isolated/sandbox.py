"""Confinement of an isolated model's process (``--sandbox``), with what Linux gives unprivileged.

Applied by the child to itself before it loads the model, irreversible, and inherited by
anything it could start:

- **files** (Landlock, Linux 5.13+): writing only beneath the model's scratch folder (where
  the FMU is unpacked); reading only that folder, the model file, and what the process needs
  to run at all (:func:`readable_roots`: the Python installation and its packages, fmionnx,
  the system's shared libraries, a few files of ``/proc/self``, ``/sys`` and ``/dev``);
  nothing else, not even a listing: not the working folder, not the home folder, not the
  system file's folder nor the other models;
- **sockets** (seccomp, a system-call filter): no UNIX socket can be made, so no local
  service (an SSH agent, Docker, X11, D-Bus) can be reached by path or by abstract name, nor
  any other socket family than IPv4 and IPv6 (netlink, raw packets, vsock to a hypervisor);
- **network**: a new user and network namespace (``unshare``), which has no interface but a
  loopback that is down; where user namespaces are disabled, Landlock's TCP rules (ABI 4)
  deny TCP connect and bind, and seccomp refuses IPv4 and IPv6 sockets altogether;
- **processes** (seccomp): the model can start no process and run no program (``fork``,
  ``vfork``, ``clone`` of a process, ``execve``: refused); threads work;
- **IPC** (Landlock scopes, ABI 6): no signal to a process outside the sandbox, no abstract
  UNIX socket of one (seccomp already refuses the socket: a second wall).

What the kernel cannot provide is reported as a problem and the run refuses to start: a user
who asked for a sandbox must not get less without knowing. ``docs/security.md`` lists, per
kernel capability, what is confined.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import platform
import site
import struct
import sys
import sysconfig
from dataclasses import dataclass
from pathlib import Path

_SYS_CREATE_RULESET, _SYS_ADD_RULE, _SYS_RESTRICT_SELF = 444, 445, 446
_CREATE_RULESET_VERSION = 1
_RULE_PATH_BENEATH = 1
_PR_SET_NO_NEW_PRIVS, _PR_SET_SECCOMP, _SECCOMP_MODE_FILTER = 38, 22, 2
_CLONE_NEWUSER, _CLONE_NEWNET = 0x10000000, 0x40000000

# Landlock file-system rights (by ABI version: 1 has bits 0-12, 2 adds REFER, 3 TRUNCATE,
# 5 IOCTL_DEV), network rights (ABI 4) and scopes (ABI 6).
_EXECUTE, _WRITE_FILE, _READ_FILE, _READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
_FS_BITS_BY_ABI = {1: 13, 2: 14, 3: 15, 4: 15}
_NET_BIND_TCP, _NET_CONNECT_TCP = 1 << 0, 1 << 1
_SCOPE_ABSTRACT_UNIX_SOCKET, _SCOPE_SIGNAL = 1 << 0, 1 << 1
_FILE_RIGHTS = _EXECUTE | _WRITE_FILE | _READ_FILE | (1 << 14) | (1 << 15)
#: The first ABI with scopes.
_SCOPES_ABI = 6

#: Folders and files every process needs to read: shared libraries and the loader's cache,
#: its own ``/proc`` entries, the CPUs the C library, BLAS and ONNX Runtime look at, the
#: kernel's random source; what the model may read and write of ``/dev`` is ``/dev/null`` alone.
SYSTEM_READABLE = (
    "/usr",
    "/lib",
    "/lib64",
    "/lib32",
    "/etc/ld.so.cache",
    "/proc/self",
    "/proc/cpuinfo",
    "/sys/devices/system/cpu",
    "/dev/urandom",
)


class _PathBeneath(ctypes.Structure):
    _pack_ = 1
    _fields_ = (("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32))


class _SockFilter(ctypes.Structure):
    _fields_ = (
        ("code", ctypes.c_uint16),
        ("jt", ctypes.c_uint8),
        ("jf", ctypes.c_uint8),
        ("k", ctypes.c_uint32),
    )


class _SockFprog(ctypes.Structure):
    _fields_ = (("len", ctypes.c_uint16), ("filter", ctypes.POINTER(_SockFilter)))


class SandboxUnavailableError(Exception):
    """The kernel cannot confine the process as asked; the message says what is missing."""


def _libc() -> ctypes.CDLL:
    libc = ctypes.CDLL(None, use_errno=True)
    libc.syscall.restype = ctypes.c_long
    return libc


def landlock_abi() -> int:
    """The kernel's Landlock ABI version (0: Landlock is missing or disabled)."""
    result = _libc().syscall(_SYS_CREATE_RULESET, None, ctypes.c_size_t(0), _CREATE_RULESET_VERSION)
    return max(int(result), 0)


def _no_network() -> bool:
    """Enter a network namespace of our own; False where user namespaces are not allowed."""
    return bool(_libc().unshare(_CLONE_NEWUSER | _CLONE_NEWNET) == 0)


# -- what may be read --------------------------------------------------------------------------


def _python_roots() -> list[Path]:
    """The Python installation this process runs: its standard library (with the extension
    modules), its ``lib`` folder (``libpython``), the environment's and the user's package
    folders, and the zip archives on ``sys.path`` inside them. Never the working folder nor
    another folder ``sys.path`` happens to name (``python -m`` puts the working folder first)."""
    roots: list[Path] = []
    for scheme_vars in ({}, {"base": sys.base_prefix, "platbase": sys.base_exec_prefix}):
        paths = sysconfig.get_paths(vars=scheme_vars) if scheme_vars else sysconfig.get_paths()
        roots += [Path(paths[key]) for key in ("stdlib", "platstdlib", "purelib", "platlib")]
    library = sysconfig.get_config_var("LIBDIR")
    if isinstance(library, str):
        roots.append(Path(library))
    roots += [Path(p) for p in site.getsitepackages()]
    user_site = site.getusersitepackages()
    if site.ENABLE_USER_SITE and user_site in sys.path:
        roots.append(Path(user_site))
    installed = [root.resolve() for root in roots if root.exists()]
    for entry in sys.path:
        path = Path(entry).resolve() if entry else None
        if path is not None and any(path.is_relative_to(root) for root in installed):
            roots.append(path)
    return roots


def readable_roots(model: Path) -> list[Path]:
    """What the confined process may read: the system's libraries and a few of its files,
    the Python installation, fmionnx itself (from a source checkout too), the model file."""
    roots = [Path(p) for p in SYSTEM_READABLE]
    roots += _python_roots()
    roots.append(Path(__file__).resolve().parents[2])  # the fmionnx package, nothing beside
    roots.append(model)
    unique = dict.fromkeys(p.resolve() for p in roots if p.exists())
    return [p for p in unique if p != Path("/")]


# -- the system-call filter -------------------------------------------------------------------


@dataclass(frozen=True)
class _Calls:
    """One architecture's seccomp arch value and system-call numbers (None: it has none)."""

    arch: int
    socket: int
    clone: int
    clone3: int
    fork: int | None
    vfork: int | None
    execve: int
    execveat: int
    io_uring_setup: int
    #: Numbers at or above this belong to another ABI on the same arch (x32 on x86_64).
    foreign_from: int | None


_CALLS = {
    "x86_64": _Calls(0xC000003E, 41, 56, 435, 57, 58, 59, 322, 425, 0x40000000),
    "aarch64": _Calls(0xC00000B7, 198, 220, 435, None, None, 221, 281, 425, None),
}
_AF_INET, _AF_INET6 = 2, 10
_CLONE_THREAD = 0x00010000
_LD_W_ABS, _JEQ, _JGE, _JSET, _RET = 0x20, 0x15, 0x35, 0x45, 0x06
_ALLOW, _ERRNO = 0x7FFF0000, 0x00050000
#: seccomp_data: nr (4 bytes), arch (4), instruction pointer (8), then six 8-byte arguments;
#: the low half of the first argument comes first (both architectures are little-endian).
_NR, _ARCH, _ARG0 = 0, 4, 16


def seccomp_filter(machine: str, *, inet: bool) -> bytes | None:
    """The BPF program of the filter for ``machine`` (None: no numbers known for it).

    ``inet``: IPv4 and IPv6 sockets are allowed (a network namespace of the model's own makes
    them harmless); every other socket family is refused with EACCES. New processes and
    programs are refused with EPERM, ``clone3`` and ``io_uring_setup`` with ENOSYS (``clone3``
    passes its flags in memory a filter cannot read: the C library then falls back to
    ``clone``, whose flags tell a thread from a process; io_uring would make sockets without
    the ``socket`` call). System calls of another ABI than the process's own are refused.
    """
    calls = _CALLS.get(machine)
    if calls is None:
        return None
    program: list[tuple[int, int, int, int]] = []
    labels: dict[str, int] = {}
    jumps: list[tuple[int, str, str]] = []  # (instruction, label if true, label if false)

    def emit(code: int, k: int = 0) -> None:
        program.append((code, 0, 0, k))

    def branch(code: int, k: int, yes: str, no: str) -> None:
        jumps.append((len(program), yes, no))
        program.append((code, 0, 0, k))

    def label(name: str) -> None:
        labels[name] = len(program)

    emit(_LD_W_ABS, _ARCH)
    branch(_JEQ, calls.arch, "native", "nosys")
    label("native")
    emit(_LD_W_ABS, _NR)
    if calls.foreign_from is not None:
        branch(_JGE, calls.foreign_from, "nosys", "calls")
    label("calls")
    branch(_JEQ, calls.socket, "socket", "next0")
    label("next0")
    branch(_JEQ, calls.clone, "clone", "next1")
    label("next1")
    refused = [calls.fork, calls.vfork, calls.execve, calls.execveat]
    for index, number in enumerate(n for n in refused if n is not None):
        branch(_JEQ, number, "eperm", f"refused{index}")
        label(f"refused{index}")
    branch(_JEQ, calls.clone3, "nosys", "next2")
    label("next2")
    branch(_JEQ, calls.io_uring_setup, "nosys", "allow")
    label("socket")
    emit(_LD_W_ABS, _ARG0)
    if inet:
        branch(_JEQ, _AF_INET, "allow", "socket6")
        label("socket6")
        branch(_JEQ, _AF_INET6, "allow", "eacces")
    label("eacces")
    emit(_RET, _ERRNO | errno.EACCES)
    label("clone")
    emit(_LD_W_ABS, _ARG0)
    branch(_JSET, _CLONE_THREAD, "allow", "eperm")
    label("eperm")
    emit(_RET, _ERRNO | errno.EPERM)
    label("nosys")
    emit(_RET, _ERRNO | errno.ENOSYS)
    label("allow")
    emit(_RET, _ALLOW)
    for at, yes, no in jumps:
        code, _, _, k = program[at]
        program[at] = (code, labels[yes] - at - 1, labels[no] - at - 1, k)
    return b"".join(struct.pack("=HBBI", *instruction) for instruction in program)


def _install_filter(program: bytes) -> None:
    count = len(program) // 8
    instructions = (_SockFilter * count).from_buffer_copy(program)
    fprog = _SockFprog(count, instructions)
    if _libc().prctl(_PR_SET_SECCOMP, _SECCOMP_MODE_FILTER, ctypes.byref(fprog), 0, 0) != 0:
        raise SandboxUnavailableError(f"seccomp filter: {os.strerror(ctypes.get_errno())}")


# -- confining ---------------------------------------------------------------------------------


def confine(writable: Path, model: Path) -> list[str]:
    """Confine this process; returns what could not be confined (empty: fully confined)."""
    missing: list[str] = []
    abi = landlock_abi()
    machine = platform.machine()
    network_namespace = _no_network()
    program = seccomp_filter(machine, inet=network_namespace)
    if abi == 0:
        missing.append("Landlock (file confinement; Linux 5.13 or newer with Landlock enabled)")
    if program is None:
        missing.append(
            f"a system-call filter for this machine ({machine}; fmionnx has one for "
            f"{' and '.join(_CALLS)})"
        )
    if missing:
        return missing
    assert program is not None
    _landlock(abi, writable, readable_roots(model), net=not network_namespace)
    _install_filter(program)
    return []


def _landlock(abi: int, writable: Path, readable: list[Path], *, net: bool) -> None:
    libc = _libc()
    fs_all = (1 << _FS_BITS_BY_ABI.get(abi, 16)) - 1
    scoped = (_SCOPE_ABSTRACT_UNIX_SOCKET | _SCOPE_SIGNAL) if abi >= _SCOPES_ABI else 0
    network = (_NET_BIND_TCP | _NET_CONNECT_TCP) if net else 0
    attr = (ctypes.c_uint64 * 3)(fs_all, network, scoped)
    size = 24 if scoped else 16 if net else 8
    ruleset = int(libc.syscall(_SYS_CREATE_RULESET, ctypes.byref(attr), ctypes.c_size_t(size), 0))
    if ruleset < 0:
        raise SandboxUnavailableError(f"landlock_create_ruleset: {os.strerror(ctypes.get_errno())}")
    try:
        read = _EXECUTE | _READ_FILE | _READ_DIR
        for path in readable:
            _allow(libc, ruleset, path, read)
        _allow(libc, ruleset, writable, fs_all)
        _allow(libc, ruleset, Path(os.devnull), _READ_FILE | _WRITE_FILE)
        if libc.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
            raise SandboxUnavailableError("prctl(PR_SET_NO_NEW_PRIVS) failed")
        if libc.syscall(_SYS_RESTRICT_SELF, ruleset, 0) != 0:
            raise SandboxUnavailableError(
                f"landlock_restrict_self: {os.strerror(ctypes.get_errno())}"
            )
    finally:
        os.close(ruleset)


def _allow(libc: ctypes.CDLL, ruleset: int, path: Path, rights: int) -> None:
    """Allow ``rights`` beneath ``path`` (only the file rights when it is a file)."""
    try:
        fd = os.open(path, os.O_PATH | os.O_CLOEXEC)
    except OSError:
        return
    try:
        if not path.is_dir():
            rights &= _FILE_RIGHTS
        rule = _PathBeneath(rights, fd)
        if libc.syscall(_SYS_ADD_RULE, ruleset, _RULE_PATH_BENEATH, ctypes.byref(rule), 0) != 0:
            raise SandboxUnavailableError(
                f"landlock_add_rule({path}): {os.strerror(ctypes.get_errno())}"
            )
    finally:
        with contextlib.suppress(OSError):
            os.close(fd)
