"""tlsync's pipeline: project file, stages (calibrate, ingest, scan, track, vote, sync, render), cache and CLI."""
