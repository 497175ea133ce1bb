"""Compiled systems kept between processes: ``validate`` and ``run`` of an unchanged system
compile nothing.

Compiling the reference system reads three models with three libraries (MuJoCo compiles the
scene, onnx parses the network, fmpy the model descriptions), builds the graph with networkx
and the ROS 2 plan from rosbags' message stores: most of a ``validate``. A CI job validating
the same systems on every push, and a user who runs a system again, pay all of that for
nothing. So a successful compile of a YAML system file is kept in the cache folder
(:func:`fmionnx.core.cachedir.cache_folder`, ``compiled/``) and read back the next time
instead of compiling, when nothing it was made from has changed.

A lone model run as a system (``fmionnx run model.fmu``, ``fmionnx.load("model.onnx")``) is
kept the same way (:func:`model_slot`): its compile loads the kinds'
pydantic specs and the run settings' types, a third of a lone FMU's start. So is the check
of a lone model by ``fmionnx validate MODEL`` (the compile and the kind's deeper checks:
FMPy's validation, the ONNX checker, MuJoCo's compiler), when it found no error; and a study's
plan (:mod:`fmionnx.pipeline.keptstudy`), keyed by the study file's bytes, with its system file
as one more dependency.

**What an entry depends on** is hashed, never trusted by its date:

- the *key* (the entry's folder name) is a sha256 over this cache's format, the code that
  compiled it (fmionnx's files and the libraries that read models, by size and modification
  time, those ``PYTHONPATH`` reaches too: see :func:`_code_stamp`), the ``FMIONNX_*``
  environment (resource limits change diagnostics), the working folder, the home folder
  (``~/m.fmu`` names another model under another ``HOME``), the path as given,
  ``--start-time``/``--step``, and the system file's bytes (a lone model: ``--interface``
  instead, its bytes being a dependency, below);
- the entry lists every model it read with the sha256 of its contents (a scene with the
  files it is shipped with, its folder where they cannot be listed) and each model's
  expected-path file (or that there was none). A lookup hashes them all again; one that
  differs is a miss, and so is a model path written from a home folder (``~user/m.fmu``)
  that names another file now;
- an entry is written only for a compile that read what it lists (:func:`store`): nothing
  that changed after the compile began, by its change time; hashes that are those the
  interfaces were read from; no ONNX model with external data (not hashed with it).

**An entry is verified or refused, never believed** (``docs/security.md``): it is read only
from a folder owned by this user that nobody else may write, without following links, up to
a size bound; its bytes must carry the HMAC of a key only this user can read (a file someone
else made, or one damaged on disk, is refused); its compiled system goes through the same
checks as a compiled-system file from another host (:func:`~fmionnx.compile.systemfile.from_json`);
and every model the system names must be one whose hash was just checked. A refused entry is
a miss: the system is compiled and the entry written again.

The cache is bounded (:func:`fmionnx.core.cachedir.evict`, ``FMIONNX_COMPILE_CACHE_MAX_BYTES``
and ``FMIONNX_CACHE_MAX_DAYS``), holds nothing that cannot be compiled again, and is switched
off by ``FMIONNX_COMPILE_CACHE=0``. Only compiles without errors are kept: a system with
errors is compiled every time, so its diagnostics are always fresh.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import os
import sys
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.runflags import RunFlags
from fmionnx.core.cachedir import cache_folder, discard, evict, touch
from fmionnx.core.diagnostics import Diagnostic
from fmionnx.core.keptentries import limits_in_force
from fmionnx.core.private import (
    NotPrivateError,
    check_private_folder,
    read_private,
    signature,
    signed_by,
    user_key,
    write_private,
)
from fmionnx.core.switches import switched_off
from fmionnx.core.types import Component

#: The cache folder's name under the cache root.
FOLDER = "compiled"
#: The format of an entry; a new version makes every older entry a miss.
FORMAT = "fmionnx-compile-cache"
VERSION = 1
#: The environment variable that switches the cache off (``0``, ``off``, ``no``, ``false``).
SWITCH = "FMIONNX_COMPILE_CACHE"
#: System files the cache keeps: YAML (an SSP archive has its own unpack cache).
SUFFIXES = frozenset({".yaml", ".yml"})
#: Lone models the cache keeps (those ``load`` runs as a one-component system).
MODEL_SUFFIXES = frozenset({".fmu", ".onnx"})
#: Largest system file and entry read (a system file larger than this is refused anyway).
MAX_SYSTEM_BYTES = 16 * 1024 * 1024
MAX_ENTRY_BYTES = 64 * 1024 * 1024
#: Most bytes and files of models hashed per lookup: a system with larger models is compiled
#: every time rather than hashing, say, a scene folder full of unrelated files on each run.
MAX_HASHED_BYTES = 1024 * 1024 * 1024
MAX_HASHED_FILES = 10_000
#: The entry's file in its folder, and the key's file in the cache folder.
ENTRY = "entry.json"


#: An entry that must not be used (unsafe, damaged, stale or of another format).
_RefusedError = NotPrivateError


@dataclass(frozen=True)
class Cached:
    """A compiled system read back from the cache, the diagnostics its compile gave, and what
    else its writer kept with it (``payload``: a study's plan, JSON data; None: nothing)."""

    system: CompiledSystem
    diagnostics: tuple[Diagnostic, ...]
    payload: object = None


def enabled() -> bool:
    """Whether the cache is on (``FMIONNX_COMPILE_CACHE`` unset or not a "no")."""
    return not switched_off(SWITCH)


def applies_to(path: Path, suffixes: frozenset[str] = SUFFIXES) -> bool:
    """Whether compiles of the system file (or, with :data:`MODEL_SUFFIXES`, the lone model)
    at ``path`` are kept: not while an editor's texts stand in for files on disk (the
    language server), whose compiles the disk does not key."""
    from fmionnx.core.sourcetext import editing_any

    return enabled() and path.suffix.lower() in suffixes and not editing_any()


@dataclass(frozen=True)
class Slot:
    """Where one compile is kept: its entry's key, worked out before the compile, so that an
    entry holds what was compiled from what its key names even when a file changes during
    the compile; for a lone model, the path its one component must name (the path it
    resolved to then); the file the key read (a system file); and when the slot was made,
    before the compile (:func:`store` keeps nothing made of a file changed since)."""

    key: str
    model: Path | None = None
    source: Path | None = None
    begun: int = dataclasses.field(default_factory=time.time_ns)


def slot(path: Path, flags: RunFlags | None) -> Slot | None:
    """The slot of the system file at ``path`` compiled with ``flags`` (None: not kept)."""
    return _file_slot(path, "system", flags)


def study_slot(path: Path) -> Slot | None:
    """The slot of the study file at ``path`` compiled into its plan (None: not kept). Its
    system file is not in the key: :func:`store` lists it as a dependency."""
    return _file_slot(path, "study", None)


def _file_slot(path: Path, purpose: str, flags: RunFlags | None) -> Slot | None:
    """The slot of a file compiled whole (its bytes in the key): a system or a study file."""
    if not applies_to(path):
        return None
    begun = time.time_ns()  # before the bytes are read: a change after it is not in the key
    try:
        key = _key(path, flags, purpose)
    except (OSError, ValueError):
        return None
    return None if key is None else Slot(key, source=path, begun=begun)


def model_slot(
    path: Path, flags: RunFlags, interface: str | None, *, checked: bool = False
) -> Slot | None:
    """The slot of the lone model at ``path`` run with ``flags`` and ``interface`` (an FMU's
    ``--interface``), or with ``checked`` of its check by ``fmionnx validate MODEL`` (its
    compile and its kind's deeper checks, any model a kind reads); None: not kept."""
    if not applies_to(path, _checked_suffixes() if checked else MODEL_SUFFIXES):
        return None
    try:
        resolved = path.resolve()
        purpose = "checked" if checked else "lone"
        return Slot(_model_key(path, flags, interface, resolved, purpose), resolved)
    except (OSError, ValueError, RuntimeError):  # RuntimeError: a loop of links
        return None


def _checked_suffixes() -> frozenset[str]:
    """What ``fmionnx validate`` checks as a lone model: the files every kind reads."""
    from fmionnx.kinds.registry import KIND_SUFFIXES

    return frozenset(s for suffixes in KIND_SUFFIXES.values() for s in suffixes)


def lookup(place: Slot | None) -> Cached | None:
    """The compile kept in ``place``, or None (a miss, or an entry refused)."""
    if place is None:
        return None
    try:
        found = _read(_root() / place.key, place.key)
    except (OSError, ValueError, _RefusedError):
        return None
    if found is not None and not (
        _names_its_model(found.system, place) and _homes_as_compiled(found.system, place)
    ):
        return None
    return found


def store(
    place: Slot | None,
    system: CompiledSystem,
    diagnostics: Sequence[Diagnostic],
    *,
    payload: object = None,
    files: Sequence[Path] = (),
) -> None:
    """Keep a compile in ``place``: ``system``, its (error-free) ``diagnostics``, and
    ``payload`` (JSON data read back as :attr:`Cached.payload`); ``files`` are more files the
    compile read (a study's system file), hashed with the models.

    Kept only when the files hashed now are those the compile read (a model rebuilt during
    the compile is compiled again next time). Never raises: a cache that cannot be written (a
    read-only home, a full disk, a folder someone else owns) only means the next run
    compiles again.
    """
    if place is None or not _names_its_model(system, place) or _reads_unlisted(system):
        return
    # RuntimeError: a loop of links made meanwhile, met resolving a model's files
    with contextlib.suppress(OSError, ValueError, RuntimeError, _RefusedError):
        budget = _Budget()
        dependencies = _dependencies(system, budget, files)
        if place.source is not None:
            budget.note(place.source.stat())
        if budget.changed_since(place.begun) or not _as_compiled(system, dependencies):
            return
        _write(place.key, system, diagnostics, dependencies, payload)


#: How long before a compile began a file's change still counts as during it: the kernel
#: stamps a file's change with a clock that is read once per tick (1 to 10 ms behind).
CHANGE_MARGIN_NS = 20_000_000


def _reads_unlisted(system: CompiledSystem) -> bool:
    """Whether a model reads files its hash does not cover (an ONNX model's external data,
    :data:`~fmionnx.kinds.base.UNLISTED_FILES`): read every time, never kept."""
    from fmionnx.kinds.base import UNLISTED_FILES

    return any(c.interface.fact(UNLISTED_FILES) == "true" for c in system.components)


def _names_its_model(system: CompiledSystem, place: Slot) -> bool:
    """Whether a lone model's system runs the model its slot's path resolved to."""
    return place.model is None or all(c.path == place.model for c in system.components)


def _homes_as_compiled(system: CompiledSystem, place: Slot) -> bool:
    """Whether each model path the system file wrote from a home folder (``~/m.fmu``,
    ``~user/m.fmu``) still names the file it named at the compile: ``HOME`` is in the key,
    but a study's system file is not, nor is another user's home folder. A path whose home
    is gone now names the path as written, in the system file's folder, as the compiler does."""
    if place.model is not None:  # a lone model: checked by the path it resolved to
        return True
    return all(
        _names_now(c.path, c.declared_path) for c in _models(system) if c.declared_path[:1] == "~"
    )


def _names_now(path: Path, declared: str) -> bool:
    """Whether ``declared`` (a path from a home folder) names ``path`` now."""
    written = Path(declared)
    try:
        expanded = written.expanduser()
    except RuntimeError:  # no such user now: kept as written, relative to the system file
        expanded = written
    if expanded.is_absolute():
        return path == expanded
    return path.parts[-len(written.parts) :] == written.parts


def _as_compiled(system: CompiledSystem, dependencies: list[Dependency]) -> bool:
    """Whether each model file hashed for the entry has the contents its interface was read
    from (a kind that says so, :data:`~fmionnx.kinds.base.FILE_HASHED`, carries the sha256
    of the file's bytes in the interface; an unpacked FMU folder's is not compared)."""
    from fmionnx.kinds.base import FILE_HASHED
    from fmionnx.kinds.registry import has_capability

    digests = dict(dependencies)
    return all(
        digests.get(str(c.path)) == c.interface.content_hash
        for c in _models(system)
        if c.path.is_file() and has_capability(c, FILE_HASHED)
    )


# -- the key ------------------------------------------------------------------------------------


def _key(path: Path, flags: RunFlags | None, purpose: str) -> str | None:
    """The entry's name for compiling ``path`` (a ``purpose`` file: ``system`` or ``study``)
    with ``flags`` here, now (None: not cacheable)."""
    from fmionnx.core.regularfile import read_head

    # A FIFO, a device or a folder named like a system file is the compiler's to refuse,
    # never a read that waits for ever.
    data = read_head(path, MAX_SYSTEM_BYTES + 1)
    if data is None or len(data) > MAX_SYSTEM_BYTES:
        return None
    return _hashed(path, flags or RunFlags(), **{purpose: hashlib.sha256(data).hexdigest()})


def _model_key(
    path: Path, flags: RunFlags, interface: str | None, resolved: Path, purpose: str
) -> str:
    """The entry's name for the lone model at ``path``. Its bytes are not in the key (a model
    can be large, and the entry's dependencies hash it anyway): a changed model finds its
    entry, whose dependencies no longer match, and is compiled again into the same key. The
    path it resolves to is: the compiled system names the model by it, so a link pointed at
    another model is another entry."""
    return _hashed(path, flags, model=[purpose, interface, str(resolved)])


def _hashed(path: Path, flags: RunFlags, **what: object) -> str:
    material = {
        "format": [FORMAT, VERSION],
        "code": _code_stamp(),
        "environment": limits_in_force(),
        "cwd": str(Path.cwd()),
        "home": _home(),
        "path": str(path),
        "flags": [flags.start, flags.step, flags.stop],
        **what,
    }
    text = json.dumps(material, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _home() -> str | None:
    """What ``~`` in a model path stands for now (``HOME``, else the user's entry): the same
    system file run with another home runs other models, so it is another entry."""
    try:
        return str(Path("~").expanduser())
    except RuntimeError:  # no home anywhere: ``~`` is kept as written
        return None


@functools.cache
def _code_stamp() -> str:
    """What the compiler is, as far as a compile's result can depend on it.

    fmionnx's own files (name, size, modification time: an editable install changes under a
    developer's hands, a reinstall rewrites them), and the folders libraries are installed in
    (installing, upgrading or removing a library adds or renames its ``.dist-info`` folder
    there, which changes the folder's modification time). Cheap: a few hundred ``stat`` calls,
    no import.
    """
    digest = hashlib.sha256(f"{sys.version}\0".encode())
    package = Path(__file__).resolve().parent.parent  # the fmionnx package
    for folder, subfolders, files in os.walk(package):
        subfolders[:] = sorted(s for s in subfolders if s != "__pycache__")
        for name in sorted(files):
            if name.endswith((".py", ".so", ".json")):
                _stamp_file(digest, Path(folder) / name, package)
    for entry in _library_folders():
        _stamp_file(digest, entry, None)
    return digest.hexdigest()


def _library_folders() -> list[Path]:
    """The folders libraries are imported from: ``site-packages``, and the folders
    ``PYTHONPATH`` names (a ROS 2 install puts its own libraries there, in front of
    ``site-packages``: another ``PYTHONPATH`` can compile with other versions). Not the
    script's folder or the working folder that ``sys.path`` also holds: those change with
    every file written (the working folder is in the key by name)."""
    import site

    folders = [*site.getsitepackages()]
    if site.ENABLE_USER_SITE:
        folders.append(site.getusersitepackages())
    installed = [Path(f) for f in folders if f in sys.path]
    here = Path.cwd()
    named = [here / f for f in os.environ.get("PYTHONPATH", "").split(os.pathsep) if f]
    named = [f for f in named if not f.is_relative_to(here)]  # `PYTHONPATH=.`: the working
    return [f for f in dict.fromkeys([*named, *installed]) if f.is_dir()]  # folder, as above


def _stamp_file(digest: hashlib._Hash, file: Path, relative_to: Path | None) -> None:
    info = file.stat()
    name = file.relative_to(relative_to).as_posix() if relative_to is not None else str(file)
    digest.update(f"{name}\0{info.st_size}\0{info.st_mtime_ns}\n".encode())


# -- what an entry depends on -------------------------------------------------------------------

#: (path, digest): the sha256 of a file, of a folder's files, or None for a file that was absent.
Dependency = tuple[str, str | None]


def _dependencies(
    system: CompiledSystem, budget: _Budget, files: Sequence[Path] = ()
) -> list[Dependency]:
    """Every model file ``system`` was compiled from and ``files``, hashed now
    (:class:`_RefusedError`: too large to hash)."""
    from fmionnx.compile.expected_path import expected_path_file
    from fmionnx.compile.systemfile import has_model_file

    found: dict[str, str | None] = {str(f): _digest(f, budget) for f in files}
    for component in system.components:
        if not has_model_file(component):
            continue
        for path in (*_model_paths(component), expected_path_file(component.path)):
            if str(path) not in found:
                found[str(path)] = _digest(path, budget)
    return sorted(found.items())


def _model_paths(component: Component) -> tuple[Path, ...]:
    """The files a component's model is made of (a scene's includes and assets too: the
    files its kind ships with it), or its whole folder where they cannot be listed."""
    from fmionnx.core.modelfiles import ShippingError
    from fmionnx.kinds.registry import model_files

    model = component.path
    try:
        itself = model.resolve()
        files = model_files(component.kind, model)
        beside = tuple(f.source for f in files if f.source.resolve() != itself)
    except (ShippingError, OSError):
        return (model.parent,)
    return (model, *beside)  # the model by the name the compiled system gives it


class _Budget:
    """How much more a lookup may hash (:data:`MAX_HASHED_BYTES`, :data:`MAX_HASHED_FILES`),
    and the latest change of a file hashed so far (its inode's change time, which writing,
    replacing or renaming a file sets and no program can set back)."""

    def __init__(self) -> None:
        self.bytes = MAX_HASHED_BYTES
        self.files = MAX_HASHED_FILES
        self.latest = 0

    def spend(self, info: os.stat_result) -> None:
        self.note(info)
        self.bytes -= info.st_size
        self.files -= 1
        if self.bytes < 0 or self.files < 0:
            msg = "the models are too large to hash on every run"
            raise _RefusedError(msg)

    def note(self, info: os.stat_result) -> None:
        # Not the modification time: any program sets it, to the past (an archive unpacked
        # with its dates) or to the future (a skewed clock, which would keep nothing).
        self.latest = max(self.latest, info.st_ctime_ns)

    def changed_since(self, begun: int) -> bool:
        """Whether a file hashed changed after ``begun`` (ns), or too close before it to tell."""
        return self.latest >= begun - CHANGE_MARGIN_NS


def _digest(path: Path, budget: _Budget) -> str | None:
    """sha256 of the file at ``path``, or of the names and contents of the folder's files
    (links are followed, as the compiler follows them); None when nothing is there."""
    if not path.exists():
        return None
    if path.is_file():
        return _file_digest(path, budget)
    digest = hashlib.sha256(b"folder\0")
    for folder, subfolders, files in os.walk(path):
        subfolders.sort()
        budget.note(Path(folder).stat())  # a file added or removed changes its folder
        for name in sorted(files):
            file = Path(folder) / name
            if file.is_file():
                digest.update(file.relative_to(path).as_posix().encode() + b"\0")
                digest.update(bytes.fromhex(_file_digest(file, budget)))
    return digest.hexdigest()


def _file_digest(path: Path, budget: _Budget) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        budget.spend(os.fstat(stream.fileno()))
        while chunk := stream.read(1 << 20):
            digest.update(chunk)
    return digest.hexdigest()


def _unchanged(dependencies: object) -> bool:
    """Whether every listed model still has the contents it had when the entry was written."""
    if not isinstance(dependencies, list):
        raise _RefusedError
    budget = _Budget()
    for item in dependencies:
        if not (isinstance(item, list) and len(item) == 2 and isinstance(item[0], str)):
            raise _RefusedError
        if _digest(Path(item[0]), budget) != item[1]:
            return False
    return True


# -- reading and writing entries ----------------------------------------------------------------


def _root() -> Path:
    return cache_folder(FOLDER)


def _read(folder: Path, key: str) -> Cached | None:
    """The entry in ``folder`` if it is sound and still current; None if there is none;
    :class:`_RefusedError` if it must not be used."""
    from fmionnx.compile.systemfile import CompiledFileError, decode_value, from_json

    root = folder.parent
    if not (folder / ENTRY).exists():
        return None
    check_private_folder(root)
    check_private_folder(folder)
    data = read_private(folder / ENTRY, MAX_ENTRY_BYTES)
    claimed, _, body = data.partition(b"\n")
    if not signed_by(user_key(root, make=False), body, claimed.decode("ascii", "replace")):
        raise _RefusedError
    entry = json.loads(body)
    if not isinstance(entry, dict) or entry.get("format") != [FORMAT, VERSION]:
        raise _RefusedError
    if entry.get("key") != key or not _unchanged(entry.get("dependencies")):
        return None
    try:
        system = from_json(str(entry.get("system")), origin="the compile cache")
        diagnostics = decode_value(tuple[Diagnostic, ...], entry.get("diagnostics"), "diagnostics")
    except CompiledFileError:
        raise _RefusedError from None
    listed = {item[0] for item in entry["dependencies"]}
    if any(str(c.path) not in listed and str(c.path.parent) not in listed for c in _models(system)):
        raise _RefusedError  # a model no lookup hashed: never run a file this entry only names
    touch(folder)
    return Cached(system, diagnostics, entry.get("payload"))


def _models(system: CompiledSystem) -> Iterator[Component]:
    from fmionnx.compile.systemfile import has_model_file

    return (c for c in system.components if has_model_file(c))


def _write(
    key: str,
    system: CompiledSystem,
    diagnostics: Sequence[Diagnostic],
    dependencies: list[Dependency],
    payload: object,
) -> None:
    from fmionnx.compile.systemfile import encode_value, to_json
    from fmionnx.core.resources import CACHE_DAYS, COMPILE_CACHE_BYTES

    max_bytes, max_days = COMPILE_CACHE_BYTES.value(), CACHE_DAYS.value()
    root = _root()
    root.mkdir(mode=0o700, parents=True, exist_ok=True)
    check_private_folder(root)
    entry = {
        "format": [FORMAT, VERSION],
        "key": key,
        "dependencies": dependencies,
        "diagnostics": encode_value(list(diagnostics)),
        "system": to_json(system),
        "payload": payload,
    }
    body = json.dumps(entry, separators=(",", ":")).encode()
    data = signature(user_key(root, make=True), body).encode() + b"\n" + body
    folder = root / key
    with contextlib.suppress(FileNotFoundError):
        try:
            check_private_folder(folder)
        except _RefusedError:  # someone else's, or opened to others: not ours to write into
            discard(folder)
    with contextlib.suppress(FileExistsError):
        folder.mkdir(mode=0o700)
    check_private_folder(folder)
    write_private(folder / ENTRY, data)  # readers see the old entry or the new one, whole
    evict(root, keep=folder, max_bytes=max_bytes, max_days=max_days)
