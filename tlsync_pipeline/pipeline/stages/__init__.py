"""One module per stage, each declaring its ``SPEC``: intrinsics, calibrate, track, ingest, vote, sync, export, render
(and ``cameras``, the per-camera files the project-wide stages share; ``camera_plan``, what the project asks of each
camera).

The list of stages is in ``pipeline.graph`` (STAGE_SPECS); this package imports nothing, so that a
stage's code (its cache key) is only what its own module imports.
"""
