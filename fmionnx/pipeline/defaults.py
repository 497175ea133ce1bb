"""Defaults every front end shows and applies (kept import-free: the CLI's help reads them)."""

#: Seconds of wall time between checkpoints (at least; they never cost more than a tenth).
CHECKPOINT_EVERY = 10.0
#: Seconds one step of a component may take before the run stops with a fault.
STEP_TIMEOUT = 60.0
