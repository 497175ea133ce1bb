"""Write a raw :class:`SystemSpec` back as a YAML system file (``fmionnx convert``).

The raw spec, not the compiled IR, is written: it is what the user (or the other tool)
said, with defaults left out, so the file stays as short as a hand-written one. Component
paths are rewritten relative to the new file; models that live only inside an unpacked SSP
archive are copied next to it first (``<stem>_files/``, same layout as in the archive).
Both the YAML file and that folder appear only when everything was written.
"""

from __future__ import annotations

import io
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ruamel.yaml import YAML

from fmionnx.compile.resolve import model_path
from fmionnx.core.errors import FmionnxError
from fmionnx.core.safewrite import refuse
from fmionnx.spec.model import ConnectionSpec, SystemSpec
from fmionnx.spec.ssp_archive import SSD_NAME


class ConvertError(FmionnxError):
    """The YAML file (or its resource folder) cannot be written."""


#: Written into every ``<stem>_files/`` folder fmionnx extracts: the folder is replaced
#: wholesale on the next convert, so only a folder carrying this marker is ours to replace.
FILES_MARKER = ".fmionnx-convert"
MARKER_TEXT = "Extracted by `fmionnx convert`; replaced by the next convert to this file.\n"

#: Every YAML file ``fmionnx convert`` writes starts with this (see ``convert_header``).
HEADER_MARK = "by `fmionnx convert`."


def convert_header(source: str) -> str:
    """The first line of a converted file; it also tells a later convert the file is ours."""
    return f"# Converted from {source} {HEADER_MARK}\n"


def _written_by_convert(output: Path) -> bool:
    """``output`` is a regular file whose first line is a convert header."""
    if output.is_symlink() or not output.is_file():
        return False
    try:
        with output.open(encoding="utf-8") as stream:
            first = stream.readline()
    except (OSError, UnicodeDecodeError):
        return False
    return first.startswith("# Converted from ") and first.rstrip().endswith(HEADER_MARK)


def check_convert_targets(output: Path, *, extracts: bool, force: bool) -> None:
    """Raise :class:`OverwriteRefusedError` unless every name convert replaces is its own.

    ``extracts``: the models of an SSP go to ``<stem>_files/``, which is replaced wholesale.
    Called before anything is written, so a refusal leaves everything as it was.
    """
    if force:
        return
    if output.is_symlink() or (output.exists() and not _written_by_convert(output)):
        raise refuse(output, "exists and was not written by `fmionnx convert`")
    files = output.parent / f"{output.stem}_files"
    if extracts and (files.exists() or files.is_symlink()):
        ours = not files.is_symlink() and files.is_dir() and (files / FILES_MARKER).is_file()
        if not ours:
            raise refuse(files, "exists and was not extracted by `fmionnx convert`")


def spec_data(spec: SystemSpec, paths: dict[str, str]) -> dict[str, Any]:
    """Plain data of ``spec`` in system-file key order, with ``paths`` per component.

    A component missing from ``paths`` has no model file and is written without ``path``.
    """
    data: dict[str, Any] = {"fmionnx": spec.fmionnx, "name": spec.name}
    if spec.description:
        data["description"] = spec.description
    run = spec.run.model_dump(mode="json", exclude_none=True)
    if run:
        data["run"] = run
    components: dict[str, Any] = {}
    for name, component in spec.components.items():
        options = component.model_dump(mode="json", by_alias=True, exclude_defaults=True)
        options.pop("kind", None)
        options.pop("path", None)
        path = {"path": paths[name]} if name in paths else {}
        components[name] = {"kind": component.kind, **path, **options}
    data["components"] = components
    connections: list[Any] = []
    for entry in spec.connections:
        if isinstance(entry, ConnectionSpec) and (
            entry.factor != 1.0 or entry.offset != 0.0 or not entry.convert_units
        ):
            connections.append(
                entry.model_dump(mode="json", by_alias=True, exclude={"convert_units"})
                | ({} if entry.convert_units else {"convert_units": False})
            )
        elif isinstance(entry, ConnectionSpec):
            connections.append(f"{entry.from_} -> {entry.to}")
        else:
            connections.append(entry)
    if connections:
        data["connections"] = connections
    if spec.inputs:
        data["inputs"] = {
            name: {
                "to": [
                    item
                    if isinstance(item, str)
                    else item.model_dump(mode="json", exclude_defaults=True)
                    for item in entry.to
                ],
                **({"value": entry.value} if entry.value is not None else {}),
                **({"description": entry.description} if entry.description else {}),
            }
            for name, entry in spec.inputs.items()
        }
    extra = spec.model_dump(
        mode="json",
        by_alias=True,
        exclude_defaults=True,
        include={"record", "plots", "checks", "ros2"},
    )
    data.update(extra)
    return data


