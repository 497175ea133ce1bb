"""Output paths, checked before any work starts.

A run that computes for minutes and then cannot write its results is the worst way to learn
that ``--out`` names a file or a read-only place; so every command checks its output paths
first (creating missing parent folders, as it would anyway) and refuses with the option's
name (a :class:`~fmionnx.pipeline.errors.RequestError`: exit 2).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from fmionnx.pipeline.errors import RequestError


def _make_folder(folder: Path, option: str, what: str) -> None:
    label = f"{option} `{what}`" + ("" if str(folder) == what else f": the folder `{folder}`")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        msg = f"{label} exists and is not a folder"
        raise RequestError(msg) from None
    except OSError as exc:
        msg = f"{label} cannot be created ({exc.strerror})"
        raise RequestError(msg) from None
    if not os.access(folder, os.W_OK | os.X_OK):
        msg = f"{label} is not writable"
        raise RequestError(msg)


def check_output_file(path: Path, option: str) -> Path:
    """``path`` can be written as a file (its folder is created)."""
    if path.is_dir():
        msg = f"{option} `{path}` is a folder; expected a file name"
        raise RequestError(msg)
    if path.exists() and not os.access(path, os.W_OK):
        msg = f"{option} `{path}` exists and is not writable"
        raise RequestError(msg)
    _make_folder(path.parent, option, str(path))
    if not path.exists():
        # A folder can pass every check and still take no new file (``/proc``, a read-only
        # mount as root); the file's writer would then fail naming its temporary file.
        try:
            handle, probe = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        except OSError as exc:
            msg = f"{option} `{path}`: no file can be made in `{path.parent}` ({exc.strerror})"
            raise RequestError(msg) from None
        os.close(handle)
        Path(probe).unlink()
    return path


def check_output_folder(path: Path, option: str) -> Path:
    """``path`` is (or can be created as) a writable folder."""
    _make_folder(path, option, str(path))
    return path


def check_results_folder(
    out: Path, *, force: bool, system_run: bool, default: bool = False
) -> None:
    """``out`` is usable for a run's results; a folder of someone else's files is refused
    unless ``force`` (see :mod:`fmionnx.results.outdir`). The default folder (``default``)
    follows the same rules; the message then says where it came from."""
    from fmionnx.results.outdir import foreign_folder

    if system_run and not force and foreign_folder(out):
        if default:
            msg = (
                f"the default results folder `{out}` holds files that are not the output of "
                "an earlier fmionnx run; choose a folder with --out, or use --force to write "
                "into it"
            )
        else:
            msg = (
                f"--out `{out}` holds files that are not the output of an earlier fmionnx run; "
                "choose an empty folder or use --force to write into it"
            )
        raise RequestError(msg)
    check_output_folder(out, "--out" if not default else "the default results folder")
