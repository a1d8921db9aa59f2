"""Crowds with a user's inputs through `tlsync run`: a GPX log and GCPs, the defaults against the inputs declared.

    python bench/crowd_inputs.py [--seeds 0 1 2] [--distractors 8] [--fps 10 5] [--seconds 45]
                                 [--log-rate 1] [--gps-noise 0.3] [--gcps 6] [--gcp-noise-px 1] [--jobs 1]
                                 [--views apart|shared] [--limits] [--against TREE]

Each seed's crowd scene (data_fixtures/crowd.py: two surveillance cameras,
look-alike walkers, every mover detected; ``--views shared``: the cameras
watch one patch at the same time, as a multi-view surveillance set does,
e.g. ``--fps 25 25 --seconds 21.2``) is written as a user brings it
(data_fixtures.crowd.UserInputs): the log a GPX file (``--log-rate`` Hz, white
noise of ``--gps-noise`` metres per axis) whose error model is not declared,
each camera's intrinsics and ``--gcps`` ground points whose pixels are
clicked with ``--gcp-noise-px`` of noise, ``gcp_sigma_m`` left at its
default. It runs `tlsync run` with these defaults, then again (the work
folder kept: only what the declaration changes re-runs) with the inputs
declared as they are: ``log_model = "white"``, ``white_sigma_m`` the noise,
``gcp_sigma_m = 0``. Prints per run: the worst pair's eps_t (frames of the
pair's first camera; inf when a camera is not synchronized), per camera the
share of its identified frames on the target's silhouette (and on the
walker's blob, a blob merged with passers-by counting, and the share of
the frames where a mover is the walker's blob that are identified on it),
its status, its
clock error over the 95 % interval's half-width at the middle of its visit
(a camera ``ok`` or ``weak`` beyond 3 is a confident wrong answer), and the
distance (m) and angle (degrees) between its pose and the true one. Beside
each seed's worst pair: the first-order bound (bench/gps_bound.py: the
median worst pair an efficient estimator that knows the log's error model
and the poses reaches on the scene's visible frames, with the blob
centroid's noise data_fixtures.crowd.CENTROID_NOISE_PX) and the ratio to it;
then the bound when the poses are not known but estimated with the lines,
each held by the scene's GCPs (their clicked pixels' noise) and by the
target's pixels (gps_bound.Survey): what the GCPs allow.

``--against TREE``: each seed's runs again with the code of another source
tree (a folder holding tlsync_pipeline/, e.g. ``git archive`` of a commit),
on copies of this tree's work folders: the same rendered videos and the
stages whose code is the same kept (scan and track, when only sync code
differs), so the two trees are compared on the same inputs (the movers
rendered differ a little from run to run). Printed as ``defaults
(against)`` and ``declared (against)``.

``--limits``: where each run's error comes from. Its sync is redone
(sync/solve/synchronize.py, under the run's log model) on its own poses and
identified tracks, and with each replaced by the truth: the true poses
with the identified tracks; the true target track (its visible frames,
with the blob centroid's white noise) with the run's poses as they are
(their stds and timing) and taken as exact; the true poses with the
identified frames but the true target's points there (plus that noise);
both true; the true poses with the true target's points only at one class
of identified frames: those whose blob is larger than the target (merged
with passers-by: identification placed the point within it), those whose
blob is the target's size, those whose point is off the walker's
silhouette. Prints each variant's worst pair.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from gps_bound import Survey, worst_pair_draws  # noqa: E402

from calibration.camera import PoseInfo, read_camera  # noqa: E402
from data_fixtures.crowd import (  # noqa: E402
    CENTROID_NOISE_PX,
    CrowdSpec,
    UserInputs,
    ground_gcps,
    write_crowd_project,
)
from tlsync_pipeline.ingest.report import read_ingest_report  # noqa: E402
from tlsync_pipeline.pipeline.stages.sync import read_pose_timing  # noqa: E402
from tlsync_pipeline.sync.model.log_model import LogModelChoice  # noqa: E402
from tlsync_pipeline.sync.model.params import SyncParams  # noqa: E402
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize  # noqa: E402
from tlsync_pipeline.sync.timeline import Timeline, eps_t, read_timeline  # noqa: E402
from tlsync_pipeline.sync.vote.visits import near_views  # noqa: E402
from tlsync_pipeline.trajectory import read_trajectory  # noqa: E402
from trackers.detections import read_detections  # noqa: E402
from trackers.track import Track, read_track  # noqa: E402

Z95 = 1.959964
BOUND_DRAWS = 200
EXACT = PoseInfo("gcp")  # a pose taken as exact (no stds): the fit of the log's white error is not gated by it
ROOT = Path(__file__).resolve().parents[1]


def tlsync_run(project: Path, root: Path = ROOT) -> int:
    """`tlsync run project --quiet` in a process of its own (the code of the source tree ``root``: this one by
    default); its exit code."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    command = [sys.executable, "-m", "tlsync_pipeline.cli", "run", str(project), "--quiet"]
    return subprocess.run(command, env=env, capture_output=True, text=True).returncode


