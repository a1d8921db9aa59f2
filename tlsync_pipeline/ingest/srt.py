"""DJI subtitle telemetry (``.SRT``), written beside a drone's video: one block per second or per frame.

Every generation writes its own layout (samples: DJI_SRT_Parser's); what is read of each block:

- media time: the subtitle's start (``00:01:02,040 --> ...``), seconds on the video's timeline;
- wall clock: ``2017.08.05 14:11:51`` (whole seconds: Phantom 4, Mavic Pro, M300),
  ``2019-09-27 10:28:08,438,904`` (ms, us: Mavic 2, Air 2/2S), ``2021-12-25 12:27:52.373``
  (Mavic 3, Mini 2/3), an ISO time with ``Z`` (UTC); without a ``Z`` it is the drone's local
  time with no zone in the file;
- position: ``[latitude: ..] [longitude: ..]`` (also ``longtitude``), or ``GPS(a, b, c)`` /
  ``RTK(a, b, c)`` whose order is decided per file (below), with ``HOME(a, b)`` beside it in
  the same order;
- height, the first the file has of: ``abs_alt`` and ``[altitude: ..]`` (MSL), ``H 45.6m``,
  ``rel_alt``, ``BAROMETER`` and ``Hb`` (above the take-off point).

Times: a wall clock with milliseconds is each fix's time (it is the drone's clock of the
telemetry; the subtitle times agree with it within a frame); a whole-second one only anchors
the subtitle times, t = media time + one offset per run (from the whole seconds:
tlsync_pipeline.ingest.clocks; within 0.5 s for blocks exactly a second apart, better as
their phases spread), so the fixes keep the subtitle's spacing. A run ends where
wall - media jumps (clips joined into one file). The wall clock is local time
unless it says ``Z`` or the project gives ``[target] utc_offset`` (local - UTC): without
either the times are relative ("offsets work, UTC does not"). Without a wall clock t is the
media time; without subtitle times (some Mavic 2 firmware) the wall clock. The report states
which, and the video's time 0 on the log's clock (``video_time_zero``).

Order of ``GPS(a, b, c)``: a value beyond +-90 is a longitude (decides); else the distance to
HOME against the file's own ``D`` (distance to home, m), else the implied speeds against its
``H.S`` (horizontal speed), else the firmware's layout: a third value with a unit (``0.0M``,
M300) means (lat, lon, altitude), a bare integer (satellites: Phantom 4, Mavic Pro, Mini)
(lon, lat). The report states the order and what decided it; evidence that disagrees is a
warning. Labelled coordinates that all lie within +-pi and 0.001 of each other are radians
(an Air 2 firmware bug): converted, with a warning.

Precision: each fix's sigma is the quantization of its printed coordinates, sqrt((q_N^2 +
q_E^2) / 24) for steps q of one unit in the last decimal (4 decimals: 11 m steps north, a
sigma of about 3 m): the receiver's own error is not in the file, so this is a floor. Blocks
without a position (``n/a``, 0, 0) are dropped and counted.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.clocks import onto_coarse_clock, whole_second_uncertainty
from tlsync_pipeline.ingest.reader import Reader, text_of
from tlsync_pipeline.ingest.records import GEODETIC, MSL, TAKEOFF, LogRecords, check_geodetic, make_records

NO_POSITION = "no position (n/a, or latitude and longitude 0)"
M_PER_DEG = 111_320.0
LOCAL_CLOCK = "the drone's local wall clock (time zone not in the file)"
RUN_BREAK_S = 2.5  # wall - media jumping by more than this: another clip
NUMBER = r"-?\d+(?:\.\d+)?"
_TIMECODE = re.compile(r"(\d+):(\d\d):(\d\d)[,.](\d{3})\s*-->")
_DATE = re.compile(r"(\d{4})[-.](\d{1,2})[-.](\d{1,2})[ T](\d{1,2}):(\d\d):(\d\d)(?:([.,])(\d{1,6}))?(?:,(\d{3}))?(Z)?")
_LAT = re.compile(r"\[\s*latitude\s*:\s*(" + NUMBER + r")")
_LON = re.compile(r"\[\s*longt?itude\s*:\s*(" + NUMBER + r")")
_TUPLE = re.compile(r"\b(GPS|RTK|HOME)\s*\(([^)]*)\)")
_HEIGHTS = (  # (pattern, reference), in the order of preference
    (re.compile(r"abs_alt\s*:\s*(" + NUMBER + ")"), MSL),
    (re.compile(r"\[\s*altitude\s*:\s*(" + NUMBER + ")"), MSL),
    (re.compile(r"(?:^|[\s,])H\s+(" + NUMBER + r")\s*m\b"), TAKEOFF),
    (re.compile(r"rel_alt\s*:\s*(" + NUMBER + ")"), TAKEOFF),
    (re.compile(r"BAROMETER\s*:\s*(" + NUMBER + ")"), TAKEOFF),
    (re.compile(r"\bHb\s*:\s*(" + NUMBER + ")"), TAKEOFF),
)
_HEIGHT_NAMES = ("abs_alt", "altitude", "H", "rel_alt", "BAROMETER", "Hb")  # also the text each pattern needs
_UNIT = re.compile(r"[A-Za-z]+$")  # a unit after a number (0.0M)
_UNIT_AND_BLANKS = re.compile(r"[A-Za-z\s]+$")
_TAG = re.compile(r"<[^>]*>")  # HTML tags in the telemetry (font colours), read as blanks
_DISTANCE = re.compile(r"(?:^|[\s,])D\s+(" + NUMBER + r")\s*m\b")
_SPEED = re.compile(r"H\.S\s+(" + NUMBER + r")\s*m/s")


@dataclass
class _Block:
    """What one subtitle block says (NaN where it says nothing)."""

    line: int
    media: float = math.nan
    wall: float = math.nan
    subsecond: bool = False
    zulu: bool = False
    a: str | None = None  # the two coordinates as written: labelled (lat, lon), or GPS(a, b, c) in file order
    b: str | None = None
    third: str | None = None  # GPS(a, b, c)'s third value as written
    labelled: bool = False
    home: tuple[float, float] | None = None
    heights: tuple[float, ...] = ()
    distance: float = math.nan
    speed: float = math.nan


def _sniff(head: bytes) -> bool:
    text = text_of(head)
    if text is None:
        return False
    lines = [line.strip() for line in text.split("\n")[:12] if line.strip()]
    if not lines or not lines[0].isdigit():
        return False
    body = "\n".join(lines)
    return bool(_TIMECODE.match(lines[1]) if len(lines) > 1 else False) or (
        bool(_DATE.search(body)) and bool(re.search(r"GPS\s*\(|\[\s*latitude", body))
    )


def _number(text: str | None) -> float:
    try:
        return float(_UNIT.sub("", text.strip())) if text is not None else math.nan
    except ValueError:
        return math.nan


def _decimals(text: str) -> int:
    digits = _UNIT_AND_BLANKS.sub("", text.strip())
    return len(digits.split(".", 1)[1]) if "." in digits else 0


def _blocks(text: str) -> list[_Block]:
    """The blocks of a subtitle file, line by line: an integer line starts a block, the last timecode in it counts."""
    blocks: list[_Block] = []
    body: list[str] = []

    def close() -> None:
        if blocks:
            text = " ".join(body)
            _parse_body(blocks[-1], _TAG.sub(" ", text) if "<" in text else text)
        body.clear()

    for number, raw in enumerate(text.split("\n"), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.isdigit():
            close()
            blocks.append(_Block(number))
        elif blocks and (tc := _TIMECODE.match(line)):
            h, m, s, ms = (int(g) for g in tc.groups())
            blocks[-1].media = h * 3600 + m * 60 + s + ms / 1000
        elif blocks:
            body.append(line)
    close()
    return blocks


def _parse_body(block: _Block, body: str) -> None:
    if date := _DATE.search(body):
        y, mo, d, h, mi, s, _, frac, micro, zulu = date.groups()
        try:
            wall = dt.datetime(int(y), int(mo), int(d), int(h), int(mi), int(s), tzinfo=dt.timezone.utc).timestamp()
        except ValueError:
            wall = math.nan
        if frac:
            wall += int(frac) / 10 ** len(frac) + (int(micro) / 1e6 if micro else 0.0)
        block.wall, block.subsecond, block.zulu = wall, bool(frac), bool(zulu)
    # each pattern is searched only where the text it needs is in the body: the same matches, fewer searches
    lat = _LAT.search(body) if "latitude" in body else None
    lon = _LON.search(body) if "long" in body else None
    tuples = {key: value.split(",") for key, value in _TUPLE.findall(body)} if "(" in body else {}
    if lat and lon:
        block.a, block.b, block.labelled = lat.group(1), lon.group(1), True
    elif (gps := tuples.get("GPS", tuples.get("RTK"))) is not None and len(gps) >= 2:
        block.a, block.b = gps[0], gps[1]
        block.third = gps[2].strip() if len(gps) > 2 else None
    if (home := tuples.get("HOME")) is not None and len(home) >= 2:
        values = (_number(home[0]), _number(home[1]))
        block.home = values if all(math.isfinite(v) for v in values) else None
    block.heights = tuple(
        float(m.group(1)) if name in body and (m := pattern.search(body)) else math.nan
        for (pattern, _), name in zip(_HEIGHTS, _HEIGHT_NAMES)
    )
    block.distance = _number(m.group(1)) if "D" in body and (m := _DISTANCE.search(body)) else math.nan
    block.speed = _number(m.group(1)) if "H.S" in body and (m := _SPEED.search(body)) else math.nan


def read_srt(path: str | Path, utc_offset_s: float | None = None) -> LogRecords:
    """Read a DJI subtitle file; utc_offset_s: local time - UTC of its wall clock (s), None = unknown. See the module
    notes.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    blocks = _blocks(text.replace("\r\n", "\n").replace("\r", "\n"))
    if not blocks:
        raise InputError(
            f"{path}: no position fix: no subtitle blocks (expected DJI SRT: a block number, a timecode line, the "
            f"telemetry)"
        )
    dropped: dict[str, list[int]] = {}
    fixes = []
    for block in blocks:
        a, b = _number(block.a), _number(block.b)
        if not (math.isfinite(a) and math.isfinite(b)) or (a == 0.0 and b == 0.0):
            dropped.setdefault(NO_POSITION, []).append(block.line)
            continue
        fixes.append((block, a, b))
    if not fixes:
        reasons = f"; {len(dropped[NO_POSITION])} block(s) without a position" if dropped else ""
        raise InputError(
            f"{path}: no position fix in the subtitle blocks{reasons} (expected GPS(...) or [latitude: ..] "
            f"[longitude: ..])"
        )
    notes, warnings = [], []
    pairs = np.array([(a, b) for _, a, b in fixes])
    labelled = np.array([f[0].labelled for f in fixes])
    lat, lon = pairs[:, 0].copy(), pairs[:, 1].copy()
    swapped = np.zeros(len(fixes), dtype=bool)  # rows written (longitude, latitude)
    if labelled.any():
        la, lo = lat[labelled], lon[labelled]
        if np.abs(la).max() <= math.pi / 2 and np.abs(lo).max() <= math.pi and np.ptp(la) < 1e-3 and np.ptp(lo) < 1e-3:
            lat[labelled], lon[labelled] = np.degrees(la), np.degrees(lo)
            warnings.append("the coordinates are in radians (a DJI firmware bug): converted to degrees")
        notes.append("latitude and longitude as labelled ([latitude: ..] [longitude: ..])")
    if (~labelled).any():
        lat_first, reason, conflict = gps_order(pairs[~labelled], [f[0] for f in fixes if not f[0].labelled])
        swapped[~labelled] = not lat_first
        lat[swapped], lon[swapped] = pairs[swapped, 1], pairs[swapped, 0]
        notes.append(f"GPS(...) read as ({'latitude, longitude' if lat_first else 'longitude, latitude'}): {reason}")
        if conflict:
            warnings.append(f"the latitude/longitude order of GPS(...) is uncertain: {conflict}")
    t, time_note, utc, clock, zero, spread = _times(path, [f[0] for f in fixes], utc_offset_s, warnings)
    notes.append(time_note)
    heights, altitude, height_note = _heights(np.array([f[0].heights for f in fixes]), _fpv(text), warnings)
    notes.append(height_note)
    decimals = np.array([[_decimals(f[0].a or ""), _decimals(f[0].b or "")] for f in fixes])
    decimals[swapped] = decimals[swapped, ::-1]
    step_n = M_PER_DEG * 10.0 ** -decimals[:, 0]
    step_e = M_PER_DEG * 10.0 ** -decimals[:, 1] * np.cos(np.radians(lat))
    sigma = np.sqrt((step_n**2 + step_e**2) / 24)
    rounding = np.hypot(step_n, step_e) / 2
    fewest, most = int(decimals.min()), int(decimals.max())
    notes.append(
        f"precision: {fewest if fewest == most else f'{fewest} to {most}'} decimals of a degree "
        f"({M_PER_DEG * 10.0**-fewest:.2g} m steps north), "
        f"per-fix sigma {sigma.min():.2g}-{sigma.max():.2g} m from the rounding alone"
    )
    if fewest <= 4:
        warnings.append(
            f"coordinates have {fewest} decimals: {M_PER_DEG * 10.0**-fewest:.0f} m steps; expect a staircase track"
        )
    lines = [f[0].line for f in fixes]
    for i in range(len(fixes)):
        check_geodetic(path, float(lat[i]), float(lon[i]), float(heights[i]), lines[i])
    rows = np.column_stack([t, lat, lon, heights])
    return make_records(
        path,
        "srt",
        GEODETIC,
        rows,
        lines,
        utc=utc,
        dropped=dropped,
        warnings=warnings,
        altitude=altitude,
        sigma=sigma,
        clock=clock,
        notes=notes,
        video_time_zero=zero,
        video_zero_spread_s=spread,
        rounding_m=rounding,
        local_time=clock == LOCAL_CLOCK,
    )


