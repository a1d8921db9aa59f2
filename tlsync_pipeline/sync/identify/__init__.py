"""The target among every mover: identification, its refinement, recording breaks, the scan's coarse pass."""
