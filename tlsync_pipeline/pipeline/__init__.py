"""The engine: project file, work folder layout, stage graph, cache, executors, lock, and one
module per stage under ``stages``."""
