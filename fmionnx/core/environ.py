"""Environment variables set for a while, then put back as they were (set or not)."""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager


def put_back(before: Mapping[str, str | None]) -> None:
    """Give each variable of ``before`` its value there again; None: unset it."""
    for key, value in before.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


@contextmanager
def variables_set(values: Mapping[str, str]) -> Iterator[None]:
    """``values`` in this process's environment for the ``with`` block only (what a process
    started meanwhile inherits)."""
    before = {key: os.environ.get(key) for key in values}
    os.environ.update(values)
    try:
        yield
    finally:
        put_back(before)
