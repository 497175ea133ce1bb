"""Mutators for the fuzzers: hypothesis strategies that turn a valid seed into a broken one.

Random bytes alone almost never get past a parser's first check, so most mutations start from
a file that compiles (the valid corpus, the reference systems, the SSP fixtures, a built FMU)
and damage it a little: a few bytes (the typo, the truncated download, the bad merge), or one
piece of its structure (a value of the wrong type, a dropped or misspelt key, an element of an
SSD moved somewhere else, a zip whose central directory lies). Everything is drawn through
hypothesis, so a failure shrinks to a small mutation of the seed and replays from its seed.
"""

from __future__ import annotations

import copy
import hashlib
import io
import re
import struct
import warnings
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from hypothesis import assume
from hypothesis import strategies as st
from lxml import etree
from ruamel.yaml import YAML

# -- bytes ------------------------------------------------------------------------------------

#: Tokens worth inserting into any text: structure characters, encodings, huge and non-finite
#: numbers, and the hostile constructs the threat model names (tags, aliases, entities).
COMMON_TOKENS: tuple[bytes, ...] = (
    b"\x00",
    b"\xff\xfe",
    b"\xef\xbb\xbf",
    b"\xc3",
    b"\t",
    b"\r",
    b"\n",
    b" ",
    b'"',
    b"'",
    b"\\",
    b"1e400",
    b"-1e-400",
    b"9" * 400,
    b"9" * 5000,
    b".nan",
    b"NaN",
    b"-.inf",
    b"0x7fffffffffffffff",
    b"../../../../etc/passwd",
    b"/dev/zero",
)

YAML_TOKENS: tuple[bytes, ...] = (
    *COMMON_TOKENS,
    b": ",
    b"- ",
    b"? ",
    b"{",
    b"}",
    b"[",
    b"]",
    b",",
    b"#",
    b"|",
    b">",
    b"&a ",
    b"*a",
    b"&a [*a, *a]",
    b"<<: ",
    b"!!python/object/apply:os.system ['true'] ",
    b"!!binary aGVsbG8= ",
    b"!!set ",
    b"%YAML 1.1\n",
    b"---\n",
    b"...\n",
    b" -> ",
    b".",
    b"[0]",
    b"[-1]",
    b"[99999999999999999999]",
    b"~",
    b"2001-12-14t21:59:43.10-05:00",
)

XML_TOKENS: tuple[bytes, ...] = (
    *COMMON_TOKENS,
    b"<",
    b">",
    b"/>",
    b"</",
    b"=",
    b"&amp;",
    b"&e;",
    b"&#0;",
    b"&#x110000;",
    b"<![CDATA[x]]>",
    b"<!-- -->",
    b"<?pi x?>",
    b'<!DOCTYPE r [<!ENTITY e SYSTEM "file:///etc/passwd">]>',
    b'<!DOCTYPE r [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>',
    b'<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" href="/etc/passwd"/>',
    b' xmlns:ssd="urn:other"',
    b"ssd:",
    b"resources/",
)


@st.composite
def mutated_bytes(
    draw: st.DrawFn, seed: bytes, tokens: Sequence[bytes] = COMMON_TOKENS, max_ops: int = 4
) -> bytes:
    """``seed`` after 1 to ``max_ops`` byte-level edits.

    Edits: insert random bytes or a token, delete a range, replace a byte, flip a bit,
    truncate, duplicate a line, swap two lines. Positions are drawn over the current text, so
    edits compose (a duplicated line may then be truncated).
    """
    data = bytearray(seed)
    for _ in range(draw(st.integers(1, max_ops))):
        op = draw(
            st.sampled_from(
                ("insert", "token", "delete", "replace", "flip", "truncate", "dup_line", "swap")
            )
        )
        pos = draw(st.integers(0, len(data)))
        if op == "insert":
            data[pos:pos] = draw(st.binary(min_size=1, max_size=8))
        elif op == "token":
            data[pos:pos] = draw(st.sampled_from(tokens))
        elif op == "delete":
            data[pos : pos + draw(st.integers(1, 64))] = b""
        elif op == "replace" and pos < len(data):
            data[pos] = draw(st.integers(0, 255))
        elif op == "flip" and pos < len(data):
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif op == "truncate":
            del data[pos:]
        elif op in {"dup_line", "swap"}:
            lines = bytes(data).splitlines(keepends=True)
            if not lines:
                continue
            i = draw(st.integers(0, len(lines) - 1))
            j = draw(st.integers(0, len(lines) - 1))
            if op == "dup_line":
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            data = bytearray(b"".join(lines))
    return bytes(data)


