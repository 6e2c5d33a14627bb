"""ArduPilot DataFlash (.bin) logs: self-describing, damage-tolerant, fast.

Every message starts with 0xA3 0x95 and a type byte; FMT messages (type 128) define each
type's length, name, field formats and column names, and FMTU/MULT/UNIT add units and
multipliers. The reader walks the message boundaries once, keeping only each message's
offset in a compact array per type (no Python object per message), and decodes the types
asked for in one numpy operation each. Damage (a truncated tail, corrupted bytes, an
unknown type) is skipped by searching for the next valid header; what was skipped, and
where, is reported.

Damage can also look like data. An FMT record is taken only when its name, format
characters and length all hold together (random bytes after an FMT header
almost never do); one that redefines a type already defined with another layout, or gives
a second type an existing name, is ignored and reported, so a junk record cannot take the
GPS type away; but one whose column names were damaged (kept for its layout) takes its names from
an intact copy of the same layout. After a stretch of damage the reader takes a header it finds only when
another header (or the end of the file) follows the message it frames, so two bytes that
happen to read 0xA3 0x95 inside damage are not taken for a message. `repeated()` finds the
messages of a type that repeat an earlier one byte for byte (a duplicated chunk).
"""

from __future__ import annotations

import mmap
import struct
from array import array
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HEAD = b"\xa3\x95"
FMT_TYPE = 128
FMT_LEN = 89
# DataFlash format characters: numpy type and the multiplier the format implies
_CHARS: dict[str, tuple[str, float]] = {
    "b": ("i1", 1.0), "B": ("u1", 1.0), "h": ("<i2", 1.0), "H": ("<u2", 1.0), "i": ("<i4", 1.0),
    "I": ("<u4", 1.0), "f": ("<f4", 1.0), "d": ("<f8", 1.0), "n": ("S4", 1.0), "N": ("S16", 1.0),
    "Z": ("S64", 1.0), "c": ("<i2", 0.01), "C": ("<u2", 0.01), "e": ("<i4", 0.01), "E": ("<u4", 0.01),
    "L": ("<i4", 1e-7), "M": ("u1", 1.0), "q": ("<i8", 1.0), "Q": ("<u8", 1.0), "a": ("<i2", 1.0),
}


@dataclass
class Format:
    type: int
    length: int
    name: str
    fmt: str
    columns: list[str]
    dtype: np.dtype | None = None
    scale: dict[str, float] = field(default_factory=dict)
    undecoded: frozenset[str] = frozenset()  # columns whose format character was damaged (`_repair_format`)
    damaged_columns: bool = False  # its column names were damaged: kept for its layout, named by an intact copy


def _dtype(fmt: str, columns: list[str]) -> tuple[np.dtype, dict[str, float]] | None:
    fields: list[tuple[str, str] | tuple[str, str, tuple[int]]] = []
    scale: dict[str, float] = {}
    for ch, col in zip(fmt, columns):
        if ch not in _CHARS:
            return None
        np_t, mult = _CHARS[ch]
        if ch == "a":
            fields.append((col, "<i2", (32,)))
        else:
            fields.append((col, np_t))
        if mult != 1.0:
            scale[col] = mult
    try:
        return np.dtype(fields), scale
    except (TypeError, ValueError):
        return None


