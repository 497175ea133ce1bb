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

from fmionnx.core import codes
from fmionnx.core.errors import ModelError

#: The diagnostic code of a model that exceeds a resource limit.
LIMIT_CODE = codes.RESOURCE_LIMIT


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

#: Dimensions of one port. Every port's buffer is a numpy array, and numpy makes arrays of at
#: most 32 dimensions in its 1.x versions (64 since 2.0): a model declaring more would pass
#: the compiler and fail when its run starts. Not changeable: it is numpy's, not a budget.
MAX_RANK = 32
RANK_HINT = "reshape the tensor in the model; no real model needs more dimensions"

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
#: Size of one file of a study's results folder fmionnx reads back (``study.json``, a case's
#: record): a million cases' ``study.json`` stays below it.
STUDY_FILE_BYTES = ResourceLimit(
    "FMIONNX_MAX_STUDY_FILE_BYTES", 1024 * MiB, "bytes", "size of study.json or a case record"
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

#: Size of one file a model names or is: a MuJoCo scene, include, mesh, texture or height
#: field, an ONNX model or its external data, a signal's table.
MODEL_FILE_BYTES = ResourceLimit(
    "FMIONNX_MAX_MODEL_FILE_BYTES",
    2 * 1024 * MiB,
    "bytes",
    "size of one model file or file a model names",
)
#: Elements of all ports of one component together: each port's buffer is allocated at
#: setup, so 16 ports at the per-array limit would take gigabytes.
PORT_ELEMENTS = ResourceLimit(
    "FMIONNX_MAX_PORT_ELEMENTS",
    128 * MiB,
    "elements",
    "elements of all ports of one component together",
)
#: Elements of all tensors an ONNX model stores (initializers, constants, external data).
MODEL_ELEMENTS = ResourceLimit(
    "FMIONNX_MAX_MODEL_ELEMENTS",
    256 * MiB,
    "elements",
    "elements of all tensors one ONNX model stores together",
)
#: Memory onnxruntime's allocator may hold in one process (every session's tensors).
ONNX_BYTES = ResourceLimit(
    "FMIONNX_MAX_ONNX_BYTES",
    4 * 1024 * MiB,
    "bytes",
    "memory onnxruntime may allocate in one process, all ONNX models together",
)
#: Elements of a MuJoCo scene once ``replicate``, includes, flexcomp and composite are
#: expanded. MuJoCo's compiler takes time quadratic in them (10 000 geoms: about 1 s).
SCENE_ELEMENTS = ResourceLimit(
    "FMIONNX_MAX_SCENE_ELEMENTS",
    10_000,
    "elements",
    "bodies, geoms, joints, sites and other elements of one MuJoCo scene",
)
#: Memory a MuJoCo scene declares: height fields, textures, ``<size memory>``, user data,
#: and the simulation's arena MuJoCo sizes from the model.
SCENE_BYTES = ResourceLimit(
    "FMIONNX_MAX_SCENE_BYTES",
    1024 * MiB,
    "bytes",
    "memory of one MuJoCo scene's height fields, textures and simulation data",
)
#: Address space of an isolated model's process (``RLIMIT_AS``): virtual memory, so the
#: interpreter, the libraries and every thread's stack count, far below it for a real model.
ISOLATED_BYTES = ResourceLimit(
    "FMIONNX_MAX_ISOLATED_BYTES",
    8 * 1024 * MiB,
    "bytes",
    "address space of one isolated model's process",
)

#: Every limit, in the order ``docs/security.md`` lists them.
LIMITS = (
    ARCHIVE_BYTES,
    ARCHIVE_MEMBERS,
    ARCHIVE_RATIO,
    ARRAY_ELEMENTS,
    PORT_ELEMENTS,
    MODEL_ELEMENTS,
    ONNX_BYTES,
    SCENE_ELEMENTS,
    SCENE_BYTES,
    ISOLATED_BYTES,
    MODEL_FILE_BYTES,
    SSP_XML_BYTES,
    COMPILED_FILE_BYTES,
    STUDY_FILE_BYTES,
    CACHE_BYTES,
    COMPILE_CACHE_BYTES,
    CACHE_DAYS,
)