def mutate_text(draw: st.DrawFn, text: str) -> str:
    """A few character-level edits of ``text`` (the near-miss spellings a user types)."""
    chars = list(text)
    for _ in range(draw(st.integers(1, 3))):
        pos = draw(st.integers(0, len(chars)))
        op = draw(st.sampled_from(("insert", "delete", "replace", "case")))
        if op == "insert":
            chars.insert(pos, draw(st.characters(codec="utf-8")))
        elif pos < len(chars):
            if op == "delete":
                del chars[pos]
            elif op == "replace":
                chars[pos] = draw(st.characters(codec="utf-8"))
            else:
                chars[pos] = chars[pos].swapcase()
    return "".join(chars)


# -- YAML structure ---------------------------------------------------------------------------

#: Raw YAML a dumped document cannot hold as data: the value or key placeholder is replaced by
#: the text itself after dumping. Huge numbers beyond Python's int-to-str limit, non-finite
#: floats, tags, aliases (undefined, recursive), timestamps, complex keys, merge keys.
RAW_VALUES: tuple[str, ...] = (
    "1" + "0" * 5000,
    "-" + "9" * 400,
    "1e400",
    "-1e400",
    "4.9e-324",
    ".nan",
    ".inf",
    "-.inf",
    "0x1F",
    "0o777",
    "1_000",
    "!!python/object/apply:os.system ['true']",
    "!!python/name:os.system",
    "!!binary aGVsbG8=",
    "!!float '1'",
    "!!str 1",
    "!custom {}",
    "*undefined",
    "&loop [*loop]",
    "&m {a: *m}",
    "2001-12-14t21:59:43.10-05:00",
    "2002-12-14",
    "~",
    "''",
    "[]",
    "{}",
    "[" * 50 + "]" * 50,
    "|\n  block\n  text",
    "'a.b -> c.d'",
    "a.b[0] -> c.d[1]",
    "a -> b -> c",
)

RAW_KEYS: tuple[str, ...] = (
    "<<",
    "[1, 2]",
    "{a: 1}",
    "null",
    "1",
    "true",
    "1.5",
    "''",
    "? complex",
    "!!python/object:os.system x",
    "*undefined",
)

#: Strings that name things fmionnx must refuse safely: special files, traversal, absolute
#: paths, folders, empty names, endpoints with odd indices.
HOSTILE_STRINGS: tuple[str, ...] = (
    "",
    " ",
    ".",
    "..",
    "/",
    "/dev/zero",
    "/dev/null",
    "/proc/self/environ",
    "../../../../etc/passwd",
    "a_folder",
    "system.yaml",
    "notzip.fmu",
    "evil.fmu",
    "huge_array.fmu",
    "fmi1",
    "windows_only",
    "x" * 300,
    "a.b",
    "a.b -> c.d",
    "a.b[0]",
    "a.b[-1]",
    "a.b[99999999999999999999]",
    "\u202e",
    "\x00",
    "fmu",
    "onnx",
    "mujoco",
    "signal",
    "me",
    "cs",
)

PLACEHOLDER = "fuzzraw{:04d}x"


