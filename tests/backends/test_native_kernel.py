"""Which native kernel library is loaded, and which is refused: manifest hash, source, ABI.

The installed library is the one ``pip install`` (``make setup``) built beside
``fmionnx/runtime/native/kernel.py``; these tests fail when it is missing or does not fit.
Tampered copies are made in ``tmp_path``: a file is always replaced by a new one, never
rewritten in place, since this process may have the original mapped.
"""

from __future__ import annotations

import ctypes
import json
import re
import shutil
from pathlib import Path

import pytest

import fmionnx
from fmionnx.results import write_results
from fmionnx.runtime.native import kernel, manifest, runbuild
from fmionnx.runtime.native.manifest import LIBRARY_NAME, MANIFEST_NAME, sha256_of
from fmionnx.runtime.result import RunStatus

SOURCE_TEXT = kernel.SOURCE.read_text(encoding="utf-8")


@pytest.fixture(autouse=True)
def caches(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Path:
    """Every cache location in tmp_path, so a test that writes one is seen doing so."""
    root = tmp_path / "caches"
    monkeypatch.setenv("FMIONNX_CACHE", str(root / "fmionnx"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(root / "xdg"))
    monkeypatch.setenv("HOME", str(root / "home"))
    monkeypatch.delenv("FMIONNX_NATIVE", raising=False)
    monkeypatch.delenv("FMIONNX_CC", raising=False)
    return root


def _replace(path: Path, data: bytes) -> None:
    partial = path.with_name(path.name + ".new")
    partial.write_bytes(data)
    partial.replace(path)


def _installed_copy(folder: Path) -> Path:
    folder.mkdir()
    for name in (LIBRARY_NAME, MANIFEST_NAME):
        shutil.copyfile(kernel.INSTALLED / name, folder / name)
    return folder


def _built_from(tmp_path: Path, text: str) -> tuple[Path, Path]:
    """(folder with library and manifest, source) for a changed copy of the C source,
    compiled as ``FMIONNX_NATIVE=build`` would (so its manifest is right)."""
    source = tmp_path / "changed" / "fmi2_group.c"
    source.parent.mkdir()
    source.write_text(text, encoding="utf-8")
    folder = runbuild.build_in_cache(source)
    assert isinstance(folder, Path), folder
    return folder, source


def _gain_chain(fixture_fmu, write_system) -> Path:
    gain = fixture_fmu("Gain")
    return write_system(
        f"""
fmionnx: 1
name: gains
run: {{stop: 0.05, step: 0.01}}
components:
  g0: {{kind: fmu, path: {gain}, parameters: {{u: 1.0}}}}
  g1: {{kind: fmu, path: {gain}}}
connections:
  - g0.y -> g1.u
record: [g1.y]
"""
    )


def test_installed_library_is_found_and_fits_the_ctypes_mirrors() -> None:
    loaded = kernel.load_installed()
    assert isinstance(loaded, kernel.Kernel), loaded
    assert loaded.origin == "installed"
    assert loaded.path == kernel.INSTALLED / LIBRARY_NAME
    assert loaded.sha256 == sha256_of(loaded.path)
    manifest = json.loads((kernel.INSTALLED / MANIFEST_NAME).read_text(encoding="utf-8"))
    assert manifest["built_by"] == "setup.py build_ext"
    assert manifest["source_sha256"] == sha256_of(kernel.SOURCE)
    assert kernel.abi_problem(ctypes.CDLL(str(loaded.path))) is None
    # one entry per struct and per field of the eleven mirrors, then the element types' sizes
    assert len(kernel.expected_layout()) == 7 + 8 + 13 + 8 + 7 + 7 + 4 + 9 + 8 + 11 + 4 + 19 + 11


def test_tampered_library_is_refused(tmp_path: Path) -> None:
    folder = _installed_copy(tmp_path / "copy")
    assert isinstance(kernel.load_library(folder, "installed"), kernel.Kernel)
    library = folder / LIBRARY_NAME
    _replace(library, library.read_bytes() + b"\0")
    reason = kernel.load_library(folder, "installed")
    assert isinstance(reason, str)
    assert re.search(r"is not the library its build recorded .*refusing to load it", reason)


def test_a_verified_library_is_hashed_again_only_once_a_file_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sweep's worker checks the kernel at every case: it hashes once per process, and a
    source edited in place afterwards (an editable install) is still refused."""
    folder = _installed_copy(tmp_path / "copy")
    source = tmp_path / "fmi2_group.c"
    source.write_text(SOURCE_TEXT, encoding="utf-8")
    hashed: list[Path] = []
    real = manifest.sha256_of

    def counted(path: Path) -> str:
        hashed.append(path)
        return real(path)

    monkeypatch.setattr(manifest, "sha256_of", counted)
    for _ in range(3):
        assert isinstance(kernel.load_library(folder, "installed", source=source), kernel.Kernel)
    assert len(hashed) == 2  # the library and the source, the first time only
    with source.open("a", encoding="utf-8") as stream:
        stream.write("/* edited */\n")
    reason = kernel.load_library(folder, "installed", source=source)
    assert isinstance(reason, str)
    assert "was built from another fmi2_group.c" in reason


def test_library_without_manifest_is_refused(tmp_path: Path) -> None:
    folder = _installed_copy(tmp_path / "copy")
    (folder / MANIFEST_NAME).unlink()
    reason = kernel.load_library(folder, "installed")
    assert isinstance(reason, str)
    assert f"has no readable build manifest {MANIFEST_NAME}" in reason


def test_library_built_from_another_source_is_refused(tmp_path: Path) -> None:
    """An editable install whose fmi2_group.c changed after the build."""
    folder = _installed_copy(tmp_path / "copy")
    edited = tmp_path / "fmi2_group.c"
    edited.write_text(SOURCE_TEXT + "\n/* edited */\n", encoding="utf-8")
    reason = kernel.load_library(folder, "installed", source=edited)
    assert isinstance(reason, str)
    assert "was built from another fmi2_group.c" in reason


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        (
            ("#define FX_ABI_VERSION 4u", "#define FX_ABI_VERSION 5u"),
            r"its ABI version is 5, this fmionnx expects 4",
        ),
        (
            (
                "    size_t n_transfers;\n} fx_member;",
                "    size_t n_transfers;\n    int x;\n} fx_member;",
            ),
            r"sizeof\(fx_member\) is \d+ in the library, \d+ in the ctypes mirror",
        ),
        (
            ("    double factor;\n    double offset;", "    double offset;\n    double factor;"),
            r"offsetof\(fx_transfer, factor\) is \d+ in the library, \d+ in the ctypes mirror",
        ),
    ],
)
def test_library_with_another_abi_is_refused(
    tmp_path: Path, change: tuple[str, str], reason: str
) -> None:
    assert change[0] in SOURCE_TEXT
    folder, source = _built_from(tmp_path, SOURCE_TEXT.replace(*change))
    refused = kernel.load_library(folder, "build", source=source)
    assert isinstance(refused, str)
    assert re.search(reason + r"; refusing to use it$", refused), refused


def test_library_of_an_older_source_without_abi_functions_is_refused(tmp_path: Path) -> None:
    cut = SOURCE_TEXT.index("/* The struct layouts Python must mirror")
    folder, source = _built_from(tmp_path, SOURCE_TEXT[:cut])
    refused = kernel.load_library(folder, "build", source=source)
    assert isinstance(refused, str)
    assert "exports no fx_abi_version/fx_abi_layout" in refused


@pytest.mark.parametrize("problem", ["missing", "tampered"])
def test_run_without_a_usable_installed_library_says_why_in_run_json(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, tmp_path: Path, problem: str
) -> None:
    folder = _installed_copy(tmp_path / "installed")
    if problem == "missing":
        (folder / LIBRARY_NAME).unlink()
        expected = r"native kernel libfmi2_group\.so is not installed .*`make setup`"
    else:
        _replace(folder / LIBRARY_NAME, b"not a library")
        expected = r"is not the library its build recorded"
    monkeypatch.setattr(kernel, "INSTALLED", folder)
    system = fmionnx.load(_gain_chain(fixture_fmu, write_system))
    result = system.run(isolate="none")
    assert result.status is RunStatus.COMPLETED
    assert result["g1.y"][-1] == 4.0
    write_results(result, system.compiled, tmp_path / "out")
    execution = json.loads((tmp_path / "out" / "run.json").read_text())["execution"]
    assert execution["native"] is False
    assert execution["native_library"] is None
    assert re.search(expected, execution["native_reason"])


def test_default_run_uses_the_installed_library_and_no_cache(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, caches: Path
) -> None:
    def no_build(source: Path) -> str:
        raise AssertionError(f"built {source} without FMIONNX_NATIVE=build")

    monkeypatch.setattr(kernel, "build_in_cache", no_build)
    result = fmionnx.load(_gain_chain(fixture_fmu, write_system)).run(isolate="none")
    assert result.details["native"] is True
    assert result.details["native_library"] == "installed"
    assert result.details["native_sha256"] == sha256_of(kernel.INSTALLED / LIBRARY_NAME)
    assert not (caches / "fmionnx" / "native").exists()  # (the compile cache may be there)


def test_opt_in_build_is_cached_with_its_manifest_and_checked(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch, caches: Path
) -> None:
    monkeypatch.setenv("FMIONNX_NATIVE", "build")
    path = _gain_chain(fixture_fmu, write_system)
    result = fmionnx.load(path).run(isolate="none")
    assert result.details["native_library"] == "build"
    assert result["g1.y"][-1] == 4.0
    (folder,) = (caches / "fmionnx" / "native").iterdir()
    assert sorted(p.name for p in folder.iterdir()) == sorted((LIBRARY_NAME, MANIFEST_NAME))
    manifest = json.loads((folder / MANIFEST_NAME).read_text(encoding="utf-8"))
    assert manifest["built_by"] == "FMIONNX_NATIVE=build"
    assert manifest["sha256"] == sha256_of(folder / LIBRARY_NAME) == result.details["native_sha256"]
    # a second run reuses the cached library
    assert fmionnx.load(path).run(isolate="none").details["native_sha256"] == manifest["sha256"]
    # and refuses it once it is no longer the library that was built
    library = folder / LIBRARY_NAME
    _replace(library, library.read_bytes() + b"\0")
    again = fmionnx.load(path).run(isolate="none")
    assert again.details["native"] is False
    reason = str(again.details["native_reason"])
    assert "is not the library its build recorded" in reason
    assert reason.endswith(f"(delete {folder} to build it again)")
    assert again["g1.y"].tobytes() == result["g1.y"].tobytes()


def test_unknown_setting_keeps_the_python_path_and_says_so(
    fixture_fmu, write_system, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FMIONNX_NATIVE", "yes")
    result = fmionnx.load(_gain_chain(fixture_fmu, write_system)).run(isolate="none")
    assert result.details["native"] is False
    assert result.details["native_reason"] == "FMIONNX_NATIVE='yes' is none of 0, 1, build"
