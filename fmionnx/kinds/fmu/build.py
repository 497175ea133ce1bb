"""Compile source-code FMUs into binary FMUs for this platform (``fmionnx build-fmu``).

This answers the paper's pain that FMUs exported on Windows did not run on Linux: any FMU that
ships its C sources (FMI 2 ``<SourceFiles>`` or FMI 3 / 2.0.4 ``buildDescription.xml``) is
compiled here with cmake and the system C compiler. The recipe (sources, include folders,
preprocessor definitions) is the FMU's own (:mod:`.buildrecipe`); for FMI 3 the build defines
the headers' macro that exports unprefixed function names, as the standard asks of a shared
library. cmake runs as a child process whose output is shown only when the build fails.

The built FMU is the source FMU with this platform's binary folder (``binaries/linux64`` for
FMI 2, ``binaries/x86_64-linux`` for FMI 3) replaced by the new library: binaries for other
platforms stay, so a vendor's FMU still runs where it ran before. Its zip comment says that
``build-fmu`` wrote it (:data:`BUILT_MARK`): the command replaces an existing file at its
output only when that is one of its own (:func:`check_build_target`).
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.archive import safe_extract, write_deterministic_zip
from fmionnx.core.errors import BuildError, ModelError
from fmionnx.core.safewrite import atomic_binary, refuse
from fmionnx.core.scratch import scratch
from fmionnx.kinds.fmu.buildcheck import check_build_inputs, copy_source_folder
from fmionnx.kinds.fmu.buildrecipe import BuildRecipe, read_recipe

#: The CMake project every source FMU is compiled with; the FMU's recipe fills its cache.
_CMAKE_LISTS = """cmake_minimum_required(VERSION 3.15)
project(fmionnx_source_fmu LANGUAGES C ${FMI_EXTRA_LANGUAGES})
add_library(fmu SHARED ${FMI_SOURCES})
set_target_properties(fmu PROPERTIES PREFIX "" SUFFIX ".so" OUTPUT_NAME "${FMI_MODEL_IDENTIFIER}")
target_compile_definitions(fmu PRIVATE ${FMI_DEFINITIONS})
target_include_directories(fmu PRIVATE ${FMI_INCLUDE_DIRS})
if(UNIX)
  target_link_libraries(fmu PRIVATE m)
endif()
install(TARGETS fmu LIBRARY DESTINATION "${FMI_TARGET_DIR}")
"""

#: The binary folder per FMI major version (FMI 2 platform name, FMI 3 platform tuple).
_TARGET_FOLDER = {2: "linux64", 3: "x86_64-linux"}

#: The zip comment of every FMU ``build-fmu`` writes: how it knows an output is its own.
BUILT_MARK = b"fmionnx build-fmu"


def _standard_headers() -> Path:
    """fmpy's copy of the FMI 2 and 3 headers: the fallback for FMUs that ship none."""
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def _cmake_cache(recipe: BuildRecipe, unpacked: Path) -> str:
    """The CMake cache of one build: ``NAME:TYPE=value`` lines (no value holds a line break)."""
    sources = unpacked / "sources"
    includes = [(sources / name).as_posix() for name in recipe.include_dirs]
    includes.append(_standard_headers().as_posix())
    entries = {
        "CMAKE_BUILD_TYPE:STRING": "Release",
        "FMI_MODEL_IDENTIFIER:STRING": recipe.model_identifier,
        "FMI_SOURCES:STRING": ";".join((sources / name).as_posix() for name in recipe.sources),
        "FMI_INCLUDE_DIRS:STRING": ";".join(includes),
        "FMI_DEFINITIONS:STRING": ";".join(recipe.definitions),
        "FMI_TARGET_DIR:STRING": (
            unpacked / "binaries" / _TARGET_FOLDER[recipe.fmi_major]
        ).as_posix(),
        "FMI_EXTRA_LANGUAGES:STRING": ";".join(
            language for language, _ in recipe.standards if language != "C"
        ),
    }
    for language, standard in recipe.standards:
        entries[f"CMAKE_{language}_STANDARD:STRING"] = standard
    return "".join(f"{key}={value}\n" for key, value in entries.items())


