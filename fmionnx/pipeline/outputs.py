"""Output paths, checked before any work starts.

A run that computes for minutes and then cannot write its results is the worst way to learn
that ``--out`` names a file or a read-only place; so every command checks its output paths
first (creating missing parent folders, as it would anyway) and refuses with the option's
name (a :class:`~fmionnx.pipeline.errors.RequestError`: exit 2).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from contextvars import ContextVar
from pathlib import Path

from fmionnx.pipeline.errors import RequestError


def _make_folder(folder: Path, option: str, what: str) -> None:
    label = f"{option} `{what}`" + ("" if str(folder) == what else f": the folder `{folder}`")
    if folder.is_symlink() and not folder.exists():
        msg = f"{label} is a symbolic link that leads nowhere (its target is missing, or a loop)"
        raise RequestError(msg)
    try:
        made = _made_levels(folder)
    except FileExistsError as exc:
        raise RequestError(_in_the_way(folder, label, option, what, exc)) from None
    except OSError as exc:
        msg = f"{label} cannot be created ({exc.strerror})"
        raise RequestError(msg) from None
    watched = _MADE.get()
    if watched is not None:
        watched.extend(made)
    if not os.access(folder, os.W_OK | os.X_OK):
        msg = f"{label} is not writable"
        raise RequestError(msg)


def _in_the_way(folder: Path, label: str, option: str, what: str, exc: FileExistsError) -> str:
    """The message for a path that is not a folder where one is needed, naming that path:
    for ``--out afile/sub``, ``afile`` (a file) is in the way, and "`afile/sub` exists and is
    not a folder" named a path that does not exist (a bug hunt)."""
    blocking = Path(exc.filename) if exc.filename is not None else folder
    if blocking == folder:
        return f"{label} exists and is not a folder"
    return f"{option} `{what}`: `{blocking}` exists and is not a folder"


def _made_levels(folder: Path) -> list[Path]:
    """Make ``folder`` and its missing parents one level at a time, along the path as written;
    return exactly the folders this call made (outermost first). ``Path.mkdir(parents=True)``
    says nothing of what it made, and the path as written is what is made: in
    ``new/../out`` it makes ``new`` too, where a guess from the normalized path would have
    named a folder the user had (a review). A level made meanwhile by someone else is theirs."""
    made = []
    for depth in range(1, len(folder.parts) + 1):
        level = Path(*folder.parts[:depth])
        try:
            level.mkdir()
        except FileExistsError:
            if not level.is_dir():
                raise
            continue
        made.append(level)
    return made


#: The folders the output checks made while :func:`undone_on_failure` watches them.
_MADE: ContextVar[list[Path] | None] = ContextVar("fmionnx_made", default=None)


@contextlib.contextmanager
def undone_on_failure() -> Iterator[None]:
    """Folders the output checks make inside the block are removed again, when still empty,
    if the block raises: a command that checked ``--out`` and then failed to load its system
    left an empty results folder behind (a bug hunt). Never a folder that existed before,
    never one holding anything (``rmdir`` refuses it: what a writer put there stays)."""
    made: list[Path] = []
    token = _MADE.set(made)
    try:
        yield
    except BaseException:
        for level in reversed(made):  # innermost first
            with contextlib.suppress(OSError):
                level.rmdir()
        raise
    finally:
        _MADE.reset(token)


def check_output_file(path: Path, option: str) -> Path:
    """``path`` can be written as a file (its folder is created)."""
    if path.is_dir():
        msg = f"{option} `{path}` is a folder; expected a file name"
        raise RequestError(msg)
    if path.exists() and not os.access(path, os.W_OK):
        msg = f"{option} `{path}` exists and is not writable"
        raise RequestError(msg)
    _make_folder(path.parent, option, str(path))
    # A folder can pass every check and still take no new file (``/proc``, a read-only mount
    # as root); the file's writer, which makes a new file beside the name and renames it over
    # even an existing one (``/proc/version``), would then fail after the work, exit 1.
    try:
        handle, probe = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    except OSError as exc:
        msg = f"{option} `{path}`: no file can be made in `{path.parent}` ({exc.strerror})"
        if path.exists():
            msg += "; the file is replaced by a new one made there"
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
    from fmionnx.results.outdir import foreign_folder, holds_study

    if system_run and out.is_dir() and holds_study(out):
        where = f"the default results folder `{out}`" if default else f"--out `{out}`"
        msg = (
            f"{where} holds a study's results (study.json, records/): a run writes into a "
            "folder of its own, even with --force; choose another folder"
        )
        raise RequestError(msg)
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