def load_yaml(text: str | bytes) -> Any:
    """Plain data of a YAML document (ruamel's safe loader: the seeds are plain data). Its
    warnings (a reused anchor, in a mutant) are not the harness's to raise."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return YAML(typ="safe", pure=True).load(text)


def dump_yaml(doc: Any, *, flow: bool | None = False, unicode: bool = True) -> str:
    """YAML text of plain data, keys in their order; ``flow``: block (False), flow (True) or
    flow for leaf collections only (None)."""
    yaml = YAML(typ="safe", pure=True)
    yaml.default_flow_style = flow
    yaml.allow_unicode = unicode
    stream = io.StringIO()
    yaml.dump(doc, stream)
    return stream.getvalue()


def walk(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every path (keys and list indices) to a node below ``node``, ``node`` itself first."""
    paths: list[tuple[Any, ...]] = [prefix]
    if isinstance(node, dict):
        for key, value in node.items():
            paths.extend(walk(value, (*prefix, key)))
    elif isinstance(node, list):
        for index, value in enumerate(node):
            paths.extend(walk(value, (*prefix, index)))
    return paths


def strings_in(node: Any) -> list[str]:
    """Every string (key or value) in a document, and the parts of endpoints (``a.b[0]``)."""
    found: list[str] = []
    if isinstance(node, dict):
        for key, value in node.items():
            found.append(str(key))
            found.extend(strings_in(value))
    elif isinstance(node, list):
        for value in node:
            found.extend(strings_in(value))
    elif isinstance(node, str):
        found.append(node)
        found.extend(p for p in re.split(r"[\s.\[\]>-]+", node) if p)
    return sorted(set(found))


def _get(root: Any, path: tuple[Any, ...]) -> Any:
    for part in path:
        root = root[part]
    return root


def _nest(depth: int, as_map: bool) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = {"a": value} if as_map else [value]
    return value


def scalar_values(pool: Sequence[str]) -> st.SearchStrategy[Any]:
    """Scalars of every YAML type, with the edges that break number handling."""
    return st.one_of(
        st.none(),
        st.booleans(),
        st.integers(),
        st.sampled_from([0, -1, 2**31, 2**53 + 1, 2**63, -(2**63) - 1, 2**64, 10**308, 10**400]),
        st.floats(),
        st.sampled_from([5e-324, 1e-310, 1.7976931348623157e308, -0.0, 1e-9, 1e9]),
        st.text(max_size=12),
        st.sampled_from(HOSTILE_STRINGS),
        st.sampled_from(pool),
    )


def yaml_values(pool: Sequence[str]) -> st.SearchStrategy[Any]:
    """Any value a YAML document can hold: scalars, small containers, deep nesting."""
    scalars = scalar_values(pool)
    return st.one_of(
        scalars,
        st.recursive(
            scalars,
            lambda inner: (
                st.lists(inner, max_size=4)
                | st.dictionaries(st.sampled_from(pool) | st.text(max_size=6), inner, max_size=4)
            ),
            max_leaves=8,
        ),
        st.builds(_nest, st.integers(1, 130), st.booleans()),
        st.lists(st.sampled_from(pool), min_size=1, max_size=300),
    )


def typed_values(original: Any, pool: Sequence[str]) -> st.SearchStrategy[Any]:
    """Values of the same YAML type as ``original``, edges included: they get past the schema
    and reach the checks and the run (periods that are not multiples, parameters out of
    range, endpoints naming other ports)."""
    if isinstance(original, bool):
        return st.booleans()
    if isinstance(original, int | float):
        return st.one_of(
            st.integers(-(10**6), 10**6),
            st.floats(),
            st.sampled_from([0, -1, 1e-9, 5e-324, 1e308, 10**30, original * 2, original / 3]),
        )
    if isinstance(original, str):
        return st.sampled_from(pool) | st.text(max_size=8).map(lambda t: original + t)
    if isinstance(original, list):
        return st.lists(st.sampled_from(pool) | st.floats(), max_size=5)
    return scalar_values(pool)


