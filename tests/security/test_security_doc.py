"""docs/security.md stays true: every limit with its default, every test it cites exists, and
every hostile-input test here is cited."""

from __future__ import annotations

import re

from fmionnx.core.resources import LIMITS
from tests.conftest import REPO

DOC = (REPO / "docs" / "security.md").read_text(encoding="utf-8")
CITED = re.compile(r"`(tests/[\w/]+\.py)::(\w+)`")


def test_every_limit_is_listed_with_its_variable_and_default() -> None:
    rows = [line for line in DOC.splitlines() if line.startswith("|")]
    for limit in LIMITS:
        (row,) = [r for r in rows if f"`{limit.variable}`" in r]
        assert re.search(rf"\b{limit.default}\b", row), (
            f"{limit.variable}: default not {limit.default}"
        )


def test_every_cited_test_exists() -> None:
    cited = CITED.findall(DOC)
    assert len(cited) > 40
    for file, name in cited:
        path = REPO / file
        assert path.is_file(), file
        assert re.search(rf"^def {name}\(", path.read_text(encoding="utf-8"), re.MULTILINE), (
            f"{file}::{name}"
        )


def test_every_hostile_input_test_is_cited() -> None:
    cited = set(CITED.findall(DOC))
    folder = REPO / "tests" / "security"
    for path in sorted(folder.glob("test_*.py")):
        if path.name == "test_security_doc.py":
            continue
        for name in re.findall(
            r"^def (test_\w+)\(", path.read_text(encoding="utf-8"), re.MULTILINE
        ):
            allowed = name in {
                "test_the_ratio_limit_can_be_raised",
                "test_real_fmus_stay_within_the_default_limits",
                "test_an_unchanged_unpacked_fmu_still_runs",
                "test_a_raised_limit_admits_the_array",
                "test_external_data_beside_the_model_runs",
                "test_entries_in_use_and_the_current_one_are_never_evicted",
                "test_folders_of_live_processes_and_of_other_names_are_kept",
            }  # the protections' other side: what must still work
            assert allowed or (f"tests/security/{path.name}", name) in cited, name


def test_native_code_rows_cite_the_isolation_tests() -> None:
    rows = [line for line in DOC.splitlines() if "tests/backends/test_isolation.py::" in line]
    for topic in ("crash", "hangs", "--sandbox", "network", "SIGKILL", "bit-identical"):
        assert any(topic in line for line in rows), topic
    assert "in progress" not in DOC
