"""The target's 2D track: its type and file, video reading and trackers.

This package never imports ``tlsync_pipeline`` nor ``calibration``.
"""

from trackers.errors import TrackInputError
from trackers.track import Track, read_track, write_track

__all__ = ["Track", "TrackInputError", "read_track", "write_track"]
