"""The functions an ELF shared library exports, read from its bytes without loading it.

Why not ``ctypes.CDLL``: loading a supplier's library runs its constructors in our process, at
compile time, before the user asked for a run. The dynamic symbol table (``.dynsym`` and the
string table it links to) says the same thing and is plain data: this reader parses the ELF
header, the section headers, and the symbol entries of every ``SHT_DYNSYM`` section, with
every offset and size checked against the file, so a damaged or hostile file yields
:class:`NotElfError`, never an exception of its own.

Only 64- and 32-bit, little- and big-endian ELF files are read; symbols count as exported when
they are defined (a section index other than ``SHN_UNDEF``), global or weak, and not hidden.
"""

from __future__ import annotations

import struct

_MAGIC = b"\x7fELF"
_SHT_DYNSYM = 11
_SHN_UNDEF = 0
_STB_GLOBAL = 1
_STB_WEAK = 2
_STV_HIDDEN = 2
_STV_INTERNAL = 1

#: Symbols read at most (a real FMU exports a few hundred; the bound keeps a hostile file cheap).
MAX_SYMBOLS = 1_000_000


class NotElfError(ValueError):
    """The bytes are not an ELF file this reader can read (the message says why)."""


def _unpack(fmt: str, data: bytes, offset: int) -> tuple[int, ...]:
    size = struct.calcsize(fmt)
    if offset < 0 or offset + size > len(data):
        msg = "a header lies beyond the end of the file"
        raise NotElfError(msg)
    return struct.unpack_from(fmt, data, offset)


def _name(strtab: bytes, offset: int) -> str:
    if offset >= len(strtab):
        msg = "a symbol name lies beyond its string table"
        raise NotElfError(msg)
    end = strtab.find(b"\0", offset)
    raw = strtab[offset:] if end < 0 else strtab[offset:end]
    return raw.decode("utf-8", "replace")


def exported_symbols(data: bytes) -> frozenset[str]:
    """Names of the defined, visible global and weak symbols of the ELF file ``data``.

    Raises NotElfError for anything that is not a readable ELF file.
    """
    if data[:4] != _MAGIC or len(data) < 16:
        msg = "not an ELF file"
        raise NotElfError(msg)
    bits = {1: 32, 2: 64}.get(data[4])
    order = {1: "<", 2: ">"}.get(data[5])
    if bits is None or order is None:
        msg = "an ELF file of unknown class or byte order"
        raise NotElfError(msg)
    if bits == 64:
        shoff, shentsize, shnum = (
            _unpack(order + "Q", data, 0x28)[0],
            *_unpack(order + "HH", data, 0x3A),
        )
        section = order + "IIQQQQIIQQ"
        symbol = order + "IBBHQQ"
    else:
        shoff, shentsize, shnum = (
            _unpack(order + "I", data, 0x20)[0],
            *_unpack(order + "HH", data, 0x2E),
        )
        section = order + "IIIIIIIIII"
        symbol = order + "IIIBBH"
    if shoff == 0 or shnum == 0:
        msg = "the ELF file has no section headers"
        raise NotElfError(msg)
    if shentsize < struct.calcsize(section):
        msg = "the ELF section headers are too small"
        raise NotElfError(msg)
    headers = [_unpack(section, data, shoff + i * shentsize) for i in range(shnum)]
    names: set[str] = set()
    read = 0
    for header in headers:
        kind, offset, size, link, entsize = header[1], header[4], header[5], header[6], header[9]
        if kind != _SHT_DYNSYM:
            continue
        if link >= len(headers) or entsize < struct.calcsize(symbol):
            msg = "the dynamic symbol table is malformed"
            raise NotElfError(msg)
        str_offset, str_size = headers[link][4], headers[link][5]
        if offset + size > len(data) or str_offset + str_size > len(data):
            msg = "the dynamic symbol table lies beyond the end of the file"
            raise NotElfError(msg)
        strtab = data[str_offset : str_offset + str_size]
        for index in range(size // entsize):
            read += 1
            if read > MAX_SYMBOLS:
                msg = f"the library declares more than {MAX_SYMBOLS} symbols"
                raise NotElfError(msg)
            entry = _unpack(symbol, data, offset + index * entsize)
            if bits == 64:
                name_at, info, other, shndx = entry[0], entry[1], entry[2], entry[3]
            else:
                name_at, info, other, shndx = entry[0], entry[3], entry[4], entry[5]
            binding = info >> 4
            visibility = other & 0x3
            if (
                shndx == _SHN_UNDEF
                or binding not in (_STB_GLOBAL, _STB_WEAK)
                or visibility in (_STV_HIDDEN, _STV_INTERNAL)
            ):
                continue
            names.add(_name(strtab, name_at))
    return frozenset(names)