def declare(project: Path, white_m: float) -> None:
    """Declare the inputs as they are in the project file: a white log of ``white_m`` and exact GCPs."""
    text = project.read_text()
    head, rest = text.split("\n", 1)
    assert head == "[target]", "the project starts with its target table"
    project.write_text(
        f'[target]\nlog_model = "white"\nwhite_sigma_m = {white_m}\n{rest}\n[calibration]\ngcp_sigma_m = 0\n'
    )


def worst_pair(timeline: Timeline, scene) -> float:
    """The timeline's worst pair's eps_t (frames of the pair's first camera; inf when a camera is missing)."""
    return max(
        eps_t(timeline.relation(*key.split("->")), truth, scene.n_frames[key.split("->")[0]])
        if set(key.split("->")) <= set(timeline.cameras)
        else math.inf
        for key, truth in scene.truth_pairs().items()
    )


def measure(directory: Path, crowd, code: int) -> dict:
    """The run's worst pair, and per camera: on-target share, status, clock error / interval, pose error."""
    scene = crowd.scene
    work = directory / "work"
    timeline = read_timeline(work / "timeline.json")
    statuses = json.loads((work / "timeline.json").read_text()).get("status", {})
    cameras = {}
    for name, truth in crowd.truth.items():
        row: dict = {"status": statuses.get(name, {}).get("status", "?")}
        track_path = work / "cameras" / name / "track.csv"
        if track_path.exists():
            track = read_track(track_path)
            row["on_target"] = float(truth.on_target(track.frame, track.xy).mean()) if len(track) else 0.0
            row["frames"] = len(track)
            row["on_blob"], row["found"] = walker_blobs(
                truth, read_detections(track_path.with_name("detections.csv")), track
            )
        line = timeline.cameras.get(name) or timeline.rejected.get(name)
        if line is not None:
            true_line = scene.lines[name]
            middle = (float(np.median(scene.tracks[name].frame)) - true_line.beta) / true_line.alpha
            error = abs((line.alpha - true_line.alpha) * middle + line.beta - true_line.beta)
            g = np.array([middle, 1.0])
            half = Z95 * math.sqrt(max(g @ line.cov @ g, 0.0)) if line.cov is not None else math.inf
            row["error_frames"], row["z"] = error, error / half if half > 0 else math.inf
        camera_path = work / "cameras" / name / "camera.json"
        if camera_path.exists():
            posed, true_camera = read_camera(camera_path), scene.cameras[name]
            if posed.R is not None:
                centre = -posed.R.T @ posed.t
                true_centre = -true_camera.R.T @ true_camera.t
                turn = posed.R @ true_camera.R.T
                row["pose_m"] = float(np.linalg.norm(centre - true_centre))
                row["pose_deg"] = math.degrees(math.acos(np.clip((np.trace(turn) - 1) / 2, -1.0, 1.0)))
        cameras[name] = row
    return {"code": code, "worst": worst_pair(timeline, scene), "cameras": cameras}