def gps_order(pairs: np.ndarray, blocks: list[_Block]) -> tuple[bool, str, str | None]:
    """(latitude first?, what decided it, a disagreement to warn about or None) for GPS(a, b, ...) pairs."""
    beyond = np.abs(pairs) > 90.0
    evidence: list[tuple[str, bool]] = []  # (what, latitude first), strongest first
    if beyond[:, 0].any() != beyond[:, 1].any():
        evidence.append(("a value beyond +-90 degrees can only be a longitude", bool(beyond[:, 1].any())))
    for name, test in (
        ("the distance to HOME matches the file's D", _home_evidence),
        ("the implied speeds match the file's H.S", _speed_evidence),
    ):
        verdict = test(pairs, blocks)
        if verdict is not None:
            evidence.append((name, verdict))
    thirds = [b.third for b in blocks if b.third]
    layout = None
    if thirds:
        unit = sum(bool(re.search(r"\d\s*[A-Za-z]+$", s)) for s in thirds) > len(thirds) / 2
        layout = (
            f"the firmware's layout GPS(lat, lon, {'altitude' if unit else 'satellites'})"
            if unit
            else "the firmware's layout GPS(lon, lat, satellites)",
            unit,
        )
    if layout is not None:
        evidence.append(layout)
    if not evidence:
        return (
            False,
            "no evidence in the file: taken as (longitude, latitude), the older firmware's layout",
            "nothing in the file decides it",
        )
    reason, verdict = evidence[0]
    against = [what for what, v in evidence[1:] if v != verdict]
    return verdict, reason, (f"{reason}, but {' and '.join(against)} says otherwise" if against else None)


