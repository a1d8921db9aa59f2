"""tlsync's pipeline: project file, stages (calibrate, track, ingest, vote, sync, render), cache and CLI."""
