"""What tests read of running processes from ``/proc`` (Linux)."""

from __future__ import annotations

from pathlib import Path


def child_pids(pid: int | str = "self") -> list[int]:
    """The child processes of ``pid`` now (started by any of its threads), zombies included;
    none for a process that ended meanwhile."""
    found: list[int] = []
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except OSError:
        return found
    for task in tasks:
        try:
            found.extend(int(child) for child in (task / "children").read_text("ascii").split())
        except OSError:  # the thread ended meanwhile
            continue
    return found


def command_line(pid: int) -> str:
    """``pid``'s command line, its arguments joined by spaces (raises OSError once it ended)."""
    return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()


def group_members(pgid: int) -> list[int]:
    """The live processes of process group ``pgid`` now (zombies aside)."""
    members: list[int] = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            state, _, _, group = (entry / "stat").read_text().rsplit(")", 1)[1].split()[:4]
        except (OSError, ValueError):  # ended while we looked
            continue
        if state != "Z" and int(group) == pgid:
            members.append(int(entry.name))
    return members
