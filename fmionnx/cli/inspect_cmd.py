"""``fmionnx inspect`` (being written)."""