@st.composite
def typed_yaml(draw: st.DrawFn, document: Any, max_ops: int = 2, numbers_only: bool = False) -> str:
    """``document`` with 1 to ``max_ops`` of its leaves replaced by values of the same type
    (``numbers_only``: only numbers, the format version excepted; such files compile more
    often, so they reach the run: parameters, periods, factors, run settings)."""
    doc = copy.deepcopy(document)
    pool = strings_in(doc) or ["x"]

    def eligible(path: tuple[Any, ...]) -> bool:
        value = _get(doc, path)
        if not numbers_only:
            return not isinstance(value, dict)
        number = isinstance(value, int | float) and not isinstance(value, bool)
        return number and path != ("fmionnx",)

    for _ in range(draw(st.integers(1, max_ops))):
        leaves = [p for p in walk(doc) if p and eligible(p)]
        path = draw(st.sampled_from(leaves))
        parent = _get(doc, path[:-1])
        parent[path[-1]] = draw(typed_values(parent[path[-1]], pool))
    assume(doc != document)
    return dump_yaml(doc)


@st.composite
def mutated_yaml(draw: st.DrawFn, document: Any, max_ops: int = 3) -> str:
    """``document`` (plain data loaded from a valid system file) with 1 to ``max_ops``
    structural edits, dumped back to YAML text.

    Edits: replace a value (any type, huge, non-finite, deeply nested, or raw YAML such as a
    tag or a recursive alias), drop a key or list item, rename a key (a near-miss, any text, a
    sibling's name to make a duplicate key, or a raw key such as ``<<``), duplicate a list
    item, move a value to another place.
    """
    doc = copy.deepcopy(document)
    pool = strings_in(doc) or ["x"]
    raw: dict[str, str] = {}

    def placeholder(text: str) -> str:
        key = PLACEHOLDER.format(len(raw))
        raw[key] = text
        return key

    for _ in range(draw(st.integers(1, max_ops))):
        paths = walk(doc)
        path = draw(st.sampled_from(paths))
        op = draw(st.sampled_from(("replace", "raw", "drop", "rename", "duplicate", "move")))
        if not path:  # the root: replace the whole document now and then
            if op in {"replace", "raw"}:
                doc = (
                    draw(yaml_values(pool))
                    if op == "replace"
                    else placeholder(draw(st.sampled_from(RAW_VALUES)))
                )
            continue
        parent = _get(doc, path[:-1])
        last = path[-1]
        if op == "replace":
            parent[last] = draw(yaml_values(pool))
        elif op == "raw":
            parent[last] = placeholder(draw(st.sampled_from(RAW_VALUES)))
        elif op == "drop":
            del parent[last]
        elif op == "rename" and isinstance(parent, dict):
            siblings = [str(k) for k in parent if k != last]
            choice = draw(st.sampled_from(("near", "text", "sibling", "raw")))
            if choice == "near":
                new = mutate_text(draw, str(last))
            elif choice == "text":
                new = draw(st.text(max_size=10))
            elif choice == "sibling" and siblings:
                new = placeholder(draw(st.sampled_from(siblings)))  # a duplicate key in the text
            else:
                new = placeholder(draw(st.sampled_from(RAW_KEYS)))
            parent[new] = parent.pop(last)
        elif op == "duplicate" and isinstance(parent, list):
            parent.insert(draw(st.integers(0, len(parent))), copy.deepcopy(parent[last]))
        elif op == "move":
            value = copy.deepcopy(parent[last])
            other = draw(st.sampled_from(walk(doc)))
            if other and isinstance(_get(doc, other[:-1]), dict | list):
                _get(doc, other[:-1])[other[-1]] = value
    assume(raw or doc != document)  # a rename to the same name, a move onto itself ...
    style = draw(st.sampled_from((None, False, True)))
    text = dump_yaml(doc, flow=style, unicode=draw(st.booleans()))
    for key, value in raw.items():
        text = text.replace(key, value)
    return text


# -- XML structure ----------------------------------------------------------------------------


def xml_values(pool: Sequence[str]) -> st.SearchStrategy[str]:
    """Attribute values: the seed's own (names, references, numbers), edges and random text."""
    return st.one_of(
        st.sampled_from(pool),
        st.sampled_from(HOSTILE_STRINGS[:19]),
        st.sampled_from(
            ("nan", "NaN", "INF", "-inf", "1e400", "-0", "0", "1" + "0" * 400, "4.9e-324", "true")
        ),
        st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=10),
        st.integers().map(str),
        st.floats().map(repr),
    )


