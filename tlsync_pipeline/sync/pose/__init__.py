"""A camera's pose from the target's track and the log (the calibrate stage)."""
