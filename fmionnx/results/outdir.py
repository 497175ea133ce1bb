"""An ``--out`` folder that already holds files: whose are they, and which are stale.

A results folder must show one run, never a mix of two. The rules (docs/running.md):

* an empty or missing folder, or the output of an earlier fmionnx run (recognised by its
  ``run.json``), is written into: the new run replaces the files it writes and removes the
  files the earlier run listed in ``run.json`` under ``files`` and this run did not write
  again (a plot that no longer exists); files fmionnx never listed are left alone;
* any other non-empty folder is refused before the run starts, unless ``--force``.

Without ``--out`` a run writes into :func:`default_folder`, ``out/<system name>/`` below the
working directory, under exactly these rules: a second run of the same system replaces the
first one's files, and a folder of someone else's files there is refused like any ``--out``.

``run.json`` is trusted only as a regular file (not a symbolic link) whose ``versions`` name
fmionnx; stale names are removed only when they stay inside the folder.
"""

from __future__ import annotations

import json
import re
from pathlib import Path, PurePosixPath
from typing import Any

RUN_JSON = "run.json"
#: The folder, relative to the working directory, that holds each system's default results.
DEFAULT_ROOT = "out"


def default_folder(system_name: str) -> Path:
    """``out/<system name>``: where a run without ``--out`` writes (docs/decisions.md).

    A system file's name is already a plain name; a compiled-system file or an SSP could
    carry anything, so characters other than letters, digits, ``_``, ``-`` and ``.`` become
    ``_`` and leading dots are dropped: the folder is always one plain, visible name.
    """
    plain = re.sub(r"[^\w.-]", "_", system_name).lstrip(".")
    return Path(DEFAULT_ROOT) / (plain or "system")


def previous_run(out: Path) -> dict[str, Any] | None:
    """The ``run.json`` an earlier fmionnx run left in ``out``, or None."""
    path = out / RUN_JSON
    if path.is_symlink() or not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    versions = data.get("versions")
    if not isinstance(versions, dict) or "fmionnx" not in versions:
        return None
    return data


def foreign_folder(out: Path) -> bool:
    """True when ``out`` holds files but is not the output of an earlier fmionnx run."""
    if not out.is_dir():
        return False
    if not any(out.iterdir()):
        return False
    return previous_run(out) is None


def listed_files(out: Path, previous: dict[str, Any] | None) -> list[Path]:
    """The files an earlier run wrote, as paths inside ``out`` (anything else is dropped)."""
    names = (previous or {}).get("files")
    if not isinstance(names, list):
        return []  # run.json of an fmionnx before 'files' existed: nothing is removed
    inside = []
    root = out.resolve()
    for name in names:
        if not isinstance(name, str) or not name:
            continue
        relative = PurePosixPath(name)
        if relative.is_absolute() or ".." in relative.parts or "\\" in name:
            continue
        path = out.joinpath(*relative.parts)
        if path.parent.resolve().is_relative_to(root):
            inside.append(path)
    return inside


def relative_name(path: Path, out: Path) -> str | None:
    """``path`` as a name inside ``out`` (POSIX form), or None when it lies elsewhere."""
    try:  # the name itself is not resolved: a link at the name is a file of the folder
        return (path.parent.resolve() / path.name).relative_to(out.resolve()).as_posix()
    except ValueError:
        return None


def remove_stale(out: Path, previous: dict[str, Any] | None, written: list[Path]) -> list[Path]:
    """Remove what the earlier run listed and this run did not write again; returns them.

    A symbolic link is removed itself (never its target); a folder is never removed.
    """
    kept = {name for p in written if (name := relative_name(p, out)) is not None}
    removed = []
    for path in listed_files(out, previous):
        if relative_name(path, out) in kept:
            continue
        if path.is_symlink() or path.is_file():
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed
