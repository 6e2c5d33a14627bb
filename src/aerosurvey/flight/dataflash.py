"""ArduPilot DataFlash (.bin) logs: self-describing, damage-tolerant, fast.

Every message starts with 0xA3 0x95 and a type byte; FMT messages (type 128) define each
type's length, name, field formats and column names, and FMTU/MULT/UNIT add units and
multipliers. The reader walks the message boundaries once, keeping only each message's
offset in a compact array per type (no Python object per message), and decodes the types
asked for in one numpy operation each. Damage (a truncated tail, corrupted bytes, an
unknown type) is skipped by searching for the next valid header; what was skipped, and
where, is reported.
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


def _dtype(fmt: str, columns: list[str]) -> tuple[np.dtype, dict[str, float]] | None:
    fields, scale = [], {}
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


@dataclass
class Skip:
    offset: int
    length: int
    reason: str


class DataFlashLog:
    """A DataFlash log opened for reading (memory-mapped)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self._fh = open(self.path, "rb")
        size = self.path.stat().st_size
        self._buf = mmap.mmap(self._fh.fileno(), 0, access=mmap.ACCESS_READ) if size else b""
        self.size = size
        self.formats: dict[int, Format] = {}
        self.offsets: dict[int, array] = {}
        self.skipped: list[Skip] = []
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
        try:
            typ, length, name, fmt, cols = struct.unpack_from("<BB4s16s64s", self._buf, o + 3)
        except struct.error:
            return False
        name_s = name.rstrip(b"\0").decode("ascii", "replace")
        fmt_s = fmt.rstrip(b"\0").decode("ascii", "replace")
        cols_s = cols.rstrip(b"\0").decode("ascii", "replace")
        columns = cols_s.split(",") if cols_s else []
        if length < 3 or not name_s.isprintable() or not name_s.strip() or (typ == FMT_TYPE and length != FMT_LEN):
            return False
        # Real logs hold FMT records whose column list does not match the format (old firmware's
        # FMT-for-FMT names four columns for "BBnNZ"; some EKF5 records list 10 names for 13
        # fields) and records with no fields at all (STRT). Their length still frames the
        # messages, so the type is kept; it just cannot be decoded into named columns.
        f = Format(typ, length, name_s, fmt_s, columns)
        dt = _dtype(fmt_s, columns) if fmt_s and len(columns) == len(fmt_s) else None
        if dt is not None and dt[0].itemsize == length - 3:
            f.dtype, f.scale = dt
        self.formats[typ] = f
        return True

    def _scan(self) -> None:
        buf, n = self._buf, self.size
        lengths = [0] * 256
        lengths[FMT_TYPE] = FMT_LEN
        offsets = self.offsets
        o = 0
        find = buf.find
        while o + 3 <= n:
            if buf[o] == 0xA3 and buf[o + 1] == 0x95:
                t = buf[o + 2]
                ln = lengths[t]
                if ln and o + ln <= n:
                    if t == FMT_TYPE:
                        if self._add_format(o):
                            f = self.formats[buf[o + 3]]
                            lengths[f.type] = f.length
                        else:
                            nxt = find(HEAD, o + 1)
                            self._skip(o, (nxt if nxt >= 0 else n) - o, "malformed FMT message")
                            o = nxt if nxt >= 0 else n
                            continue
                    a = offsets.get(t)
                    if a is None:
                        a = offsets[t] = array("Q")
                    a.append(o)
                    o += ln
                    continue
                reason = "message cut off at the end of the file" if ln else f"unknown message type {t}"
            else:
                reason = "bytes outside any message"
            nxt = find(HEAD, o + 1)
            end = nxt if nxt >= 0 else n
            self._skip(o, end - o, reason)
            o = end
        if o < n:
            self._skip(o, n - o, "message cut off at the end of the file")

    def _skip(self, offset: int, length: int, reason: str) -> None:
        if self.skipped and self.skipped[-1].offset + self.skipped[-1].length == offset and self.skipped[-1].reason == reason:
            self.skipped[-1].length += length
        else:
            self.skipped.append(Skip(offset, length, reason))

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
        return next((f for f in self.formats.values() if f.name == name), None)

    def messages(self, name: str, scaled: bool = True) -> dict[str, np.ndarray]:
        """All messages of one type as columns (empty dict when the log has none).

        Values are scaled by the format's implied multiplier (1e-7 for L lat/lon, 0.01 for
        c/C/e/E), so lat/lon come out in degrees.
        """
        f = self.type_of(name)
        if f is None or f.dtype is None or f.type not in self.offsets:
            return {}
        offs = np.frombuffer(self.offsets[f.type], dtype=np.uint64).astype(np.int64) + 3
        raw = np.frombuffer(self._buf, dtype=np.uint8)
        width = np.arange(f.dtype.itemsize)
        rec = np.empty(len(offs), dtype=f.dtype)
        chunk = max(1, (8 << 20) // (8 * f.dtype.itemsize))  # bounds the gather index at about 8 MB
        for a in range(0, len(offs), chunk):
            part = offs[a:a + chunk]
            rec[a:a + len(part)] = raw[part[:, None] + width[None, :]].view(f.dtype).reshape(-1)
        out: dict[str, np.ndarray] = {}
        for col in f.dtype.names:
            v = rec[col]
            if scaled and col in f.scale:
                v = v.astype(np.float64) * f.scale[col]
            out[col] = v
        return out
