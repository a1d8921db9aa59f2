"""Synchronization: votes, the robust line kernel (paper RANSAC, line search), refinement,
camera clocks, the timeline and the registry of sync methods. Pure functions, no file I/O
except each type's own reader and writer."""