def limits(directory: Path, crowd, seed: int, choice: LogModelChoice) -> dict[str, float]:
    """The worst pair of the run's sync redone with its poses and identified tracks, and with each replaced by the
    truth (see the module), under the run's log model ``choice``: {variant: worst pair (frames)}."""
    scene, work = crowd.scene, directory / "work"
    own = {}
    for name in scene.cameras:
        files = work / "cameras" / name
        camera = read_camera(files / "camera.json", name=name)
        timing = read_pose_timing(files / "calibration_report.json")
        own[name] = CameraInput(camera, read_track(files / "track.csv"), camera.fps, pose_timing=timing)
    trajectory = near_views(read_trajectory(work / "target" / "trajectory.csv"), [c.camera for c in own.values()])
    suggested = (read_ingest_report(work / "target" / "ingest_report.json").log_model or {}).get("name")
    model = choice.resolve(suggested)
    rng = np.random.default_rng([seed, 3])

    def true_pose(name: str, inputs: CameraInput) -> CameraInput:
        camera = replace(scene.cameras[name], name=name, pose_info=EXACT)
        return replace(inputs, camera=camera, pose_timing=None)

    def noisy(frame: np.ndarray, xy: np.ndarray) -> Track:
        seen = np.isfinite(xy).all(axis=1)
        noise = rng.normal(0.0, CENTROID_NOISE_PX, xy.shape)
        return Track(frame[seen], *(xy[seen] + noise[seen]).T)

    true_track = {n: noisy(scene.tracks[n].frame, scene.tracks[n].xy) for n in own}
    at_identified = {n: noisy(i.track.frame, crowd.truth[n].xy[i.track.frame]) for n, i in own.items()}
    movers = {n: read_detections(work / "cameras" / n / "detections.csv") for n in own}
    merged = {n: merged_blobs(movers[n], i.track) for n, i in own.items()}
    on_walker = {n: crowd.truth[n].on_target(i.track.frame, i.track.xy) for n, i in own.items()}

    def true_points_where(name: str, inputs: CameraInput, where: np.ndarray) -> CameraInput:
        """True poses; the identified track with the true target's points (at_identified) at the frames ``where``."""
        track, truth = inputs.track, at_identified[name]
        assert track is not None
        seen = np.isin(track.frame, truth.frame)
        xy = track.xy.copy()
        swap = where & seen
        xy[swap] = truth.xy[np.searchsorted(truth.frame, track.frame[swap])]
        keep = seen | ~where
        moved = Track(track.frame[keep], *xy[keep].T, w=track.w[keep], h=track.h[keep])
        return replace(true_pose(name, inputs), track=moved)

    variants = {
        "own": own,
        "true poses": {n: true_pose(n, i) for n, i in own.items()},
        "true track": {n: replace(i, track=true_track[n]) for n, i in own.items()},
        "true track, poses exact": {
            n: replace(i, camera=replace(i.camera, pose_info=EXACT), track=true_track[n], pose_timing=None)
            for n, i in own.items()
        },
        "true poses, true points at identified frames": {
            n: replace(true_pose(n, i), track=at_identified[n]) for n, i in own.items()
        },
        "both true": {n: replace(true_pose(n, i), track=true_track[n]) for n, i in own.items()},
        "true poses, true points at merged-blob frames": {
            n: true_points_where(n, i, merged[n]) for n, i in own.items()
        },
        "true poses, true points at own-blob frames": {n: true_points_where(n, i, ~merged[n]) for n, i in own.items()},
        "true poses, true points at frames off the walker": {
            n: true_points_where(n, i, ~on_walker[n]) for n, i in own.items()
        },
    }
    return {
        label: worst_pair(synchronize(inputs, trajectory, SyncParams(), log_model=model)[0], scene)
        for label, inputs in variants.items()
    }


def merged_blobs(movers, track: Track) -> np.ndarray:
    """Per identified frame, whether its mover is a blob larger than the target (identification step 6 placed the
    point within it, its box shrunk to the target's): the mover of that frame with the track's score whose centre is
    nearest the point has a larger box than the track's."""
    out = np.zeros(len(track), dtype=bool)
    assert track.w is not None and track.h is not None and track.score is not None
    for k, (frame, score) in enumerate(zip(track.frame, track.score)):
        rows = np.flatnonzero((movers.frame == frame) & (np.abs(movers.score - score) < 1e-3))
        if len(rows):
            row = rows[np.argmin(np.hypot(movers.x[rows] - track.x[k], movers.y[rows] - track.y[k]))]
            out[k] = movers.w[row] > track.w[k] + 0.5 or movers.h[row] > track.h[k] + 0.5
    return out