def _enu_distance(lat0, lon0, lat1, lon1) -> np.ndarray:
    north = np.radians(lat1 - lat0) * 6_371_000.0
    east = np.radians(lon1 - lon0) * 6_371_000.0 * np.cos(np.radians((lat0 + lat1) / 2))
    return np.hypot(north, east)


def _decisive(errors_lat_first: np.ndarray, errors_lon_first: np.ndarray) -> bool | None:
    """The order whose errors are less than half the other's (medians), None when neither is."""
    if len(errors_lat_first) < 3:
        return None
    a, b = float(np.median(errors_lat_first)), float(np.median(errors_lon_first))
    if a < 0.5 * b:
        return True
    if b < 0.5 * a:
        return False
    return None


def _home_evidence(pairs: np.ndarray, blocks: list[_Block]) -> bool | None:
    rows = [i for i, b in enumerate(blocks) if b.home is not None and math.isfinite(b.distance) and b.distance > 20.0]
    if not rows:
        return None
    p, h = pairs[rows], np.array([blocks[i].home for i in rows])
    d = np.array([blocks[i].distance for i in rows])
    lat_first = np.abs(_enu_distance(h[:, 0], h[:, 1], p[:, 0], p[:, 1]) - d)
    lon_first = np.abs(_enu_distance(h[:, 1], h[:, 0], p[:, 1], p[:, 0]) - d)
    return _decisive(lat_first, lon_first)