#: Files a run writes into its results folder besides its plots (any image there).
RUN_FILES = frozenset({"run.json", "results.csv", ".fmionnx-owned"})


def check_distinct_outputs(recordings: dict[str, Path | None], out: Path | None) -> None:
    """No two of a run's outputs at one path: ``--record`` and ``--rrd`` (``recordings``, by
    option) apart, and neither one of the files the run writes into ``out`` (``run.json``,
    ``results.csv``, an image: its plots). One overwrote the other, a run.json became a
    Rerun recording, and the run still said it wrote both (a bug hunt)."""
    from fmionnx.compile.plotfiles import IMAGE_SUFFIXES

    seen: dict[Path, str] = {}
    for option, path in recordings.items():
        if path is None:
            continue
        where = _normal(path)
        if where in seen:
            msg = f"{seen[where]} and {option} name the same file `{path}`: choose two names"
            raise RequestError(msg)
        seen[where] = option
        inside = out is not None and where.parent == _normal(out)
        if inside and (path.name in RUN_FILES or path.suffix.lower() in IMAGE_SUFFIXES):
            msg = (
                f"{option} `{path}` is a file the run writes into its results folder `{out}`: "
                "choose another name"
            )
            raise RequestError(msg)


def _normal(path: Path) -> Path:
    """``path`` absolute, ``..`` and ``.`` taken out by name (links are not followed: the
    files need not exist yet)."""
    return Path(os.path.normpath(path.absolute()))


#: The first bytes of an MCAP file, and of a Rerun recording (``.rrd``).
MCAP_MAGIC, RRD_MAGIC = b"\x89MCAP0\r\n", b"RRF"


def check_recording_file(path: Path, option: str, *, force: bool, source: Path) -> None:
    """An existing file at ``path`` is replaced only when it is a recording of the kind the
    option writes (``--record``: an MCAP file fmionnx wrote; ``--rrd``: a Rerun recording,
    whose writer cannot be told), or with ``force``: a recording is regenerated at will, a
    file of anything else (notes) is the user's. The run's own ``source`` file never, with
    ``force`` or not (a user who adds ``--force`` for the results folder means that one)."""
    if path.is_symlink() or not path.is_file():
        return  # a link at the name is replaced, never written through
    try:
        itself = path.samefile(source)
    except OSError:
        itself = False
    if itself:
        msg = f"{option} `{path}` is the file this run reads: choose another name"
        raise RequestError(msg)
    if force:
        return
    ours = _fmionnx_mcap(path) if option == "--record" else _starts_with(path, RRD_MAGIC)
    if not ours:
        what = "an MCAP recording fmionnx wrote" if option == "--record" else "a Rerun recording"
        msg = (
            f"{option} `{path}` exists and is not {what}; not replacing it (choose another "
            "name, or use --force to replace it)"
        )
        raise RequestError(msg)


def _starts_with(path: Path, magic: bytes) -> bool:
    try:
        with path.open("rb") as stream:
            return stream.read(len(magic)) == magic
    except OSError:
        return False


def _fmionnx_mcap(path: Path) -> bool:
    """Whether ``path`` is an MCAP file whose header names fmionnx as its library (what
    :class:`~fmionnx.results.mcap_record.McapRecorder` writes): magic, the header record
    (opcode 1, its length), its profile and library strings (each a length and UTF-8)."""
    try:
        with path.open("rb") as stream:
            head = stream.read(len(MCAP_MAGIC) + 9 + 512)
    except OSError:
        return False
    if not head.startswith(MCAP_MAGIC) or head[len(MCAP_MAGIC) : len(MCAP_MAGIC) + 1] != b"\x01":
        return False  # no header record (a file cut short after the magic included)
    at = len(MCAP_MAGIC) + 9
    strings = []
    for _ in range(2):
        size = int.from_bytes(head[at : at + 4], "little")
        strings.append(head[at + 4 : at + 4 + size])
        at += 4 + size
    return strings[1] == b"fmionnx"