def walker_blobs(truth, movers, track) -> tuple[float, float]:
    """The share of the identified frames whose mover is the walker's blob (its centre on the walker's silhouette or
    its box holding the walker's centre: a blob merged with passers-by counts), and the share of the frames where a
    mover is the walker's blob whose identified mover is. The identified mover of a frame: the mover whose box holds
    the track's point, the nearest centre when several or none do (the point may be moved by the logged point's
    height)."""
    centre = truth.xy[movers.frame]
    with np.errstate(invalid="ignore"):
        holds = (np.abs(movers.x - centre[:, 0]) <= movers.w / 2) & (np.abs(movers.y - centre[:, 1]) <= movers.h / 2)
    walker = truth.on_target(movers.frame, movers.xy) | (holds & np.isfinite(centre[:, 0]))
    right = 0
    for frame, x, y in zip(track.frame, track.x, track.y):
        rows = np.flatnonzero(movers.frame == frame)
        if not len(rows):
            continue
        inside = (np.abs(movers.x[rows] - x) <= movers.w[rows] / 2) & (np.abs(movers.y[rows] - y) <= movers.h[rows] / 2)
        pool = rows[inside] if inside.any() else rows
        right += bool(walker[pool[np.argmin(np.hypot(movers.x[pool] - x, movers.y[pool] - y))]])
    seen = len(np.unique(movers.frame[walker]))
    return right / max(len(track), 1), right / max(seen, 1)


def one_seed(seed: int, args: argparse.Namespace) -> dict:
    """Both runs of one seed's scene and its first-order bound: {"defaults": measure(...), "declared": measure(...),
    "bound": the median worst pair of the bound's draws (frames)}."""
    spec = CrowdSpec(
        seed=seed,
        distractors=args.distractors,
        fps=tuple(args.fps),
        n_frames=tuple(int(round(args.seconds * f)) for f in args.fps),
        log_rate=args.log_rate,
        gps_noise_m=args.gps_noise,
        views=args.views,
    )
    inputs = UserInputs(gpx=True, gcps=args.gcps, gcp_noise_px=args.gcp_noise_px)
    with tempfile.TemporaryDirectory() as tmp:
        first = Path(tmp) / "defaults"
        project, crowd = write_crowd_project(first, spec, inputs)
        rate_sigma = SyncParams().rate_sigma
        draws = worst_pair_draws(crowd.scene, rate_sigma, BOUND_DRAWS, np.random.default_rng(seed))
        out = {"bound": float(np.median(draws)), "bound_gcp": float(np.median(draws))}
        if inputs.gcps and inputs.gcp_noise_px > 0:
            survey = {
                n: Survey(xyz, inputs.gcp_noise_px) for n, (xyz, _) in ground_gcps(crowd.scene, seed, inputs).items()
            }
            posed = worst_pair_draws(crowd.scene, rate_sigma, BOUND_DRAWS, np.random.default_rng(seed), gcps=survey)
            out["bound_gcp"] = float(np.median(posed))
        out["defaults"] = measure(first, crowd, tlsync_run(project))
        second = Path(tmp) / "declared"
        shutil.copytree(first, second)
        declare(second / "project.toml", args.gps_noise)
        out["declared"] = measure(second, crowd, tlsync_run(second / "project.toml"))
        if args.against is not None:
            for kind, folder in (("defaults", first), ("declared", second)):
                other = Path(tmp) / f"{kind} against"
                shutil.copytree(folder, other)
                out[f"{kind} (against)"] = measure(other, crowd, tlsync_run(other / "project.toml", args.against))
        if args.limits:
            out["defaults"]["limits"] = limits(first, crowd, seed, LogModelChoice())
            out["declared"]["limits"] = limits(second, crowd, seed, LogModelChoice("white", white_m=args.gps_noise))
    return out


