"""Output paths given on the command line, checked before any work starts (exit 2 with the
option's name; the rules are :mod:`fmionnx.pipeline.outputs`')."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from fmionnx.cli.app import fail, refused
from fmionnx.pipeline import outputs


def check_output_file(path: Path, option: str) -> Path:
    """``path`` can be written as a file (its folder is created); else exit 2."""
    with refused():
        return outputs.check_output_file(path, option)


def check_output_folder(path: Path, option: str) -> Path:
    """``path`` is (or can be created as) a writable folder; else exit 2."""
    with refused():
        return outputs.check_output_folder(path, option)


def refuse_an_input(output: Path, inputs: Iterable[Path], option: str = "--output") -> None:
    """Exit 2 when ``output`` is one of the files the command reads (the system file, a
    model): a derived file (a graph, a launch file) written over its own source destroys
    what the user wrote. Any other existing file is replaced, never through a link."""
    if not output.exists():
        return
    for source in inputs:
        try:
            same = output.samefile(source)
        except OSError:
            continue
        if same:
            also = "" if str(source) == str(output) else f" (`{source}`)"
            msg = f"{option} `{output}` is a file this command reads{also}: choose another name"
            raise fail(msg)


def write_derived(output: Path, data: str | bytes, option: str = "--output") -> None:
    """Write ``data`` (text as UTF-8) to ``output`` atomically, replacing a link at the name
    itself, never the file it points to (:mod:`fmionnx.core.safewrite`); a refusal of the
    file system is one line and exit 1."""
    from fmionnx.cli.app import ExitCode
    from fmionnx.core.safewrite import write_bytes_atomic, write_text_atomic

    try:
        if isinstance(data, str):
            write_text_atomic(output, data)
        else:
            write_bytes_atomic(output, data)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        raise fail(f"{option} `{output}`: cannot write it ({reason})", ExitCode.PROBLEMS) from None