@st.composite
def mutated_xml(
    draw: st.DrawFn,
    seed: bytes,
    max_ops: int = 3,
    ops: Sequence[str] = ("drop", "duplicate", "move", "tag", "attr", "delattr", "text"),
    extra: Sequence[str] = (),
) -> bytes:
    """An XML seed with 1 to ``max_ops`` structural edits, serialised again.

    Edits: drop an element, duplicate it, move it under another element, rename its tag (to
    another tag of the seed), set an attribute (existing or another one of the seed) to a drawn
    value, delete an attribute, set an element's text; ``ops`` chooses among them. ``extra``
    adds values to the pool attributes are drawn from (a format's own hostile values).
    """
    parser = etree.XMLParser(resolve_entities=False, no_network=True)
    root = etree.fromstring(seed, parser)
    elements = list(root.iter(etree.Element))
    tags = sorted({e.tag for e in elements})
    names = sorted({k for e in elements for k in e.attrib})
    values = sorted({v for e in elements for v in e.attrib.values()} | set(extra))
    for _ in range(draw(st.integers(1, max_ops))):
        elements = list(root.iter(etree.Element))
        element = draw(st.sampled_from(elements))
        parent = element.getparent()
        op = draw(st.sampled_from(ops))
        if op == "drop" and parent is not None:
            parent.remove(element)
        elif op == "duplicate" and parent is not None:
            parent.insert(parent.index(element), copy.deepcopy(element))
        elif op == "move" and parent is not None:
            target = draw(st.sampled_from(elements))
            if element not in target.iterancestors() and target is not element:
                parent.remove(element)
                target.append(element)
        elif op == "tag":
            element.tag = draw(st.sampled_from(tags))
        elif op == "attr" and names:
            element.set(draw(st.sampled_from(names)), draw(xml_values(values)))
        elif op == "delattr" and element.attrib:
            del element.attrib[draw(st.sampled_from(sorted(element.attrib)))]
        elif op == "text":
            element.text = draw(xml_values(values))
    return bytes(etree.tostring(root, xml_declaration=True, encoding="UTF-8"))


# -- zip archives -----------------------------------------------------------------------------

LOCAL_HEADER = struct.Struct("<4s5H3I2H")  # signature ... name length, extra length
CENTRAL_HEADER = struct.Struct("<4s6H3I5H2I")
EOCD = struct.Struct("<4s4H2IH")

#: Member names a hostile archive uses (traversal, absolute, Windows separators, a folder
#: where a file is expected, a name too long for the file system). An empty name is left to
#: the raw edits: ``zipfile`` cannot write one.
HOSTILE_MEMBER_NAMES: tuple[str, ...] = (
    "../escaped.txt",
    "../../escaped.txt",
    "/fmionnx-fuzz-absolute.txt",
    "a/../../escaped.txt",
    "..\\..\\escaped.txt",
    "C:/escaped.txt",
    "modelDescription.xml/",
    "binaries/linux64/../../../escaped.so",
    "resources/../../escaped.txt",
    "x" * 300,
)