def describe(run: dict, bound: float) -> str:
    parts = [f"worst {run['worst']:.3f} = {run['worst'] / bound:.2f}x the bound (exit {run['code']})"]
    for name, c in run["cameras"].items():
        pose = f" pose {c['pose_m']:.2f} m {c['pose_deg']:.1f} deg" if "pose_m" in c else ""
        z = f" |err| {c['error_frames']:.2f} fr = {c['z']:.1f}x" if "z" in c else ""
        on = (
            f" on {c['on_target']:.0%} of {c['frames']} (walker's blob {c['on_blob']:.0%}, "
            f"of its frames {c['found']:.0%})"
            if "on_target" in c
            else ""
        )
        parts.append(f"{name}: {c['status']}{on}{z}{pose}")
    return "; ".join(parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--distractors", type=int, default=8)
    parser.add_argument("--fps", type=float, nargs="+", default=[10.0, 5.0])
    parser.add_argument("--seconds", type=float, default=45.0, help="each video's length")
    parser.add_argument("--log-rate", type=float, default=1.0, metavar="HZ")
    parser.add_argument("--gps-noise", type=float, default=0.3, metavar="M", help="white noise per axis, metres")
    parser.add_argument("--gcps", type=int, default=6, help="ground points per camera")
    parser.add_argument("--gcp-noise-px", type=float, default=1.0)
    parser.add_argument("--views", choices=("apart", "shared"), default="apart")
    parser.add_argument("--limits", action="store_true", help="each run's sync redone on true poses and tracks")
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument(
        "--against", type=Path, metavar="TREE", help="also run each seed with this source tree's code (same inputs)"
    )
    args = parser.parse_args()
    kinds = ("defaults", "declared") + (() if args.against is None else ("defaults (against)", "declared (against)"))
    with ProcessPoolExecutor(args.jobs) as pool:
        results = list(pool.map(one_seed, args.seeds, [args] * len(args.seeds)))
    worst = {k: np.array([r[k]["worst"] for r in results]) for k in kinds}
    on = {k: [min(c.get("on_target", 0.0) for c in r[k]["cameras"].values()) for r in results] for k in worst}
    blob = {k: [min(c.get("on_blob", 0.0) for c in r[k]["cameras"].values()) for r in results] for k in worst}
    found = {k: [min(c.get("found", 0.0) for c in r[k]["cameras"].values()) for r in results] for k in worst}
    wrong = {
        k: sum(
            c["status"] in ("ok", "weak") and c.get("z", 0.0) > 3.0 for r in results for c in r[k]["cameras"].values()
        )
        for k in worst
    }
    bound = np.array([r["bound"] for r in results])
    bound_gcp = np.array([r["bound_gcp"] for r in results])
    for seed, r in zip(args.seeds, results):
        print(f"seed {seed}    bound: {r['bound']:.3f}, poses from the GCPs: {r['bound_gcp']:.3f}")
        for k in kinds:
            print(f"seed {seed} {k:>8}: {describe(r[k], r['bound'])}")
            if "limits" in r[k]:
                print(f"seed {seed} {k:>8} limits: " + "; ".join(f"{v} {w:.3f}" for v, w in r[k]["limits"].items()))
    print(f"first-order bound: median {np.median(bound):.3f}, {np.mean(bound <= 0.2):.0%} of the seeds <= 0.2")
    print(
        f"with the poses from the GCPs: median {np.median(bound_gcp):.3f}, {np.mean(bound_gcp <= 0.2):.0%} of the "
        f"seeds <= 0.2"
    )
    for k in ("defaults", "declared") if args.limits else ():
        labels = list(results[0][k]["limits"])
        print(
            f"limits, {k}, median worst pair: "
            + "; ".join(f"{v} {np.median([r[k]['limits'][v] for r in results]):.3f}" for v in labels)
        )
    print(
        f"{'inputs':>8} {'<=0.2':>6} {'median':>7} {'max':>7} {'/ bound (median)':>16} "
        f"{'on target (worse camera, median)':>33} {'walker blob':>11} {'found':>6} {'wrong':>5}"
    )
    for k in kinds:
        print(
            f"{k:>8} {np.mean(worst[k] <= 0.2):>6.0%} {np.median(worst[k]):>7.3f} {np.max(worst[k]):>7.3f} "
            f"{np.median(worst[k] / bound):>16.2f} {np.median(on[k]):>33.1%} {np.median(blob[k]):>11.1%} "
            f"{np.median(found[k]):>6.1%} {wrong[k]:>5}"
        )


if __name__ == "__main__":
    main()
