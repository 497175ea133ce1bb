"""An ``--out`` folder that already holds files: whose are they, and which are stale.

A results folder must show one run, never a mix of two. The rules (docs/running.md):

* an empty or missing folder, or the output of an earlier fmionnx run (recognised by its
  ownership record, :mod:`fmionnx.core.owned`), is written into: the new run replaces the
  files it writes and removes the files the earlier run wrote and this run does not write
  again (a plot that no longer exists) -- only those the record proves fmionnx wrote, each
  the very file written then (a file the user edited or put there is left alone);
* any other non-empty folder is refused before the run starts, unless ``--force``; with it,
  the run writes its files and deletes nothing it cannot prove it wrote;
* a study's folder (:func:`holds_study`) is refused, ``--force`` or not: its files are
  fmionnx's too, and a run would replace them as an earlier run's stale files.

``run.json`` lists the run's files too (for people and tools), but proves nothing: a forged
``run.json`` naming ``thesis.txt`` deletes nothing.

Without ``--out`` a run writes into :func:`default_folder`, ``out/<system name>/`` below the
working directory, under exactly these rules: a second run of the same system replaces the
first one's files, and a folder of someone else's files there is refused like any ``--out``.
"""

from __future__ import annotations

import re
from pathlib import Path

from fmionnx.core.owned import OwnedFolder

RUN_JSON = "run.json"
#: What marks a study's folder: its description and its records' folder
#: (:mod:`fmionnx.results.study`'s ``DESCRIPTION`` and ``RECORDS``, not imported here: a
#: run's start does not load the study modules).
STUDY_MARKS = ("study.json", "records")
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


def foreign_folder(out: Path) -> bool:
    """True when ``out`` holds files but no ownership record of fmionnx's."""
    if not out.is_dir():
        return False
    if not any(out.iterdir()):
        return False
    return not OwnedFolder(out).claimed()


def holds_study(out: Path) -> bool:
    """Whether ``out`` holds a study's results that fmionnx can prove it wrote (its
    ``study.json`` or a case's record, as the folder's ownership record lists them), which a
    run must not write into: it
    would take the study's proven files for an earlier run's and remove them. A folder that
    merely has a ``records`` folder or a file of that name is the user's: ``--force`` writes
    into it and deletes nothing it cannot prove."""
    description, records = STUDY_MARKS
    return any(
        name == description or name.startswith(f"{records}/")
        for name in OwnedFolder(out).proven_names()
    )


def relative_name(path: Path, out: Path) -> str | None:
    """``path`` as a name inside ``out`` (POSIX form), or None when it lies elsewhere."""
    try:  # the name itself is not resolved: a link at the name is a file of the folder
        return (path.parent.resolve() / path.name).relative_to(out.resolve()).as_posix()
    except ValueError:
        return None
