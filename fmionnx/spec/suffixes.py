"""The file suffixes of system files, apart from the front ends that read them.

Telling a system file from a lone model (``fmionnx validate FILE``) needs the suffixes only;
importing the front ends (:mod:`.frontends`) brings the YAML parser and the system-file
types of every kind, which a cached compile or a lone model never uses.
"""

from __future__ import annotations

#: Suffixes of SSP files: a format without a step size, so the compiler has a default for it.
SSP_SUFFIXES = frozenset({".ssp", ".ssd"})
#: Suffixes of YAML system files.
YAML_SUFFIXES = frozenset({".yaml", ".yml"})
#: Every suffix a front end reads (:data:`.frontends.FRONTENDS` has one entry per suffix).
SYSTEM_SUFFIXES = SSP_SUFFIXES | YAML_SUFFIXES
