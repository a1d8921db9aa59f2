"""GoPro's GPMF metadata (KLV): parsing of one payload and its GPS streams. Pure functions.

A KLV item is an 8-byte header, FourCC key, type character, structure size
(bytes) and repeat count (big-endian uint16), then size x repeat bytes of
data padded to a multiple of 4. Type 0 nests items. A ``DEVC`` holds
``STRM`` streams; a stream's sticky items (``SCAL``, ``GPSF``, ``GPSU``,
``GPSP``, ``GPSA``, ``TYPE``, and the timing items ``STMP``, ``TSMP``,
``TIMO``) describe the samples that follow them. ``STMP`` (HERO8 onwards,
MAX) is the camera's microsecond clock at the stream's first sample in the
payload, ``TSMP`` the stream's sample count since the recording started
(this payload's included), ``TIMO`` a delay of the stream's data (s).
``GPS5`` samples are int32 latitude, longitude (deg x SCAL), altitude (m x
SCAL), 2D and 3D speed; ``GPS9`` (HERO11 onwards) add days since 2000,
seconds since midnight (UTC), DOP x 100 and fix type, one time per sample.
"""

from __future__ import annotations

import calendar
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

_TYPES = {
    "b": "b",
    "B": "B",
    "s": "h",
    "S": "H",
    "l": "i",
    "L": "I",
    "f": "f",
    "d": "d",
    "j": "q",
    "J": "Q",
    "q": "i",
    "Q": "q",
}


class GPMFError(ValueError):
    """A payload that does not parse: names the byte offset and what was expected."""


@dataclass(frozen=True)
class GPSBlock:
    """The GPS samples of one payload.

    samples: float64 (n, k) scaled values (GPS5: lat, lon, alt, speed2d,
    speed3d; GPS9 adds days, seconds, dop, fix); utc: GPSU as POSIX seconds
    or None; fix: GPSF (0 none, 2 2D, 3 3D) or None; dop: GPSP / 100 or None;
    msl: GPSA says "MSLV" (heights above MSL) ; nine: a GPS9 stream;
    stmp_us: STMP (us) or None; tsmp: TSMP or None; timo_s: TIMO (s), 0 when absent.
    """

    samples: np.ndarray
    utc: float | None
    fix: int | None
    dop: float | None
    msl: bool
    nine: bool
    stmp_us: int | None = None
    tsmp: int | None = None
    timo_s: float = 0.0


def klv_items(data: bytes, start: int = 0, end: int | None = None):
    """(key, type, size, repeat, payload offset) of each item in data[start:end]; GPMFError when an item runs past the
    end.
    """
    end = len(data) if end is None else end
    offset = start
    while offset + 8 <= end:
        key = data[offset : offset + 4]
        kind, size, repeat = data[offset + 4], data[offset + 5], struct.unpack(">H", data[offset + 6 : offset + 8])[0]
        length = size * repeat
        if offset + 8 + length > end:
            raise GPMFError(f"byte {offset}: item {key!r} of {length} bytes runs past the end ({end})")
        yield key, kind, size, repeat, offset + 8
        offset += 8 + ((length + 3) & ~3)
        if key == b"\x00\x00\x00\x00":
            break


def _values(data: bytes, kind: str, size: int, repeat: int, offset: int, fields: str | None = None) -> list | str:
    """The item's values as a flat list (numbers) or a str (types c, U, F)."""
    raw = data[offset : offset + size * repeat]
    if kind in "cUF":
        return raw.split(b"\x00", 1)[0].decode("latin-1")
    if kind == "?":
        if not fields:
            raise GPMFError(f"byte {offset}: complex item without a TYPE")
        fmt = ">" + "".join(_TYPES[c] for c in fields)
        if struct.calcsize(fmt) != size:
            raise GPMFError(f"byte {offset}: TYPE {fields!r} is {struct.calcsize(fmt)} bytes, the item says {size}")
        return [v for k in range(repeat) for v in struct.unpack_from(fmt, raw, k * size)]
    code = _TYPES.get(kind)
    if code is None:
        raise GPMFError(f"byte {offset}: unknown type {kind!r}")
    count = size * repeat // struct.calcsize(code)
    return list(struct.unpack_from(f">{count}{code}", raw))


