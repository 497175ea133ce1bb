from __future__ import annotations

import io

import pytest

from fmionnx.reporters import REPORTER_BY_NAME, FileResult
from fmionnx.reporters.github import escape_data, escape_property


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("50% done", "50%25 done"),
        ("two\nlines\r", "two%0Alines%0D"),
        ("a:b,c", "a:b,c"),
        ("%0A", "%250A"),
    ],
)
def test_message_escapes_percent_and_line_breaks_only(text: str, expected: str) -> None:
    assert escape_data(text) == expected


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("C:\\x,y", "C%3A\\x%2Cy"),
        ("E031 dtype", "E031 dtype"),
        ("100%\n", "100%25%0A"),
    ],
)
def test_property_also_escapes_colon_and_comma(text: str, expected: str) -> None:
    assert escape_property(text) == expected


def test_annotations_carry_file_line_col_title_and_severity(two_files: list[FileResult]) -> None:
    out = io.StringIO()
    REPORTER_BY_NAME["github"].render(two_files, out, color=True)
    lines = out.getvalue().splitlines()
    assert lines[0] == (
        "::error file=a.yaml,line=7,col=5,title=E031 dtype::cannot connect `net.label_out` "
        "(string) to `gain.u` (float64)%0Anote: models/modelDescription.xml:36:12: `u` is "
        "declared here%0Ahint: connect a numeric output"
    )
    assert lines[1].startswith("::warning file=a.yaml,line=5,col=3,title=W030 unconnected-input::")
    assert lines[2].endswith("::component `plant` has no port `y2`, value: 50%25")
    assert (
        lines[3]
        == "::error file=sub/b.yaml,title=E010 file-not-found::system file problem without a position"
    )
    assert lines[4].startswith(
        "::notice file=sub/b.yaml,line=4,col=3,title=I080 lock-binary-changed::"
    )
    assert lines[5] == "3 errors, 1 warning in 2 files"
