"""KML tracks (Google Earth, phone apps): ``gx:Track`` and time-stamped Points and LineStrings.

Parsed with defusedxml: a document that declares entities is refused (no
expansion, no external fetch). Read, in document order:

- ``gx:Track`` (also inside ``gx:MultiTrack``): its ``when`` / ``gx:coord``
  pairs (``lon lat alt``), one fix each; a ``gx:SimpleArrayData`` named
  ``accuracy`` (as My Tracks writes, metres) gives each fix's sigma;
- a Placemark with a ``Point`` and a ``TimeStamp``: one fix, unless the file
  has tracks (then such Points are start/end/waypoint markers, ignored);
- a Placemark with a ``LineString`` and a ``TimeSpan`` (begin and end): the
  vertices' times are spread between begin and end in proportion to the
  distance along the line (constant speed; the report warns), since a
  LineString has no per-vertex times. LineStrings without times are not a log
  and are ignored.

Times are ISO 8601 (no offset = UTC). Heights follow ``altitudeMode``:
``absolute`` means above mean sea level (MSL); ``clampToGround`` (the
default) and ``relativeToGround`` heights are not above a datum, so they are
read as written and the report warns.
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError
from tlsync_pipeline.ingest.reader import Reader, text_of, xml_root
from tlsync_pipeline.ingest.records import GEODETIC, MSL, LogRecords, check_geodetic, make_records, sort_by_time

UNIT = "point"
BAD_TIME = "time not ISO 8601"
BAD_COORD = "coordinate not 'lon lat [alt]'"
UNEQUAL = "gx:Track with unequal numbers of when and gx:coord (extra ones)"


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _iso(text: str | None) -> float | None:
    if not text:
        return None
    try:
        when = dt.datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        return None
    return (when if when.tzinfo else when.replace(tzinfo=dt.timezone.utc)).timestamp()


def _coord(text: str, sep: str | None) -> tuple[float, float, float] | None:
    parts = text.strip().split(sep)
    try:
        values = [float(v) for v in parts]
    except ValueError:
        return None
    if len(values) not in (2, 3) or not all(math.isfinite(v) for v in values):
        return None
    return values[1], values[0], values[2] if len(values) == 3 else 0.0


def _child(element, name: str):
    return next((c for c in element.iter() if _local(c.tag) == name), None)


def read_kml(path: str | Path) -> LogRecords:
    """Read the timed positions of a KML file; see the module notes."""
    path = Path(path)
    from defusedxml import DefusedXmlException
    from defusedxml.ElementTree import ParseError, fromstring

    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        root = fromstring(raw)
    except DefusedXmlException as exc:
        raise InputError(
            f"{path}: refused: the KML declares entities or a DTD ({type(exc).__name__}); tlsync does not expand them"
        ) from None
    except ParseError as exc:
        line = getattr(exc, "position", (None,))[0]
        raise InputError(f"{path}{f':{line}' if line else ''}: not well-formed XML: {exc}") from None
    rows, numbers, sigmas, modes, warnings = [], [], [], set(), []
    dropped: dict[str, list[int]] = {}
    counter = [0]
    has_tracks = any(_local(e.tag) == "Track" for e in root.iter())
    markers = 0

    def add(t, coord, mode, sigma=math.nan):
        counter[0] += 1
        if t is None:
            dropped.setdefault(BAD_TIME, []).append(counter[0])
            return
        if coord is None:
            dropped.setdefault(BAD_COORD, []).append(counter[0])
            return
        check_geodetic(path, coord[0], coord[1], coord[2], counter[0], UNIT)
        rows.append([t, *coord])
        numbers.append(counter[0])
        sigmas.append(sigma)
        modes.add(mode)

    spread = 0
    for element in root.iter():
        name = _local(element.tag)
        if name not in ("Track", "Placemark"):
            continue
        mode = _text(_child(element, "altitudeMode")).strip() or "clampToGround"
        if name == "Track":
            whens = [c.text for c in element if _local(c.tag) == "when"]
            coords = [c.text or "" for c in element if _local(c.tag) == "coord"]
            accuracy = _accuracy(element, len(whens))
            for when, coord, sigma in zip(whens, coords, accuracy):
                add(_iso(when), _coord(coord, None), mode, sigma)
            extra = abs(len(whens) - len(coords))
            if extra:
                dropped.setdefault(UNEQUAL, []).extend(range(counter[0] + 1, counter[0] + 1 + extra))
                counter[0] += extra
        elif name == "Placemark":
            stamp, span = _child(element, "TimeStamp"), _child(element, "TimeSpan")
            point, line = _child(element, "Point"), _child(element, "LineString")
            if point is not None and stamp is not None and _child(element, "Track") is None:
                if has_tracks:
                    markers += 1
                    continue
                coordinates = _text(_child(point, "coordinates")).strip()
                add(_iso(_text(_child(stamp, "when"))), _coord(coordinates, "," if "," in coordinates else None), mode)
            elif line is not None and span is not None:
                begin, end = _iso(_text(_child(span, "begin"))), _iso(_text(_child(span, "end")))
                vertices = [_coord(v, ",") for v in _text(_child(line, "coordinates")).split()]
                for t, coord in zip(_spread(begin, end, vertices), vertices):
                    add(t, coord, mode)
                spread += 1
    if spread:
        warnings.append(
            f"{spread} LineString(s) with only a TimeSpan: vertex times spread at constant speed between begin and end"
        )
    if markers:
        warnings.append(
            f"{markers} time-stamped Point placemark(s) ignored: with tracks in the file they are markers (start, "
            f"end, waypoints)"
        )
    altitude = MSL
    if modes - {"absolute"}:
        warnings.append(
            f"altitudeMode {', '.join(sorted(modes - {'absolute'}))}: heights are not above a datum (read as written)"
        )
    rows, numbers, sigmas = sort_by_time(rows, numbers, sigmas)
    sigma_m = np.asarray(sigmas, dtype=float)
    return make_records(
        path,
        "kml",
        GEODETIC,
        rows,
        numbers,
        unit=UNIT,
        dropped=dropped,
        ignored=markers,
        warnings=warnings,
        altitude=altitude,
        sigma=sigma_m if np.isfinite(sigma_m).any() else None,
    )


def _accuracy(track, n: int) -> list[float]:
    """Per-point accuracy (m) from the track's gx:SimpleArrayData name="accuracy", NaN where absent."""
    for data in track.iter():
        if _local(data.tag) == "SimpleArrayData" and data.get("name") == "accuracy":
            values = []
            for value in (v for v in data if _local(v.tag) == "value"):
                try:
                    values.append(float(value.text))
                except (TypeError, ValueError):
                    values.append(math.nan)
            return (values + [math.nan] * n)[:n]
    return [math.nan] * n


def _text(element) -> str:
    return (element.text or "") if element is not None else ""


def _spread(begin: float | None, end: float | None, vertices: list) -> list[float | None]:
    """Times of LineString vertices between begin and end, in proportion to the distance along the line."""
    if begin is None or end is None or end < begin or any(v is None for v in vertices):
        return [None] * len(vertices)
    steps = [0.0]
    for a, b in zip(vertices, vertices[1:]):
        north = math.radians(b[0] - a[0])
        east = math.radians(b[1] - a[1]) * math.cos(math.radians(a[0]))
        steps.append(steps[-1] + math.hypot(north, east))
    total = steps[-1]
    if total == 0:
        return [begin + (end - begin) * k / max(len(vertices) - 1, 1) for k in range(len(vertices))]
    return [begin + (end - begin) * s / total for s in steps]


def _sniff(head: bytes) -> bool:
    text = text_of(head)
    return text is not None and text.startswith("<") and xml_root(text) == "kml"


READER = Reader("kml", "KML (XML root <kml>)", read_kml, _sniff)