@dataclass(frozen=True, repr=False)
class ZipLayout:
    """Where things are in a zip: each member's local header and data, the central directory.

    Its repr is short: it is an argument of the mutation strategies, and hypothesis warns (an
    error under pytest) when a strategy's repr, its arguments' included, runs to tens of kB."""

    data: bytes
    names: tuple[str, ...]
    local_offsets: tuple[int, ...]
    data_spans: tuple[tuple[int, int], ...]
    central_start: int
    central_offsets: tuple[int, ...]
    eocd: int

    @staticmethod
    def of(data: bytes) -> ZipLayout:
        """Read the layout of a well-formed archive (a seed)."""
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            infos = archive.infolist()
        spans = []
        for info in infos:
            fields = LOCAL_HEADER.unpack_from(data, info.header_offset)
            start = info.header_offset + LOCAL_HEADER.size + fields[-2] + fields[-1]
            spans.append((start, start + info.compress_size))
        eocd = data.rfind(b"PK\x05\x06")
        central_start = EOCD.unpack_from(data, eocd)[6]
        offsets = []
        pos = central_start
        for _ in infos:
            offsets.append(pos)
            fields = CENTRAL_HEADER.unpack_from(data, pos)
            pos += CENTRAL_HEADER.size + fields[10] + fields[11] + fields[12]
        return ZipLayout(
            data,
            tuple(i.filename for i in infos),
            tuple(i.header_offset for i in infos),
            tuple(spans),
            central_start,
            tuple(offsets),
            eocd,
        )

    def __repr__(self) -> str:
        digest = hashlib.sha256(self.data).hexdigest()[:12]
        return f"ZipLayout({len(self.data)} bytes, sha256 {digest}..., members {self.names})"

    def _repr_pretty_(self, printer: Any, cycle: bool) -> None:
        """What hypothesis's printer asks first (it prints a dataclass field by field)."""
        printer.text(repr(self))

    def members(self) -> list[tuple[zipfile.ZipInfo, bytes]]:
        """(info, content) of every member, for rebuilding the archive."""
        with zipfile.ZipFile(io.BytesIO(self.data)) as archive:
            return [(i, archive.read(i)) for i in archive.infolist()]


def rebuild(members: Sequence[tuple[str | zipfile.ZipInfo, bytes]]) -> bytes:
    """A new deflated archive of ``members`` (duplicate names allowed on purpose)."""
    out = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "Duplicate name": the point of some mutations
        with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for name, content in members:
                # A fixed date: the same draws must give the same bytes on every replay.
                info = name if isinstance(name, zipfile.ZipInfo) else zipfile.ZipInfo(name)
                info.compress_type = zipfile.ZIP_DEFLATED
                archive.writestr(info, content)
    return out.getvalue()


def _patch(data: bytearray, offset: int, fmt: str, value: int) -> None:
    size = struct.calcsize(fmt)
    if offset >= 0 and offset + size <= len(data):
        struct.pack_into(fmt, data, offset, value)


class Mutant:
    """A mutated archive and what was done to it: the repr is the description (a failure
    report shows the edit, not tens of kilobytes of zip). Not a dataclass: hypothesis prints
    a dataclass field by field, bytes and all."""

    __slots__ = ("data", "how")

    def __init__(self, data: bytes, how: str) -> None:
        self.data = data
        self.how = how

    def __repr__(self) -> str:
        digest = hashlib.sha256(self.data).hexdigest()[:12]
        return f"Mutant({self.how}; {len(self.data)} bytes, sha256 {digest}...)"


def _short(data: bytes, limit: int = 600) -> str:
    text = repr(data)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(data)} bytes)"