def _run(command: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(command, capture_output=True, text=True, check=False)


def default_output(source: Path) -> Path:
    """``Model/`` -> ``Model.fmu`` beside it; ``Model.fmu`` -> ``Model.built.fmu``.

    A path without a name of its own (``.``, ``..``, ``""``) is resolved first: ``.`` inside
    ``Model/`` writes ``../Model.fmu``. One that has none even then (``/``) is a ValueError
    whose message says to name the output.
    """
    if source.name in ("", ".", ".."):
        source = source.resolve()
    if not source.name:
        msg = f"`{source}` has no name to derive the output's from: name it with --output"
        raise ValueError(msg)
    if source.suffix == ".fmu":
        return source.with_name(source.stem + ".built.fmu")
    return source.with_name(source.name + ".fmu")


def written_by_build(path: Path) -> bool:
    """``path`` is a regular file (not a link) holding a zip archive ``build-fmu`` wrote."""
    if path.is_symlink() or not path.is_file():
        return False
    try:
        with zipfile.ZipFile(path) as archive:
            return archive.comment == BUILT_MARK
    except (OSError, zipfile.BadZipFile, ValueError, EOFError):
        return False


def check_build_target(output: Path, *, force: bool) -> None:
    """Raise :class:`~fmionnx.core.safewrite.OverwriteRefusedError` when ``output`` holds
    something ``build-fmu`` did not write (a vendor's FMU, a file of the user's, a link);
    ``force`` allows it. Rebuilding over an earlier build is the normal loop."""
    if force or not (output.exists() or output.is_symlink()):
        return
    if not written_by_build(output):
        raise refuse(output, "exists and was not written by `fmionnx build-fmu`")


def _replace_target_binaries(unpacked: Path, fmi_major: int) -> None:
    """Remove this platform's binary folder (the build writes it anew); keep the others."""
    target = unpacked / "binaries" / _TARGET_FOLDER[fmi_major]
    if target.is_symlink() or target.is_file():
        target.unlink()
    elif target.is_dir():
        shutil.rmtree(target)


def _write_built(unpacked: Path, work: Path, output: Path) -> None:
    """Zip ``unpacked`` into ``output`` (atomically) with :data:`BUILT_MARK` as its comment."""
    built = work / "built.fmu"
    write_deterministic_zip(unpacked, built)
    with zipfile.ZipFile(built, "a") as archive:
        archive.comment = BUILT_MARK
    output.parent.mkdir(parents=True, exist_ok=True)
    with built.open("rb") as source, atomic_binary(output) as stream:
        shutil.copyfileobj(source, stream)


def build_fmu(source: Path, output: Path | None = None) -> Path:
    """Build the source FMU at ``source`` (folder or ``.fmu``) into ``output``; return it.

    Raises ModelError for an unusable source (missing model description or sources, a link
    in a source folder that is broken or leads out of it: see
    :func:`~.buildcheck.copy_source_folder`) and BuildError, with the compiler log, when compilation fails. ``output`` is written
    atomically: a failed build leaves no half-written FMU. Binaries of other platforms are
    kept. Whether ``output`` may be replaced is the caller's to check
    (:func:`check_build_target`); this writes it.
    """
    output = output or default_output(source)
    if source.is_dir() and not (source / "modelDescription.xml").is_file():
        msg = f"`{source}` has no modelDescription.xml"  # checked before copying the folder
        raise ModelError(
            codes.BAD_MODEL, msg, hint="a source FMU holds modelDescription.xml and sources/"
        )
    with scratch("build") as tmp:
        unpacked = tmp / "fmu"
        if source.is_dir():
            copy_source_folder(source, unpacked)  # its links checked: nothing from outside
        elif source.is_file():
            safe_extract(source, unpacked)
        else:
            msg = f"`{source}` does not exist"
            raise ModelError(codes.FILE_NOT_FOUND, msg)
        if not (unpacked / "modelDescription.xml").is_file():
            msg = f"`{source}` has no modelDescription.xml"
            raise ModelError(
                codes.BAD_MODEL, msg, hint="a source FMU holds modelDescription.xml and sources/"
            )
        if not (unpacked / "sources").is_dir():
            msg = f"`{source}` has no sources/ folder: there is nothing to compile"
            raise ModelError(codes.NO_BINARY, msg)
        check_build_inputs(unpacked)
        recipe = read_recipe(unpacked)
        _replace_target_binaries(unpacked, recipe.fmi_major)
        project, work = tmp / "project", tmp / "cmake"
        project.mkdir()
        work.mkdir()
        (project / "CMakeLists.txt").write_text(_CMAKE_LISTS)
        (work / "CMakeCache.txt").write_text(_cmake_cache(recipe, unpacked))
        log = ""
        for command in (
            ["cmake", "-S", str(project), "-B", str(work)],
            ["cmake", "--build", str(work), "--target", "install"],
        ):
            try:
                result = _run(command)
            except OSError as exc:
                msg = f"building `{source}` needs cmake: {exc.strerror}"
                raise BuildError(msg, "") from None
            log += result.stdout + result.stderr
            if result.returncode != 0:
                msg = f"building `{source}` failed (exit {result.returncode})"
                raise BuildError(msg, log[-8000:])
        _write_built(unpacked, tmp, output)
    return output
