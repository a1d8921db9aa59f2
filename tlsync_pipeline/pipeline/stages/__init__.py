"""One module per stage: calibrate, track, ingest, vote, sync, export, render."""

# Stage name -> version; bump a version when the stage's output for the same inputs changes.
STAGE_VERSIONS = {"calibrate": 1, "track": 1, "ingest": 1, "vote": 1, "sync": 1, "export": 2, "render": 1}
STAGES = tuple(STAGE_VERSIONS)
PER_CAMERA = ("calibrate", "track", "vote")