@st.composite
def mutated_zip(
    draw: st.DrawFn,
    layout: ZipLayout,
    inner: Callable[[str], Sequence[bytes]] = lambda _name: COMMON_TOKENS,
) -> Mutant:
    """An archive seed with one zip-level edit, described in the result.

    Raw edits keep the seed's bytes and damage one structure: bytes of the central directory,
    of a local header or of a member's deflate stream; a lying size, compression method,
    entry count, flag (encrypted ...) or directory offset; a truncation. Rebuilding edits make a well-formed zip
    that says something hostile: a member renamed (traversal, absolute path ...), a member
    twice under one name, a member dropped, or a member's content (XML) mutated byte-wise
    (``inner`` gives the tokens for a member name).
    """
    op = draw(
        st.sampled_from(
            (
                "central",
                "local",
                "deflate",
                "sizes",
                "method",
                "flags",
                "eocd",
                "truncate",
                "rename",
                "duplicate",
                "drop",
                "content",
            )
        )
    )
    data = bytearray(layout.data)
    member = draw(st.integers(0, len(layout.names) - 1))
    target = layout.names[member]
    if op in {"central", "local", "deflate"}:
        if op == "central":
            lo, hi = layout.central_start, len(data)
            where = "central directory"
        elif op == "local":
            lo, hi = layout.local_offsets[member], layout.data_spans[member][0]
            where = f"local header of {target!r}"
        else:
            lo, hi = layout.data_spans[member]
            where = f"deflate stream of {target!r}"
        edits = []
        # Distinct places: a byte edited twice could come back to the seed's (found by
        # `make fuzz`: 0x50->0x51->0x50, the seed itself).
        spot = st.integers(lo, hi - 1) if hi > lo else st.nothing()
        places = draw(st.lists(spot, max_size=4, unique=True, min_size=int(hi > lo)))
        for at in places:
            value = (data[at] + draw(st.integers(1, 255))) % 256  # never the same byte
            edits.append(f"[{at}] {data[at]:#04x}->{value:#04x}")
            data[at] = value
        return Mutant(bytes(data), f"{where}: bytes {', '.join(edits) or 'none'}")
    if op == "sizes":
        which = draw(st.sampled_from((20, 24)))  # compressed / uncompressed size
        value = draw(st.sampled_from((0, 1, 2**31, 2**32 - 1)) | st.integers(0, 2**32 - 1))
        _patch(data, layout.central_offsets[member] + which, "<I", value)
        local = draw(st.booleans())
        if local:
            _patch(data, layout.local_offsets[member] + which - 2, "<I", value)
        assume(data != layout.data)
        what = "compressed" if which == 20 else "uncompressed"
        also = " (and local header)" if local else ""
        return Mutant(bytes(data), f"{target!r}: {what} size {value} in central directory{also}")
    if op == "method":
        value = draw(st.sampled_from((0, 1, 9, 12, 14, 93, 99, 0xFFFF)))
        _patch(data, layout.central_offsets[member] + 10, "<H", value)
        local = draw(st.booleans())
        if local:
            _patch(data, layout.local_offsets[member] + 8, "<H", value)
        assume(data != layout.data)
        also = " (and local header)" if local else ""
        return Mutant(bytes(data), f"{target!r}: compression method {value}{also}")
    if op == "flags":  # general purpose bits: encrypted, data descriptor, strong encryption ...
        value = draw(st.sampled_from((0x1, 0x8, 0x40, 0x800, 0x2000, 0xFFFF)))
        _patch(data, layout.central_offsets[member] + 8, "<H", value)
        local = draw(st.booleans())
        if local:
            _patch(data, layout.local_offsets[member] + 6, "<H", value)
        assume(data != layout.data)
        also = " (and local header)" if local else ""
        return Mutant(bytes(data), f"{target!r}: general purpose flags {value:#06x}{also}")
    if op == "eocd":
        offset, fmt = draw(
            st.sampled_from(((8, "<H"), (10, "<H"), (12, "<I"), (16, "<I"), (20, "<H")))
        )
        value = draw(st.integers(0, 0xFFFF if fmt == "<H" else 0xFFFFFFFF))
        _patch(data, layout.eocd + offset, fmt, value)
        assume(data != layout.data)
        return Mutant(bytes(data), f"end of central directory: field at +{offset} = {value}")
    if op == "truncate":
        at = draw(st.integers(0, len(data) - 1))
        return Mutant(bytes(data[:at]), f"truncated to {at} of {len(data)} bytes")
    members: list[tuple[str | zipfile.ZipInfo, bytes]] = [
        (info.filename, content) for info, content in layout.members()
    ]
    content = members[member][1]
    if op == "rename":
        new = draw(st.sampled_from(HOSTILE_MEMBER_NAMES) | st.sampled_from(layout.names))
        members[member] = (new, content)
        how = f"member {target!r} renamed {new!r}"
    elif op == "duplicate":
        other = draw(st.sampled_from((b"", b"garbage", content[: len(content) // 2])))
        members.insert(draw(st.integers(0, len(members))), (target, other))
        how = f"member {target!r} twice, once as {_short(other, 60)}"
    elif op == "drop":
        del members[member]
        how = f"member {target!r} dropped"
    else:
        changed = draw(mutated_bytes(content, inner(target)))
        members[member] = (target, changed)
        how = f"member {target!r} replaced by {_short(changed)}"
    rebuilt = rebuild(members)
    assume(rebuilt != layout.data)
    return Mutant(rebuilt, f"rebuilt: {how}")
