"""One module per stage: calibrate, track, ingest, vote, sync, export, render."""

# Stage name -> version; bump a version when the stage's output for the same inputs changes.
STAGE_VERSIONS = {"calibrate": 1, "track": 1, "ingest": 1, "vote": 2, "sync": 2, "export": 2, "render": 2}
STAGES = tuple(STAGE_VERSIONS)
PER_CAMERA = ("calibrate", "track", "vote")