def _speed_evidence(pairs: np.ndarray, blocks: list[_Block], window: int = 10) -> bool | None:
    """Distances over `window` blocks against the H.S speeds integrated over them (straight stretches agree)."""
    media = np.array([b.media for b in blocks])
    speed = np.array([b.speed for b in blocks])
    if len(blocks) <= window or not np.isfinite(speed).all() or not np.isfinite(media).all():
        return None
    dt_s = np.diff(media)
    path = np.array([np.sum(speed[i : i + window] * dt_s[i : i + window]) for i in range(len(blocks) - window)])
    keep = path > 30.0
    if keep.sum() < 3:
        return None
    i = np.flatnonzero(keep)
    lat_first = np.abs(_enu_distance(pairs[i, 0], pairs[i, 1], pairs[i + window, 0], pairs[i + window, 1]) - path[i])
    lon_first = np.abs(_enu_distance(pairs[i, 1], pairs[i, 0], pairs[i + window, 1], pairs[i + window, 0]) - path[i])
    return _decisive(lat_first, lon_first)


def _times(path: Path, blocks: list[_Block], utc_offset_s: float | None, warnings: list[str]):
    """(t, note, utc, clock, video_time_zero, how far that can be off) of the fixes; see the module notes."""
    media = np.array([b.media for b in blocks])
    wall = np.array([b.wall for b in blocks])
    has_media, has_wall = np.isfinite(media).all(), np.isfinite(wall).all()
    if np.isfinite(wall).any() and not has_wall:
        warnings.append(
            f"{int((~np.isfinite(wall)).sum())} of {len(blocks)} blocks have no date: the wall clock is not used"
        )
    zulu = has_wall and all(b.zulu for b in blocks)
    subsecond = has_wall and all(b.subsecond for b in blocks)
    if utc_offset_s is not None and (zulu or not has_wall):
        warnings.append(
            "utc_offset is not used: " + ("the file's dates are UTC (Z)" if zulu else "the file has no wall clock")
        )
    if has_wall and not zulu and utc_offset_s is not None:
        wall = wall - utc_offset_s
    utc = has_wall and (zulu or utc_offset_s is not None)
    zone = (
        "UTC (the file says Z)"
        if zulu
        else (
            f"local time, UTC{_hours(utc_offset_s)} as given (utc_offset)"
            if utc_offset_s is not None
            else "the drone's local time (no zone in the file; give [target] utc_offset for UTC)"
        )
    )
    if has_media and has_wall:
        anchored, run = onto_coarse_clock(media, wall, whole_seconds=not subsecond, break_s=RUN_BREAK_S)
        if int(run[-1]) > 0:
            warnings.append(
                f"{int(run[-1]) + 1} runs of subtitle times against the wall clock (clips joined into one file): each "
                f"anchored apart"
            )
        first = run == 0
        if subsecond:
            spread = float(np.abs(wall - anchored).max())
            note = f"times: the wall clock, {zone}; the subtitle (video) times agree within {spread * 1000:.0f} ms"
            t, zero = wall, float(np.median(wall[first] - media[first]))
        else:
            spread = whole_second_uncertainty(media[first])
            note = (
                f"times: the subtitle (video) times, anchored to the wall clock's whole seconds (within "
                f"{spread:.2f} s), {zone}"
            )
            t, zero = anchored, float(anchored[0] - media[0])
        return t, note, utc, None if utc else LOCAL_CLOCK, zero, spread
    if has_wall:
        return wall, f"times: the wall clock (no subtitle times), {zone}", utc, None if utc else LOCAL_CLOCK, None, None
    if has_media:
        return (
            media,
            "times: subtitle times on the video's timeline (the file has no date)",
            False,
            "the video's timeline (subtitle times)",
            0.0,
            0.0,
        )
    raise InputError(
        f"{path}:{blocks[0].line}: a subtitle block with neither a timecode nor a date (and others like it)"
    )


