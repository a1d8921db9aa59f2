"""Every log reader tlsync has, in the order content detection tries them.

Binary magic numbers first (ULog, DataFlash, MAVLink tlog, ROS bags, FIT,
MP4), then XML roots (GPX, KML), then text layouts, most specific first
(NMEA, RTKLIB, DJI SRT subtitles, DJI CSV, TUM, generic CSV). A text test never runs on a
binary file (``reader.text_of``), so a text fragment inside a binary log
cannot decide. FORMATS, in this order, is what ``--format`` and ``[target]
format`` accept (besides ``auto``).
"""

from __future__ import annotations

from tlsync_pipeline.ingest.csvlog import ODOMETRY_READER
from tlsync_pipeline.ingest.csvlog import READER as CSV
from tlsync_pipeline.ingest.dataflash import READER as DATAFLASH
from tlsync_pipeline.ingest.dji import READER as DJI
from tlsync_pipeline.ingest.fit import READER as FIT
from tlsync_pipeline.ingest.formats import FORMATS
from tlsync_pipeline.ingest.gopro import READER as GOPRO
from tlsync_pipeline.ingest.gpx import READER as GPX
from tlsync_pipeline.ingest.kml import READER as KML
from tlsync_pipeline.ingest.nmea import READER as NMEA
from tlsync_pipeline.ingest.reader import Reader
from tlsync_pipeline.ingest.rosbag import READER as ROSBAG
from tlsync_pipeline.ingest.rtklib import READER as RTKLIB
from tlsync_pipeline.ingest.srt import READER as SRT
from tlsync_pipeline.ingest.tlog import READER as TLOG
from tlsync_pipeline.ingest.tum import READER as TUM
from tlsync_pipeline.ingest.ulog import READER as ULOG

READERS: tuple[Reader, ...] = (
    ULOG,
    DATAFLASH,
    TLOG,
    ROSBAG,
    FIT,
    GOPRO,
    GPX,
    KML,
    NMEA,
    RTKLIB,
    SRT,
    DJI,
    TUM,
    CSV,
    ODOMETRY_READER,
)
assert FORMATS == tuple(r.name for r in READERS), "ingest/formats.py lists READERS' names"
BY_NAME = {r.name: r for r in READERS}