def dump_yaml(data: dict[str, Any], header: str = "") -> str:
    """YAML text of plain data (block style, floats round-trip exactly)."""
    yaml = YAML(typ="safe", pure=True)
    yaml.default_flow_style = False
    yaml.sort_base_mapping_type_on_output = False  # type: ignore[assignment]
    stream = io.StringIO()
    yaml.dump(data, stream)
    return header + stream.getvalue()


def _relative(target: Path, folder: Path) -> str:
    return Path(os.path.relpath(target.resolve(), folder.resolve())).as_posix()


def write_yaml_system(
    spec: SystemSpec,
    base: Path,
    output: Path,
    *,
    archive_root: Path | None = None,
    header: str = "",
    force: bool = False,
) -> None:
    """Write ``spec`` (paths relative to ``base``) to ``output`` atomically.

    ``archive_root`` is the unpacked SSP the spec's models live in; its content is copied to
    ``<stem>_files/`` beside ``output``. Without ``force``, a file or folder at those names
    that convert did not write is an :class:`OverwriteRefusedError` and nothing is written.
    """
    check_convert_targets(output, extracts=archive_root is not None, force=force)
    folder = output.parent.resolve()
    folder.mkdir(parents=True, exist_ok=True)
    files = folder / f"{output.stem}_files"
    staging: Path | None = None
    temporary: Path | None = None
    try:
        paths: dict[str, str] = {}
        if archive_root is not None:
            staging = Path(tempfile.mkdtemp(prefix=".convert-", dir=folder))
            ignore = shutil.ignore_patterns(SSD_NAME)
            shutil.copytree(archive_root, staging, dirs_exist_ok=True, ignore=ignore)
            (staging / FILES_MARKER).write_text(MARKER_TEXT, encoding="utf-8")
        for name, component in spec.components.items():
            if not component.has_model_file:
                continue
            source = model_path(base, component.path).resolve()
            if archive_root is not None and source.is_relative_to(archive_root.resolve()):
                inside = source.relative_to(archive_root.resolve())
                paths[name] = _relative(files / inside, folder)
            else:
                paths[name] = _relative(source, folder)
        text = dump_yaml(spec_data(spec, paths), header)
        with tempfile.NamedTemporaryFile(
            "w", encoding="utf-8", dir=folder, prefix=".convert-", suffix=".yaml", delete=False
        ) as stream:
            stream.write(text)
            temporary = Path(stream.name)
        if output.is_dir():
            msg = f"`{output}` is a folder"
            raise IsADirectoryError(msg)
        if staging is not None:
            if files.is_symlink() or files.is_file():
                files.unlink()  # only with --force (checked above): the link, not its target
            elif files.exists():
                shutil.rmtree(files)
            staging.rename(files)
            staging = None
        temporary.replace(output)
        temporary = None
    except OSError as exc:
        msg = f"cannot write `{output}`: {exc}"
        raise ConvertError(msg) from None
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        if temporary is not None:
            temporary.unlink(missing_ok=True)