def _hours(offset_s: float) -> str:
    sign = "+" if offset_s >= 0 else "-"
    minutes = int(round(abs(offset_s) / 60))
    return f"{sign}{minutes // 60:02d}:{minutes % 60:02d}"


def _fpv(text: str) -> bool:
    """DJI FPV firmware writes [altitude: ..] in tenths of a metre (DJI_SRT_Parser's test for that drone)."""
    return (
        'font size="28"' in text
        and bool(re.search(r"\d{4}-\d{1,2}-\d{1,2} \d{1,2}:\d\d:\d\d\.\d{3}", text))
        and "[altitude:" in text
    )


def _heights(values: np.ndarray, fpv: bool, warnings: list[str]) -> tuple[np.ndarray, str, str]:
    """(heights, reference, note): each fix's first height in the order of _HEIGHTS.

    One kind for the whole file when every fix has it; otherwise each block its own (files joined from two
    drones write different ones), the reference of the most fixes, a warning when the references differ, and
    fixes without any height interpolated between their neighbours'.
    """
    for k, (_, reference) in enumerate(_HEIGHTS):
        if np.isfinite(values[:, k]).all():
            return (
                _scaled(values[:, k], k, fpv, warnings),
                reference,
                f"heights: {_HEIGHT_NAMES[k]} (m above {_WHERE[reference]})",
            )
    found = np.isfinite(values)
    if not found.any():
        warnings.append("no height in the subtitles: heights set to 0 above the take-off point")
        return np.zeros(len(values)), TAKEOFF, "heights: none in the file (0)"
    kind = np.where(found.any(axis=1), found.argmax(axis=1), -1)
    column = np.where(kind >= 0, values[np.arange(len(values)), np.maximum(kind, 0)], np.nan)
    altitude = kind == _HEIGHT_NAMES.index("altitude")
    column[altitude] = _scaled(column[altitude], _HEIGHT_NAMES.index("altitude"), fpv, warnings)
    used = sorted(set(kind[kind >= 0].tolist()))
    counts = {k: int((kind == k).sum()) for k in used}
    reference = _HEIGHTS[max(used, key=lambda k: counts[k])][1]
    if len({_HEIGHTS[k][1] for k in used}) > 1:
        warnings.append(
            "the blocks give heights above different references ("
            + ", ".join(f"{counts[k]} {_HEIGHT_NAMES[k]} above {_WHERE[_HEIGHTS[k][1]]}" for k in used)
            + f"): all read as above {_WHERE[reference]}; clips of different drones joined into one file?"
        )
    missing = kind < 0
    if missing.any():
        index = np.arange(len(column))
        column[missing] = np.interp(index[missing], index[~missing], column[~missing])
        warnings.append(
            f"{int(missing.sum())} of {len(column)} blocks have no height: interpolated from their neighbours"
        )
    kinds = " and ".join(f"{_HEIGHT_NAMES[k]} ({counts[k]} fixes)" for k in used)
    return column, reference, f"heights: {kinds}, each block its own (m above {_WHERE[reference]})"


_WHERE = {MSL: "mean sea level", TAKEOFF: "the take-off point"}


def _scaled(column: np.ndarray, k: int, fpv: bool, warnings: list[str]) -> np.ndarray:
    """DJI FPV's [altitude: ..] in metres (x 10, with a warning); other heights as they are."""
    if fpv and _HEIGHT_NAMES[k] == "altitude" and len(column):
        warnings.append("DJI FPV subtitles: [altitude: ..] read as tenths of a metre (x 10)")
        return column * 10.0
    return column


READER = Reader(
    "srt", "DJI SRT subtitles (block number, timecode, GPS(...) or [latitude: ..])", read_srt, _sniff, local_clock=True
)
