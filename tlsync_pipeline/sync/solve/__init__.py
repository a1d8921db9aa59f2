"""The sync stage's fit: the methods and their registry, the log's bias, plausibility checks, causes, the timeline."""
