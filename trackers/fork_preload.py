"""Imported by a run's fork server before it forks any worker (tlsync_pipeline/pipeline/graph.py, worker_modules):
the blob detector's compiled passes are loaded there once (``load_compiled_passes``), and every worker forked from
it starts with them."""

from trackers.blob import load_compiled_passes

load_compiled_passes()