def _gpsu(text: str) -> float | None:
    """POSIX seconds of a GPSU string ``yymmddhhmmss.sss`` (UTC), None when it does not read."""
    try:
        y, mo, d, h, mi = (int(text[i : i + 2]) for i in range(0, 10, 2))
        return calendar.timegm((2000 + y, mo, d, h, mi, 0)) + float(text[10:])
    except (ValueError, IndexError, OverflowError):
        return None


def _streams(payload: bytes):
    """(start, end) byte ranges of every STRM of every DEVC in a payload."""
    for key, kind, size, repeat, offset in klv_items(payload):
        if key != b"DEVC" or kind != 0:
            continue
        for skey, skind, ssize, srepeat, soffset in klv_items(payload, offset, offset + size * repeat):
            if skey == b"STRM" and skind == 0:
                yield soffset, soffset + ssize * srepeat


def gps_blocks(payload: bytes) -> list[GPSBlock]:
    """The GPS5/GPS9 blocks of one GPMF payload, in order; GPMFError on a malformed payload."""
    return [block for start, end in _streams(payload) for block in _stream(payload, start, end)]


def stream_stamp(payload: bytes, key: bytes = b"SHUT") -> int | None:
    """STMP (us) of the stream holding ``key`` samples in a payload, None without one.

    The shutter stream (SHUT) is the video's own: gpmf-parser counts every
    stream's STMP from the SHUT STMP of the stream's first payload.
    """
    for start, end in _streams(payload):
        stamp = None
        for skey, kind, size, repeat, offset in klv_items(payload, start, end):
            if skey == b"STMP" and kind:
                values = _values(payload, chr(kind), size, repeat, offset)
                stamp = int(values[0]) if isinstance(values, list) and values else None
            elif skey == key:
                return stamp
    return None


def _stream(data: bytes, start: int, end: int) -> list[GPSBlock]:
    sticky: dict[bytes, Any] = {}
    blocks = []
    for key, kind, size, repeat, offset in klv_items(data, start, end):
        k = chr(kind) if kind else "\0"
        if key in (b"SCAL", b"GPSF", b"GPSP", b"GPSU", b"GPSA", b"TYPE", b"STMP", b"TSMP", b"TIMO"):
            sticky[key] = _values(data, k, size, repeat, offset)
        elif key in (b"GPS5", b"GPS9"):
            width = 5 if key == b"GPS5" else 9
            values = np.asarray(_values(data, k, size, repeat, offset, sticky.get(b"TYPE")), dtype=np.float64)
            if values.size % width:
                raise GPMFError(f"byte {offset}: {key.decode()} holds {values.size} values, not a multiple of {width}")
            scale = np.asarray(sticky.get(b"SCAL", [1]), dtype=np.float64)
            if scale.size not in (1, width) or not np.all(scale != 0):
                raise GPMFError(f"byte {offset}: SCAL has {scale.size} values for {width} fields (or a zero)")
            fix = sticky.get(b"GPSF")
            dop = sticky.get(b"GPSP")
            utc = sticky.get(b"GPSU")
            stmp, tsmp, timo = sticky.get(b"STMP"), sticky.get(b"TSMP"), sticky.get(b"TIMO")
            blocks.append(
                GPSBlock(
                    values.reshape(-1, width) / scale,
                    _gpsu(utc) if isinstance(utc, str) else None,
                    int(fix[0]) if isinstance(fix, list) and fix else None,
                    float(dop[0]) / 100 if isinstance(dop, list) and dop else None,
                    sticky.get(b"GPSA") == "MSLV",
                    width == 9,
                    int(stmp[0]) if isinstance(stmp, list) and stmp else None,
                    int(tsmp[0]) if isinstance(tsmp, list) and tsmp else None,
                    float(timo[0]) if isinstance(timo, list) and timo else 0.0,
                )
            )
    return blocks
