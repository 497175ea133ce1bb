"""Native fast path: runs of FMI 2 and FMI 3 co-simulation FMUs stepped by one small C function.

``fmi2_group.c`` is built into a library when fmionnx is installed (``setup.py``), or on
request at run time (:mod:`.runbuild`); :mod:`.kernel` loads it after checking its build
manifest (:mod:`.manifest`) and its ABI, :mod:`.grouping` decides which components it steps,
:mod:`.group` drives one group and reports faults like the Python path. Results are
bit-identical to the Python path; ``FMIONNX_NATIVE=0`` turns it off.

The package itself imports nothing: an isolated child loads :mod:`.kernel` without
:mod:`.grouping`, which brings the compiled system's types (and pydantic) with it.
"""