#: bytes each format character takes in a message
_SIZES: dict[str, int] = {ch: (64 if ch == "a" else np.dtype(t).itemsize) for ch, (t, _) in _CHARS.items()}
_NAME_CHARS = frozenset(b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_")


def _cstr(raw: bytes) -> bytes:
    """A NUL-padded field up to its first NUL."""
    end = raw.find(b"\0")
    return raw if end < 0 else raw[:end]


def check_format(typ: int, length: int, name: bytes, fmt: bytes, cols: bytes) -> str | None:
    """Why an FMT record cannot be a real one, or None when it can.

    The name is 1-4 letters, digits or '_'; every format character is a DataFlash one; the
    length is the one the format characters add up to. (Column names are not checked here: a
    record whose layout holds but whose column names are damaged still frames and decodes its
    messages; the reader reports it.) ArduPilot wrote a few records whose column list and length are both out of step
    with the format (EKF5 in some ArduCopter 3.3 logs: 13 format characters, 10 columns,
    28 bytes); such a record still frames its messages and is kept (never decoded).
    """
    n, f, c = _cstr(name), _cstr(fmt), _cstr(cols)
    if not n or any(b not in _NAME_CHARS for b in n):
        return f"FMT record with an invalid name {n!r}"
    if any(chr(b) not in _SIZES for b in f):
        return f"FMT record for {n.decode()} with invalid format characters {f!r}"
    implied = 3 + sum(_SIZES[chr(b)] for b in f)
    if typ == FMT_TYPE and (length != FMT_LEN or implied != FMT_LEN):
        return f"FMT record for the FMT type with length {length} or format {f!r} (must be {FMT_LEN}, 'BBnNZ')"
    if length < 3:
        return f"FMT record for {n.decode()} with length {length} (less than the 3-byte header)"
    if implied != length and len(c.split(b",") if c else []) == len(f):
        return f"FMT record for {n.decode()}: its format {f.decode()!r} takes {implied} bytes, the record says {length}"
    return None


#: a format character of each size, standing in for a damaged one of that size
_OF_SIZE = {1: "B", 2: "H", 4: "I", 8: "Q", 16: "N", 64: "Z"}


def _repair_format(typ: int, length: int, name: bytes, fmt: bytes, cols: bytes) -> tuple[bytes, int] | None:
    """(the format with its one damaged character replaced, that character's index) when an FMT
    record holds together but for one format character that is not a DataFlash one: its length,
    its column names (one per character) and its other characters give that character's size, so
    the record still frames its messages and decodes every other column; None otherwise."""
    f, c = _cstr(fmt), _cstr(cols)
    bad = [i for i, b in enumerate(f) if chr(b) not in _SIZES]
    if len(bad) != 1 or len(c.split(b",")) != len(f):
        return None
    size = length - 3 - sum(_SIZES[chr(b)] for i, b in enumerate(f) if i != bad[0])
    if size not in _OF_SIZE:
        return None
    fixed = f[:bad[0]] + _OF_SIZE[size].encode() + f[bad[0] + 1:]
    return (fixed, bad[0]) if check_format(typ, length, name, fixed, cols) is None else None


@dataclass
class Skip:
    """Bytes the reader did not take as messages, and why.

    kind: "damage" (bytes outside any message, a message cut off, an unknown type),
    "format" (an FMT record rejected or ignored).
    """

    offset: int
    length: int
    reason: str
    kind: str = "damage"


class DataFlashLog:
    """A DataFlash log opened for reading (memory-mapped)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._fh = open(self.path, "rb")
        size = self.path.stat().st_size
        self._buf = mmap.mmap(self._fh.fileno(), 0, access=mmap.ACCESS_READ) if size else b""
        self.size = size
        self.formats: dict[int, Format] = {}
        self.offsets: dict[int, array[int]] = {}
        self.skipped: list[Skip] = []
        self._names: dict[str, Format] = {}
        self._reject = ""
        self._lengths = [0] * 256  # message length by type, as the scan knows them
        self._scan()

    def close(self) -> None:
        if isinstance(self._buf, mmap.mmap):
            self._buf.close()
        self._fh.close()

    def __enter__(self) -> DataFlashLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _add_format(self, o: int) -> bool:
        """Take the FMT record at `o`; False when it is not a real one (damage, reported by the caller)."""
        try:
            typ, length, name, fmt, cols = struct.unpack_from("<BB4s16s64s", self._buf, o + 3)
        except struct.error:
            self._reject = "FMT record cut off at the end of the file"
            return False
        why = check_format(typ, length, name, fmt, cols)
        repaired = _repair_format(typ, length, name, fmt, cols) if why is not None else None
        if why is not None and repaired is None:
            self._reject = why
            return False
        name_s, cols_s = (_cstr(x).decode("ascii", "replace") for x in (name, cols))
        fmt_s = _cstr(repaired[0] if repaired else fmt).decode("ascii", "replace")
        columns = cols_s.split(",") if cols_s else []
        old = self.formats.get(typ)
        bad = [i for i, b in enumerate(_cstr(cols)) if b < 0x20 or b > 0x7E]
        # an intact copy of a record kept for its layout with damaged column names (a copied chunk cut inside
        # it, the log's first bytes read as its names) names its columns
        names = old is not None and old.damaged_columns and not bad and (old.length, old.name, old.fmt) == (length, name_s, fmt_s)
        clash = not names and old is not None and (old.length, old.name, old.fmt, old.columns) != (length, name_s, fmt_s, columns)
        if (old is not None or self.type_of(name_s) is not None) and \
                (not self._followed(o + FMT_LEN) or self._inner_message(o, o + FMT_LEN) is not None):
            # a record of a type already defined (ignored, or a copy that changes nothing), followed
            # by no message or holding messages that are, is damage that reads as an FMT header (a
            # copied chunk's first bytes, cut where its column names have ended): its 89 bytes would
            # take real messages
            self._reject = f"FMT record for {name_s} that repeats a defined type and spans other messages"
            return False
        undecoded: frozenset[str] = frozenset()
        if repaired is not None:
            at = repaired[1]
            col = _cstr(cols).split(b",")[at].decode("ascii", "replace")
            undecoded = frozenset([col])
            self._skip(o + 3 + 6 + at, 1, f"{why}: character {at + 1} damaged; the record's length and other characters "
                       f"still frame its messages, column {col} is not decoded", "format")
        if bad:
            self._skip(o + 3 + 22 + bad[0], bad[-1] - bad[0] + 1, f"FMT record for {name_s}: damaged column names "
                       f"{cols_s!r}; kept for its layout, which holds", "format")
        if old is not None:
            if names:
                self._set_columns(old, columns)
                old.damaged_columns = False
            if not clash and not undecoded:
                old.undecoded = frozenset()  # an intact copy of a repaired record: every column decodes
            if clash:
                self._skip(o, FMT_LEN, f"FMT record redefines type {typ} ({old.name}, {old.fmt}, {old.length} bytes) as "
                                       f"{name_s}, {fmt_s}, {length} bytes: ignored, the first definition is kept", "format")
            return True
        same = self.type_of(name_s)
        if same is not None:
            self._skip(o, FMT_LEN, f"FMT record gives type {typ} the name {name_s} of type {same.type}: ignored", "format")
            return True
        # Real logs hold FMT records whose column list does not match the format (old firmware's
        # FMT-for-FMT names four columns for "BBnNZ"; some EKF5 records list 10 names for 13
        # fields) and records with no fields at all (STRT). Their length still frames the
        # messages, so the type is kept; it just cannot be decoded into named columns.
        f = Format(typ, length, name_s, fmt_s, [], undecoded=undecoded, damaged_columns=bool(bad))
        self._set_columns(f, columns)
        self.formats[typ] = f
        self._names[name_s] = f
        return True

    @staticmethod
    def _set_columns(f: Format, columns: list[str]) -> None:
        """Name a format's columns, and decode it when they match its format characters and length."""
        f.columns = columns
        dt = _dtype(f.fmt, columns) if f.fmt and len(columns) == len(f.fmt) else None
        if dt is not None and dt[0].itemsize == f.length - 3:
            f.dtype, f.scale = dt

    def _scan(self) -> None:
        buf, n = self._buf, self.size
        lengths = self._lengths
        lengths[FMT_TYPE] = FMT_LEN
        offsets = self.offsets
        o = 0
        find = buf.find
        resync = False  # True after damage: the next header must be confirmed by the one after it
        last = -1  # offset of the last message taken
        while o + 3 <= n:
            if buf[o] == 0xA3 and buf[o + 1] == 0x95:
                t = buf[o + 2]
                ln = lengths[t]
                if ln and o + ln <= n:
                    if resync:
                        e = o + ln
                        if not (e == n or buf[e:e + 2] == HEAD or (e + 1 == n and buf[e] == 0xA3)):
                            nxt = find(HEAD, o + 1)
                            self._skip(o, (nxt if nxt >= 0 else n) - o, "bytes outside any message")
                            o = nxt if nxt >= 0 else n
                            continue
                        resync = False
                    if t == FMT_TYPE:
                        if self._add_format(o):
                            f = self.formats.get(buf[o + 3])
                            if f is not None:
                                lengths[f.type] = f.length
                        else:
                            nxt = find(HEAD, o + 1)
                            self._skip(o, (nxt if nxt >= 0 else n) - o, self._reject, "format")
                            o = nxt if nxt >= 0 else n
                            resync = True
                            continue
                    a = offsets.get(t)
                    if a is None:
                        a = offsets[t] = array("Q")
                    a.append(o)
                    last = o
                    o += ln
                    continue
                reason = "message cut off at the end of the file" if ln else f"unknown message type {t}"
            else:
                reason = "bytes outside any message"
            # damage right after a message taken as it stood: damage may have cut that one short
            # (a message after it starts inside it), then it is damage and the scan goes on there
            lt = buf[last + 2] if last >= 0 else FMT_TYPE
            if not resync and lt != FMT_TYPE and last + lengths[lt] == o:
                cut = None if self._followed(o) else self._inner_message(last, o)
                if cut is not None:
                    offsets[lt].pop()
                    self._skip(last, cut - last, "message cut off by damage")
                    o, last = cut, -1
                    continue
            nxt = find(HEAD, o + 1)
            end = nxt if nxt >= 0 else n
            self._skip(o, end - o, reason)
            o = end
            resync = True
        if o < n:
            self._skip(o, n - o, "message cut off at the end of the file")

    def _followed(self, e: int) -> bool:
        """Whether a message ending at `e` is followed by a header or the end of the file."""
        return e >= self.size - 1 or self._buf[e:e + 2] == HEAD

    def _inner_message(self, o: int, e: int) -> int | None:
        """The first header inside what seems a message spanning [o, e) that frames a message
        followed by a header (or the end of the file): where that message really ends when
        damage cut it short, or where real messages lie under damage that reads as one. None
        when there is none."""
        buf, n, lengths = self._buf, self.size, self._lengths
        h = buf.find(HEAD, o + 1, e + 1)  # a header may start on the message's last byte
        while h >= 0:
            ln = lengths[buf[h + 2]] if h + 2 < n else 0
            if ln and h + ln <= n and self._followed(h + ln):
                return h
            h = buf.find(HEAD, h + 1, e + 1)
        return None

    def _skip(self, offset: int, length: int, reason: str, kind: str = "damage") -> None:
        last = self.skipped[-1] if self.skipped else None
        if last is not None and last.offset + last.length == offset and last.reason == reason and kind == "damage":
            last.length += length
        else:
            self.skipped.append(Skip(offset, length, reason, kind))

    @property
    def skipped_bytes(self) -> int:
        return sum(s.length for s in self.skipped)

    def counts(self) -> dict[str, int]:
        return {self.formats[t].name if t in self.formats else str(t): len(a) for t, a in self.offsets.items()}

    def record(self, offset: int) -> bytes:
        """The message found at `offset` (one of `offsets`), header included, byte for byte."""
        t = self._buf[offset + 2]
        return bytes(self._buf[offset:offset + (FMT_LEN if t == FMT_TYPE else self.formats[t].length)])

    def type_of(self, name: str) -> Format | None:
        return self._names.get(name)

    def message_offsets(self, name: str) -> np.ndarray:
        """File offsets of the messages of one type, in file order (empty when there are none)."""
        f = self.type_of(name)
        if f is None or f.type not in self.offsets:
            return np.zeros(0, np.int64)
        return np.frombuffer(self.offsets[f.type], dtype=np.uint64).astype(np.int64)

    def _rows(self, f: Format, offs: np.ndarray, width: int) -> np.ndarray:
        """The `width` bytes after the header of each message at `offs`, one row each."""
        raw = np.frombuffer(self._buf, dtype=np.uint8)
        cols = np.arange(width)
        out = np.empty((len(offs), width), np.uint8)
        chunk = max(1, (8 << 20) // (8 * max(width, 1)))  # bounds the gather index at about 8 MB
        for a in range(0, len(offs), chunk):
            part = offs[a:a + chunk] + 3
            out[a:a + len(part)] = raw[part[:, None] + cols[None, :]]
        return out

    def repeated(self, name: str) -> np.ndarray:
        """For each message of a type (file order): the index of the earlier message it repeats
        byte for byte, or -1. Messages carry a time stamp, so a repeat is a copied chunk."""
        offs = self.message_offsets(name)
        f = self.type_of(name)
        if f is None or not len(offs):
            return np.full(len(offs), -1, np.int64)
        rows = self._rows(f, offs, f.length - 3)
        keys = np.ascontiguousarray(rows).view(np.dtype((np.void, rows.shape[1]))).reshape(-1) if rows.shape[1] else \
            np.zeros(len(offs), np.dtype((np.void, 1)))
        _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
        orig = first[inverse.reshape(-1)]
        return np.where(orig == np.arange(len(offs)), -1, orig).astype(np.int64)

    def messages(self, name: str, scaled: bool = True) -> dict[str, np.ndarray]:
        """All messages of one type as columns (empty dict when the log has none).

        Values are scaled by the format's implied multiplier (1e-7 for L lat/lon, 0.01 for
        c/C/e/E), so lat/lon come out in degrees.
        """
        f = self.type_of(name)
        if f is None or f.dtype is None or f.type not in self.offsets:
            return {}
        rec = self._rows(f, self.message_offsets(name), f.dtype.itemsize).view(f.dtype).reshape(-1)
        out: dict[str, np.ndarray] = {}
        for col in f.dtype.names or ():
            if col in f.undecoded:
                continue
            v = rec[col]
            if scaled and col in f.scale:
                v = v.astype(np.float64) * f.scale[col]
            out[col] = v
        return out
