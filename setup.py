"""Builds fmionnx's native FMI 2 kernel when fmionnx is installed (metadata: pyproject.toml).

The kernel (``fmionnx/runtime/native/fmi2_group.c``) is a plain C shared library that the
master loads with ctypes; it is no Python extension module. It is declared as an
``Extension`` so that setuptools compiles it with the platform's compiler settings, puts it
into wheels (which makes them platform wheels) and, for an editable install, beside its
source. The ``build_ext`` below only changes what makes it a plain library: its file name
(``libfmi2_group.so``, which no ``import`` picks up), no ``PyInit_`` export and no
libpython to link. It then writes the build manifest beside the library (sha256 of the
library and of the source), which the loader checks before it loads the file.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent
NATIVE = Path("fmionnx", "runtime", "native")


def _manifest_module() -> ModuleType:
    """``fmionnx/runtime/native/manifest.py`` (standard library only), without importing
    fmionnx, whose dependencies are not installed while it is being built."""
    path = HERE / NATIVE / "manifest.py"
    spec = importlib.util.spec_from_file_location("_fmionnx_native_manifest", path)
    if spec is None or spec.loader is None:
        msg = f"cannot load {path}"
        raise RuntimeError(msg)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


MANIFEST = _manifest_module()
KERNEL = ".".join((*NATIVE.parts, Path(MANIFEST.LIBRARY_NAME).stem))


class BuildKernel(build_ext):
    """``build_ext`` that builds the kernel as a plain shared library with its manifest."""

    def get_ext_filename(self, fullname: str) -> str:
        # called with the dotted name and, by get_ext_fullpath, with its last part alone
        if not KERNEL.endswith("." + fullname) and fullname != KERNEL:
            return super().get_ext_filename(fullname)
        return "/".join((*fullname.split(".")[:-1], MANIFEST.LIBRARY_NAME))

    def get_export_symbols(self, ext: Extension) -> list[str]:
        if ext.name != KERNEL:
            return super().get_export_symbols(ext)
        return list(ext.export_symbols)  # its C functions; never a PyInit_ function

    def get_libraries(self, ext: Extension) -> list[str]:
        if ext.name != KERNEL:
            return super().get_libraries(ext)
        return list(ext.libraries)  # libm only: the kernel calls nothing of Python

    def build_extension(self, ext: Extension) -> None:
        if ext.name == KERNEL and self.compiler.compiler_type not in {"unix", "mingw32", "cygwin"}:
            msg = f"the native kernel needs a GCC or Clang compiler, not {self.compiler.compiler_type}"
            raise RuntimeError(msg)
        super().build_extension(ext)
        if ext.name == KERNEL:
            self._record(Path(self.get_ext_fullpath(ext.name)).parent)

    def copy_extensions_to_source(self) -> None:
        """Editable installs: the library is copied beside its source; so is a manifest."""
        super().copy_extensions_to_source()
        if any(ext.name == KERNEL for ext in self.extensions):
            self._record(Path(self.get_ext_fullpath(KERNEL)).parent)

    def get_outputs(self) -> list[str]:
        outputs = super().get_outputs()
        extra = [
            str(Path(out).with_name(MANIFEST.MANIFEST_NAME))
            for out in outputs
            if Path(out).name == MANIFEST.LIBRARY_NAME
        ]
        return outputs + extra

    def _record(self, folder: Path) -> None:
        compiler = getattr(self.compiler, "compiler_so", None) or [self.compiler.compiler_type]
        source = HERE / NATIVE / MANIFEST.SOURCE_NAME
        MANIFEST.write_manifest(folder, source, "setup.py build_ext", str(compiler[0]))


setup(
    ext_modules=[
        Extension(
            KERNEL,
            sources=[(NATIVE / MANIFEST.SOURCE_NAME).as_posix()],
            libraries=["m"],
            extra_compile_args=list(MANIFEST.COMPILE_FLAGS),
            export_symbols=[
                "fx_group_step",
                "fx_group_run",
                "fx_link_step",
                "fx_serve",
                "fx_abi_version",
                "fx_abi_layout",
            ],
        )
    ],
    cmdclass={"build_ext": BuildKernel},
)
