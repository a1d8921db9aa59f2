"""The target's 2D track: its type and file, video reading and trackers.

``track_video(path, kind="blob"|"csrt", init=None, init_frame=0, params=None,
progress=True)`` is the one entry point: a video file in, a Track out.
This package never imports ``tlsync_pipeline`` nor ``calibration``.
"""

from trackers.errors import TrackInputError
from trackers.track import Track, read_track, write_track
from trackers.tracking import track_video
from trackers.video import iter_frames, probe_video, read_frames

__all__ = ["Track", "TrackInputError", "iter_frames", "probe_video", "read_frames", "read_track", "track_video", "write_track"]
