"""Every log reader tlsync has, in the order content detection tries them.

Binary magic numbers first (ULog, DataFlash, MAVLink tlog, ROS bags, FIT,
MP4), then XML roots (GPX, KML), then text layouts, most specific first
(NMEA, RTKLIB, DJI CSV, TUM, generic CSV). A text test never runs on a
binary file (``reader.text_of``), so a text fragment inside a binary log
cannot decide. FORMATS, in this order, is what ``--format`` and ``[target]
format`` accept (besides ``auto``).
"""

from __future__ import annotations

from tlsync_pipeline.ingest import csvlog, dataflash, dji, fit, gopro, gpx, kml, nmea, rosbag, rtklib, tlog, tum, ulog
from tlsync_pipeline.ingest.reader import Reader

READERS: tuple[Reader, ...] = (
    ulog.READER,
    dataflash.READER,
    tlog.READER,
    rosbag.READER,
    fit.READER,
    gopro.READER,
    gpx.READER,
    kml.READER,
    nmea.READER,
    rtklib.READER,
    dji.READER,
    tum.READER,
    csvlog.READER,
    csvlog.ODOMETRY_READER,
)
FORMATS: tuple[str, ...] = tuple(r.name for r in READERS)
BY_NAME = {r.name: r for r in READERS}
