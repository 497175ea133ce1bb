"""``fmionnx graph`` (being written)."""
