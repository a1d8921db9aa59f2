"""Votes (t_c, t_r) of a track against the prepared trajectory, and where the trajectory passes a camera's view."""
