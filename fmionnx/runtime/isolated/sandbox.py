"""Confinement of an isolated model's process (``--sandbox``), with what Linux gives unprivileged.

Applied by the child to itself before it loads the model, and irreversible:

- **no network**: a new user and network namespace (``unshare``), which has no interface but
  a loopback that is down; where user namespaces are disabled, Landlock's TCP rules (ABI 4)
  deny TCP connect and bind instead;
- **files**: Landlock (Linux 5.13+) allows writing only beneath the model's own temporary
  folder (where the FMU is extracted), and reading only the model file, that folder, and what
  the process needs to run at all (the Python installation and its packages, the system's
  shared libraries, ``/dev/null``).

What the kernel cannot provide is reported as a problem, and the run refuses to start: a
user who asked for a sandbox must not get less without knowing. System calls are not
filtered (no seccomp policy): the confinement is of files and network.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from pathlib import Path

_SYS_CREATE_RULESET, _SYS_ADD_RULE, _SYS_RESTRICT_SELF = 444, 445, 446
_CREATE_RULESET_VERSION = 1
_RULE_PATH_BENEATH = 1
_PR_SET_NO_NEW_PRIVS = 38
_CLONE_NEWUSER, _CLONE_NEWNET = 0x10000000, 0x40000000

# Landlock file-system rights (by ABI version: 1 has bits 0-12, 2 adds REFER, 3 TRUNCATE,
# 5 IOCTL_DEV) and network rights (ABI 4).
_EXECUTE, _WRITE_FILE, _READ_FILE, _READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
_FS_BITS_BY_ABI = {1: 13, 2: 14, 3: 15, 4: 15, 5: 16}
_NET_BIND_TCP, _NET_CONNECT_TCP = 1 << 0, 1 << 1
_FILE_RIGHTS = _EXECUTE | _WRITE_FILE | _READ_FILE | (1 << 14) | (1 << 15)

#: Folders every process needs to read (shared libraries, the loader's cache, devices).
SYSTEM_READABLE = ("/usr", "/lib", "/lib64", "/lib32", "/etc/ld.so.cache", "/proc/self", "/sys")


class _PathBeneath(ctypes.Structure):
    _pack_ = 1
    _fields_ = (("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32))


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


def readable_roots(model: Path) -> list[Path]:
    """What the confined process may read: itself (Python and its packages), the system, the
    model file."""
    roots = [Path(p) for p in SYSTEM_READABLE]
    roots += [Path(p) for p in (sys.prefix, sys.base_prefix, sys.exec_prefix)]
    roots += [Path(p) for p in sys.path if p]
    # fmionnx itself: an editable install maps it from its source folder, which is on
    # sys.path only when that folder happens to be the working folder.
    roots.append(Path(__file__).resolve().parents[2])
    roots.append(model)
    return [p for p in dict.fromkeys(roots) if p.exists()]


def confine(writable: Path, model: Path) -> list[str]:
    """Confine this process; returns what could not be confined (empty: fully confined)."""
    missing: list[str] = []
    abi = landlock_abi()
    network_namespace = _no_network()
    if abi == 0:
        missing.append("Landlock (file confinement; Linux 5.13 or newer with Landlock enabled)")
    if not network_namespace and abi < 4:
        missing.append("user namespaces or Landlock ABI 4 (no network)")
    if missing:
        return missing
    _landlock(abi, writable, readable_roots(model), net=not network_namespace)
    return []


def _landlock(abi: int, writable: Path, readable: list[Path], *, net: bool) -> None:
    libc = _libc()
    fs_all = (1 << _FS_BITS_BY_ABI.get(abi, 16)) - 1
    attr = (ctypes.c_uint64 * 3)(fs_all, (_NET_BIND_TCP | _NET_CONNECT_TCP) if net else 0, 0)
    size = 8 if not net else 16
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
