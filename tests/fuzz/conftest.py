"""Fuzzing profiles and the folders the fuzzers work in.

Two hypothesis profiles, registered here (defined in :func:`tests.fuzz.harness.register_profiles`)
and chosen per property by :func:`tests.fuzz.harness.fuzz_settings`
(never loaded globally, so the other property tests of the suite keep their own settings):

* ``fuzz-short`` (``make test``): a few dozen examples per property, derandomized and not
  shrunk, so the suite stays within about a minute and a failure replays on every machine;
* ``fuzz-long`` (``make fuzz``, ``FMIONNX_FUZZ=long``): a hundred times as many, random, so
  each run explores inputs no earlier run tried; failures are shrunk to a small input and
  print the blob that replays them.

Neither keeps an example database: the fuzzers must not write into the repository, and a
failure's input is printed in full by the property itself.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.fuzz.harness import register_profiles

register_profiles()


@pytest.fixture(scope="module", autouse=True)
def fuzz_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """SSP archives unpack into a cache of this module's own, never the user's.

    Module-scoped (hypothesis runs many examples per test function, and function-scoped
    fixtures are not reset between them), set through a MonkeyPatch context of its own.
    """
    cache = tmp_path_factory.mktemp("fuzz-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("FMIONNX_CACHE", str(cache))
        yield cache
