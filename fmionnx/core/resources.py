"""Resource limits for files fmionnx did not write: one table, each limit changeable.

Users run models they did not write. A 23 KB FMU may declare an array of 10^9 elements, a
600 KB zip may expand to gigabytes, an SSD may be a gigabyte of XML. Each such input is
measured against a limit *before* memory or disk is spent on it, and refused with a
diagnostic that names the limit and how to raise it.

The defaults are far above what real models need. A user with a genuinely larger model
raises one limit with its environment variable (``FMIONNX_MAX_ARRAY_ELEMENTS=500000000``).
Environment variables rather than options, because the same limit must hold in every process
that opens the file: the CLI, the Python API, ROS 2 nodes and study workers, which inherit
the environment but not the command line. ``docs/security.md`` lists the table.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from fmionnx.core.errors import ModelError

#: The diagnostic code of a model that exceeds a resource limit.
LIMIT_CODE = "E008"


@dataclass(frozen=True, slots=True)
class ResourceLimit:
    """One limit: its default, the environment variable that changes it, what it bounds."""

    variable: str
    default: int
    unit: str
    bounds: str

    def value(self) -> int:
        """The limit in force: the environment variable when set, else the default.

        Raises ModelError (E008) for a setting that is not a positive whole number, rather
        than silently running without the limit.
        """
        text = os.environ.get(self.variable, "").strip()
        if not text:
            return self.default
        try:
            number = int(text.replace("_", ""))
        except ValueError:
            number = 0
        if number <= 0:
            msg = f"{self.variable}=`{text}` is not a positive whole number"
            raise ModelError(LIMIT_CODE, msg, hint=f"unset it to use the default {self.default}")
        return number

    def hint(self) -> str:
        """How to raise the limit, for the hint of the diagnostic that hit it."""
        return (
            f"the limit is {self.value()} {self.unit} ({self.bounds}); if the model is "
            f"genuine, raise it with the environment variable {self.variable}"
        )

    def exceeded(self, what: str) -> ModelError:
        """The E008 error for ``what`` (a phrase naming the measured amount) over the limit."""
        return ModelError(LIMIT_CODE, what, hint=self.hint())


MiB = 1024**2

#: Bytes all members of one archive (FMU, SSP) may expand to together.
ARCHIVE_BYTES = ResourceLimit(
    "FMIONNX_MAX_ARCHIVE_BYTES", 2 * 1024 * MiB, "bytes", "unpacked size of one archive"
)
#: Members of one archive.
ARCHIVE_MEMBERS = ResourceLimit(
    "FMIONNX_MAX_ARCHIVE_MEMBERS", 50_000, "members", "files and folders in one archive"
)
#: Unpacked size over archive size. Real FMUs and SSPs (binaries, XML) stay below 20.
ARCHIVE_RATIO = ResourceLimit(
    "FMIONNX_MAX_COMPRESSION_RATIO", 200, "to 1", "unpacked size over archive size"
)
#: Elements of one FMU variable or ONNX tensor (a 4K RGB image has 25 million).
ARRAY_ELEMENTS = ResourceLimit(
    "FMIONNX_MAX_ARRAY_ELEMENTS",
    64 * MiB,
    "elements",
    "elements of one FMU array variable or ONNX tensor",
)
#: Size of one SSP XML file (``.ssd``, ``.ssv``, ``.ssm``).
SSP_XML_BYTES = ResourceLimit(
    "FMIONNX_MAX_SSP_XML_BYTES", 64 * MiB, "bytes", "size of one .ssd/.ssv/.ssm file"
)
#: Size of one compiled-system file (``*.fmionnx.json``).
COMPILED_FILE_BYTES = ResourceLimit(
    "FMIONNX_MAX_COMPILED_BYTES", 64 * MiB, "bytes", "size of one *.fmionnx.json file"
)
#: Size of the SSP unpack cache; least recently used archives are removed beyond it.
CACHE_BYTES = ResourceLimit(
    "FMIONNX_CACHE_MAX_BYTES", 4 * 1024 * MiB, "bytes", "size of the SSP unpack cache"
)
#: Size of the compiled-system cache (``validate``/``run`` of an unchanged system).
COMPILE_CACHE_BYTES = ResourceLimit(
    "FMIONNX_COMPILE_CACHE_MAX_BYTES", 256 * MiB, "bytes", "size of the compiled-system cache"
)
#: Days an unpacked SSP stays in the cache without being used.
CACHE_DAYS = ResourceLimit(
    "FMIONNX_CACHE_MAX_DAYS", 30, "days", "age of an unused cache entry (SSP, compiled systems)"
)

#: Every limit, in the order ``docs/security.md`` lists them.
LIMITS = (
    ARCHIVE_BYTES,
    ARCHIVE_MEMBERS,
    ARCHIVE_RATIO,
    ARRAY_ELEMENTS,
    SSP_XML_BYTES,
    COMPILED_FILE_BYTES,
    CACHE_BYTES,
    COMPILE_CACHE_BYTES,
    CACHE_DAYS,
)
