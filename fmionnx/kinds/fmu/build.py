"""Compile source-code FMUs into binary FMUs for this platform (``fmionnx build-fmu``).

This answers the paper's pain that FMUs exported on Windows did not run on Linux: any FMU that
ships its C sources (FMI 2 ``<SourceFiles>`` or FMI 3 / 2.0.4 ``buildDescription.xml``) is
compiled here with cmake and the system C compiler. The recipe (sources, include folders,
preprocessor definitions) is the FMU's own (:mod:`.buildrecipe`); for FMI 3 the build defines
the headers' macro that exports unprefixed function names, as the standard asks of a shared
library. cmake runs as a child process whose output is shown only when the build fails.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from fmionnx.core import codes
from fmionnx.core.archive import safe_extract, write_deterministic_zip
from fmionnx.core.errors import BuildError, ModelError
from fmionnx.core.scratch import scratch
from fmionnx.kinds.fmu.buildcheck import check_build_inputs
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
    """``Model/`` -> ``Model.fmu`` beside it; ``Model.fmu`` -> ``Model.built.fmu``."""
    if source.suffix == ".fmu":
        return source.with_name(source.stem + ".built.fmu")
    return source.with_name(source.name + ".fmu")


def build_fmu(source: Path, output: Path | None = None) -> Path:
    """Build the source FMU at ``source`` (folder or ``.fmu``) into ``output``; return it.

    Raises ModelError for an unusable source (missing model description or sources) and
    BuildError, with the compiler log, when compilation fails. ``output`` is written
    atomically: a failed build leaves no half-written FMU.
    """
    output = output or default_output(source)
    with scratch("build") as tmp:
        unpacked = tmp / "fmu"
        if source.is_dir():
            shutil.copytree(source, unpacked)
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
        shutil.rmtree(unpacked / "binaries", ignore_errors=True)
        recipe = read_recipe(unpacked)
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
        write_deterministic_zip(unpacked, output)
    return output
