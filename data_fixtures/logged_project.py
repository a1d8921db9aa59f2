"""A project folder of given cameras, tracks and trajectory, as a user would write one for ``tlsync run``.

Each camera brings its camera.json (without a pose when the camera is not
posed: the calibrate stage then poses it from the target) and its track.csv;
the target brings its trajectory.csv, with the log's error model declared in
``[target] log_model``. Used to run a flight held in memory (a real one with a
simulated receiver's error, say) through the pipeline's stages.
"""

from __future__ import annotations

from pathlib import Path

from calibration.camera import write_camera
from tlsync_pipeline.sync.solve.methods import CameraInput
from tlsync_pipeline.trajectory import Trajectory, write_trajectory
from trackers.track import write_track


def write_logged_project(folder: Path, cameras: dict[str, CameraInput], trajectory: Trajectory, log_model: str) -> Path:
    """Write ``folder/project.toml`` with every camera's camera.json and track.csv and the target's trajectory.csv
    (``log_model``: a preset name of [target] log_model); returns the project file."""
    folder.mkdir(parents=True, exist_ok=True)
    write_trajectory(trajectory, folder / "trajectory.csv")
    lines = ["[target]", 'trajectory = "trajectory.csv"', f'log_model = "{log_model}"', ""]
    for name, given in cameras.items():
        assert given.track is not None, "a logged project's cameras bring their tracks"
        write_camera(given.camera, folder / f"{name}_camera.json")
        write_track(given.track, folder / f"{name}_track.csv")
        lines += ["[[cameras]]", f'name = "{name}"', f'camera = "{name}_camera.json"', f'track = "{name}_track.csv"']
        lines += [f"fps = {given.fps!r}"] if given.fps is not None else []
        lines.append("")
    project = folder / "project.toml"
    project.write_text("\n".join(lines), encoding="utf-8")
    return project
