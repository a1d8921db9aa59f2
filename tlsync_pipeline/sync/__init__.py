"""Synchronization, in packages along the data flow (docs/architecture.md, "The sync packages"):

kernels/ (robust line fits, slope prior, smoothing) <- model/ (shared types and the configuration's leaves:
parameters, declared methods, camera clock, status, log error model) <- vote/, identify/, pose/ (what the
vote, scan, identify and calibrate stages run) <- solve/ (the sync stage's fit) -> timeline.py (its output,
read by export and render). Pure functions, no file I/O except each type's own reader and writer.
"""
