"""The real drone flight (../shared/real/drone2) logged by a consumer receiver: its RTK log plus a simulated error.

The flight's cameras, tracks and truth are real; its RTK trajectory gets, per
seed, the errors of a receiver of data_fixtures/log_error.py (a Gauss-Markov
bias plus white noise, at the log's own samples), and the sync is told the
receiver's kind as a user would ([target] log_model; both phones `phone`).
With ``--poses removed`` every camera's pose comes from the target, except those of the cameras
``--surveyed`` names.
``--through stages`` runs each simulated log as a user would: a project folder
of the cameras (without their poses when removed), tracks and the erroneous
log with its model declared (data_fixtures/logged_project.py), through
``tlsync run -j JOBS`` in a child process (calibrate poses the cameras, then
vote, sync and render); its CPU is the run's and its workers', its peak memory
that of its process tree (the run, the fork server and the workers: the sum of
their proportional set sizes, and of their RSS in brackets, sampled every 50
ms, bench/_memory.py TreePeak).
``--through synchronize`` (default) calls synchronize() on the same inputs in
this process, with one BLAS thread as the pipeline runs the sync stage
(sync/kernels/blas.py: OpenBLAS's threads spin on the fits'
small matrices, a pose's 4000 x 8 Jacobian's SVD 48 ms of CPU on two busy
cores against 0.3 ms on one thread). ``--slow K`` flies the same path K times slower and ``--hover
S`` holds the drone still S seconds every HOVER_EVERY_S seconds of the flight,
``--max-speed V`` stretches only the parts flown faster than V m/s to that
speed (a flight that hovers and creeps, its hovers as they were;
data_fixtures/slowed_flight.py), and ``--only-slower V`` cuts each track to
where the drone flies slower than V m/s: the slow flights a metre of bias
turns into seconds. ``--crop SHARE`` cuts each camera's video to that share of
its visit (the first camera keeps the visit's start, the last its end, the
others between), ``--cameras`` keeps a subset, and ``--count N`` repeats the
cameras under new names to make N (the same views again: a flight with more
cameras, for memory and CPU). ``--bound`` prints instead the first-order bound
(bench/gps_bound.py) on the median and the worst pair's eps_t for each
receiver's exact error model, its poses known or (``--poses removed``)
estimated with the lines, the tracks' pixels white with BOUND_PX (every
BOUND_THIN-th frame kept, its noise scaled to keep their information). Per
receiver and bias model (``--bias-model``): the runs where every camera was
synchronized, the median and max over runs of the worst and of the median
synchronized pair's eps_t (frames, eq. 5), the share of synchronized pairs
whose 95 % interval of beta contains the truth, the pairs further than a frame
and than three times that interval from it, the cameras answered (ok or weak)
whose line is wrong (further than max(1 frame, 3 x its 95 % interval) from the
truth at the middle of its visit, bench/_report.py), the refused cameras whose
rejected line was right by the same measure, the refused cameras with their
cause, the sync's CPU a run (through the stages: the whole ``tlsync run``'s,
calibrate's pose search included), the peak resident memory of the runs
through the stages (their process trees'), and this process's peak resident
memory. ``--runs`` prints every run (each camera's status, the refusals' reason codes, and the median distance of
each camera's track from the log projected as the render stage draws it at its line: the line's pose on the log
timeline.json's ``log_correction`` corrects, render's ``drawn_as_fitted``), ``--json PATH`` appends
each run to PATH as a JSON line. ``--first-seed N`` runs the seeds N, N+1, ...; ``--white M`` gives the receiver
M metres of white noise on every axis instead of its preset's (issue 33's drone: 0.3 m). Skips cleanly when the
folder is absent.

    nice python bench/real_flight_gps.py [--data /work/shared/real/drone2] [--seeds 8] [--first-seed 0]
        [--models drone phone2] [--white M] [--bias-model on off] [--poses given|removed] [--surveyed cam0 cam2]
        [--through synchronize|stages] [--slow 1] [--hover 0] [--max-speed V] [--only-slower V] [--crop SHARE]
        [--cameras cam0 cam2] [--count N] [--jobs N] [--runs] [--json PATH]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _memory import TreePeak, peak_rss_mb
from _report import BEYOND, Z95, camera_error, is_right, pair_errors
from gps_bound import pair_draws

from data_fixtures.log_error import PRESETS as RECEIVERS
from data_fixtures.log_error import log_errors
from data_fixtures.logged_project import write_logged_project
from data_fixtures.scene import Scene
from data_fixtures.slowed_flight import (
    SlowedFlight,
    cropped,
    slow_part,
    slowed_flight,
    speed_cap_warp,
    time_warp,
)
from tlsync_pipeline.outputs.plots import track_residuals
from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.render import drawn_as_fitted
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.kernels.blas import one_blas_thread
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.model.status import AMBIGUOUS, FAILED
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import Relation, Timeline, read_timeline, read_truth
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.track import Track

DEFAULT = Path("/work/shared/real/drone2")
HOVER_EVERY_S = 40.0  # seconds of the original flight between two hovers (--hover)
BOUND_PX = 2.0  # the bound's tracking noise (pixels, per axis)
BOUND_THIN = 6  # the bound keeps every this many tracked frames, their noise over its square root
BOUND_DRAWS = 400


@dataclasses.dataclass(frozen=True)
class Variant:
    """How the flight is changed: slowed ``slow`` times with hovers of ``hover_s`` s every HOVER_EVERY_S s, or its
    parts faster than ``max_speed`` m/s stretched to it; each track cut to where the target is slower than
    ``only_slower`` m/s and each video to ``crop`` of its visit; the ``cameras`` kept (None: all); the poses removed
    when ``poses`` is "removed", except those of the cameras ``surveyed``; the cameras repeated under new names to
    make ``count`` (None: as they are)."""

    slow: float = 1.0
    hover_s: float = 0.0
    max_speed: float | None = None
    only_slower: float | None = None
    crop: float | None = None
    cameras: tuple[str, ...] | None = None
    poses: str = "given"
    count: int | None = None
    surveyed: tuple[str, ...] = ()

    def describe(self) -> str:
        """One line for the bench's header."""
        parts = [
            f"poses {self.poses}" + (f" (kept: {' '.join(self.surveyed)})" if self.surveyed else ""),
            f"{self.slow:g} times slower",
            f"hovers of {self.hover_s:g} s every {HOVER_EVERY_S:g} s",
        ]
        if self.max_speed is not None:
            parts.append(f"faster than {self.max_speed:g} m/s stretched to it")
        if self.only_slower is not None:
            parts.append(f"tracks cut to the drone slower than {self.only_slower:g} m/s")
        if self.crop is not None:
            parts.append(f"videos cut to {100 * self.crop:.0f} % of their visit")
        if self.cameras is not None:
            parts.append("cameras " + " ".join(self.cameras))
        if self.count is not None:
            parts.append(f"the cameras repeated to make {self.count}")
        return ", ".join(parts)


def flight(data: Path, variant: Variant) -> tuple[SlowedFlight, object]:
    """The flight changed as ``variant`` says, and its sync parameters."""
    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    _, n_frames = read_truth(data / "truth.json")
    lines = {
        name: Relation(float(line["alpha"]), float(line["beta"]))
        for name, line in json.loads((data / "truth.json").read_text())["cameras_to_target"].items()
    }
    if variant.cameras is not None:
        cameras = {name: cameras[name] for name in variant.cameras}
        lines = {name: lines[name] for name in variant.cameras}
    assert trajectory.rate is not None
    if variant.max_speed is not None:
        warp = speed_cap_warp(trajectory.sample / trajectory.rate, trajectory.xyz, variant.max_speed)
    else:
        duration = float(trajectory.sample[-1]) / trajectory.rate
        warp = time_warp(duration, variant.slow, variant.hover_s, HOVER_EVERY_S)
    slowed = slowed_flight(cameras, trajectory, lines, n_frames, warp)
    if variant.only_slower is not None:
        slowed = slow_part(slowed, variant.only_slower)
    if variant.crop is not None:
        slowed = cropped(slowed, variant.crop)
    if variant.poses == "removed":
        cams = {
            n: c if n in variant.surveyed else dataclasses.replace(c, camera=c.camera.without_pose())
            for n, c in slowed.cameras.items()
        }
        slowed = dataclasses.replace(slowed, cameras=cams)
    if variant.count is not None:
        slowed = repeated(slowed, variant.count)
    return slowed, project.sync


def repeated(slowed: SlowedFlight, count: int) -> SlowedFlight:
    """The flight's cameras in turn, the first ones again under new names ("cam0_1", ...) until there are ``count``:
    the same views again, the k-th copy's video starting k frames earlier (its track's frames and its true line's
    beta k more: a project takes no two identical tracks), as new cameras make the sync's and the render's work
    grow."""
    names = list(slowed.cameras)
    cameras, lines, n_frames = {}, {}, {}
    for k in range(count):
        name, copy = names[k % len(names)], k // len(names)
        new = f"{name}_{copy}" if copy else name
        given, line = slowed.cameras[name], slowed.lines[name]
        track = given.track
        assert track is not None and track.time_s is None, "a copy shifts the track's frames only"
        cameras[new] = dataclasses.replace(
            given,
            camera=dataclasses.replace(given.camera, name=new),
            track=dataclasses.replace(track, frame=track.frame + copy),
        )
        lines[new] = Relation(line.alpha, line.beta + copy)
        n_frames[new] = slowed.n_frames[name] + copy
    return dataclasses.replace(slowed, cameras=cameras, lines=lines, n_frames=n_frames)


def run_one(
    slowed: SlowedFlight,
    sync_params,
    receiver: str,
    seed: int,
    bias_model: bool,
    through: str,
    jobs: int = 1,
    white_m: float | None = None,
) -> dict:
    """One simulated log of ``receiver`` (its white noise ``white_m`` metres on every axis when given): the sync's
    figures against the truth (``through``: "synchronize" in this process, "stages" through ``tlsync run -j
    JOBS``)."""
    trajectory = slowed.trajectory
    model = RECEIVERS[receiver]
    if white_m is not None:
        model = dataclasses.replace(model, white_h_m=white_m, white_v_m=white_m)
    errors, _ = log_errors(np.random.default_rng(seed), trajectory.sample / trajectory.rate, model)
    logged = dataclasses.replace(trajectory, xyz=trajectory.xyz + errors)
    declared = "phone" if receiver.startswith("phone") else receiver
    params = dataclasses.replace(sync_params, log_bias=bias_model)
    if through == "stages":
        if not bias_model:
            raise SystemExit("--through stages runs the project's [sync] as it is: --bias-model on only")
        timeline, seconds, (peak_mb, rss_mb) = through_stages(slowed, logged, declared, jobs)
    else:
        with one_blas_thread():  # as the pipeline runs the sync stage
            started = time.process_time()
            timeline, _ = synchronize(slowed.cameras, logged, params, log_model=LOG_MODELS[declared])
            seconds, peak_mb, rss_mb = time.process_time() - started, np.nan, np.nan
    pairs = pair_errors(timeline, slowed.pairs(), slowed.n_frames)
    eps = [e for e, _ in pairs]
    statuses = timeline.statuses(list(slowed.cameras))
    return {
        "seed": seed,
        "synchronized": len(timeline.cameras),
        "cameras": len(slowed.cameras),
        "worst": max(eps, default=np.nan),
        "median": float(np.median(eps)) if eps else np.nan,
        "z": [score for _, score in pairs],
        "beyond": sum(e > 1.0 and z > BEYOND * Z95 for e, z in pairs),
        "wrong": [name for name in timeline.cameras if not _right(timeline, slowed, name)],
        "statuses": {name: status.status for name, status in statuses.items()},
        "codes": {
            name: sorted({r.code for r in status.reasons if r.severity in (AMBIGUOUS, FAILED)})
            for name, status in statuses.items()
            if not status.synchronized
        },
        "refused_right": [name for name in timeline.rejected if _right(timeline, slowed, name)],
        "refused": {
            name: why.split(": ", 1)[-1] + _line_off(timeline, slowed, name) for name, why in timeline.failed.items()
        },
        "cpu_s": seconds,
        "peak_mb": peak_mb,
        "rss_mb": rss_mb,
        "drawn_px": drawn_px(timeline, slowed, logged, params),
    }


def drawn_px(timeline: Timeline, slowed: SlowedFlight, logged: Trajectory, params) -> dict[str, float]:
    """Per synchronized camera, the median distance (pixels) of its track from the log projected as the render stage
    draws it at its line (``drawn_as_fitted``: the line's pose, on the log timeline.json's log_correction corrects);
    NaN for a camera drawn with a pose the bench does not hold (through the stages: the calibrate stage's)."""
    inputs, log = drawn_as_fitted(timeline, {n: slowed.cameras[n] for n in timeline.cameras}, logged)
    path = PiecewiseTrajectory(prepare_trajectory(log, preparation_of(params)))
    out = {}
    for name, given in inputs.items():
        track = given.track
        assert track is not None
        found = track_residuals(given.camera, track, path, timeline.cameras[name]) if given.camera.posed else None
        out[name] = float(np.median(found.distance)) if found is not None and len(found.sample) else np.nan
    return out


def through_stages(
    slowed: SlowedFlight, logged, declared: str, jobs: int
) -> tuple[Timeline, float, tuple[float, float]]:
    """The timeline ``tlsync run -j JOBS`` makes of the flight's project (written to a temporary folder), the CPU of
    the run and its workers (s) and the peak memory of its process tree (MB: Pss, RSS; bench/_memory.py TreePeak)."""
    with tempfile.TemporaryDirectory() as folder:
        project = write_logged_project(Path(folder), slowed.cameras, logged, declared)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        run = subprocess.Popen(
            [sys.executable, "-m", "tlsync_pipeline.cli", "run", str(project), "-j", str(jobs), "-q"],
            env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        with TreePeak(run.pid) as peak:
            _, stderr = run.communicate()
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if run.returncode not in (0, 1):
            raise RuntimeError(f"tlsync run exited {run.returncode}: {stderr[-2000:]}")
        timeline = read_timeline(Path(folder) / "work" / "timeline.json")
    seconds = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return timeline, seconds, (peak.mb, peak.rss_mb)


def _right(timeline: Timeline, slowed: SlowedFlight, name: str) -> bool:
    """Whether the camera's synchronized or rejected line is right: within max(1 frame, 3 x its 95 % interval) of the
    truth at the middle of its visit (bench/_report.py)."""
    line = timeline.cameras.get(name) or timeline.rejected[name]
    track = slowed.cameras[name].track
    assert track is not None
    return is_right(*camera_error(line, slowed.lines[name], track.frame))


def _line_off(timeline: Timeline, slowed: SlowedFlight, name: str) -> str:
    """How far the refused camera's line lies from the truth (" [line +X s]", the log's seconds at its middle tracked
    frame), or "" when no line was fitted (a pose refused first)."""
    line, truth, track = timeline.rejected.get(name), slowed.lines[name], slowed.cameras[name].track
    if line is None or track is None or not len(track) or slowed.trajectory.rate is None:
        return ""
    frame = float(np.median(track.frame))
    off = (frame - line.beta) / line.alpha - (frame - truth.beta) / truth.alpha
    return f" [line {off / slowed.trajectory.rate:+.1f} s]"


def _cause(why: str) -> str:
    """A refusal's reason, short."""
    return why if len(why) <= 110 else why[:107] + "..."


def summary(receiver: str, bias_model: bool, runs: list[dict]) -> str:
    """One table row over the runs."""
    z = np.array([s for r in runs for s in r["z"]])
    every = sum(r["synchronized"] == r["cameras"] for r in runs)
    worst, median = np.array([r["worst"] for r in runs]), np.array([r["median"] for r in runs])
    refused = "; ".join(f"seed {r['seed']} {n}: {_cause(why)}" for r in runs for n, why in r["refused"].items()) or "-"
    wrong = "; ".join(f"seed {r['seed']} {n} {r['statuses'][n]}" for r in runs for n in r["wrong"]) or "0"
    right_refused = sum(len(r["refused_right"]) for r in runs)
    return (
        f"| {receiver} | {'on' if bias_model else 'off'} | {every} / {len(runs)} | "
        f"{sum(r['synchronized'] for r in runs)} / {sum(r['cameras'] for r in runs)} | "
        f"{np.nanmedian(median):.2f} ({np.nanmax(median):.2f}) | {np.nanmedian(worst):.2f} ({np.nanmax(worst):.2f}) | "
        f"{100 * np.mean(z <= Z95):.0f} % of {len(z)} | {sum(r['beyond'] for r in runs)} | {wrong} | "
        f"{right_refused} | {np.median([r['cpu_s'] for r in runs]):.1f} | {_peak(runs)} | {refused} |"
    )


def bound(slowed: SlowedFlight, receiver: str, poses_free: bool, white_m: float | None = None) -> str:
    """The first-order bound's row for ``receiver`` (its white noise ``white_m`` metres on every axis when given; the
    flight's cameras with their true poses): the median over draws of the median and of the worst pair's eps_t
    (frames), and the 90th percentile of the median pair's."""
    tracks = {}
    for name, inputs in slowed.cameras.items():
        track = inputs.track
        assert track is not None
        keep = slice(None, None, BOUND_THIN)
        tracks[name] = Track(track.frame[keep], track.x[keep], track.y[keep])
    cameras = {name: inputs.camera for name, inputs in slowed.cameras.items()}
    model = RECEIVERS[receiver]
    if white_m is not None:
        model = dataclasses.replace(model, white_h_m=white_m, white_v_m=white_m)
    noise = {"log": model, "S_t_px": BOUND_PX / np.sqrt(BOUND_THIN)}
    scene = Scene(slowed.trajectory, slowed.trajectory, cameras, cameras, tracks, slowed.lines, slowed.n_frames, noise)
    pairs = pair_draws(scene, SyncParams().rate_sigma, BOUND_DRAWS, np.random.default_rng(0), poses_free=poses_free)
    median, worst = np.median(pairs, axis=0), pairs.max(axis=0)
    return (
        f"| {receiver} | {'estimated' if poses_free else 'known'} | {np.median(median):.2f} "
        f"({np.quantile(median, 0.9):.2f}) | {np.median(worst):.2f} |"
    )


def _pixels(drawn: dict[str, float]) -> str:
    """Each camera's median distance of its track from the drawn log (pixels), one decimal."""
    return "{" + ", ".join(f"{name}: {px:.1f}" for name, px in drawn.items()) + "}"


def _peak(runs: list[dict]) -> str:
    """The largest peak memory of the runs (MB), "-" when none was measured (runs in this process)."""
    peaks = [(r["peak_mb"], r["rss_mb"]) for r in runs if np.isfinite(r["peak_mb"])]
    return f"{max(p for p, _ in peaks):.0f} ({max(r for _, r in peaks):.0f})" if peaks else "-"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--first-seed", type=int, default=0, metavar="N", help="the seeds N, N+1, ... (default 0)")
    parser.add_argument(
        "--white", type=float, default=None, metavar="M", help="the receiver's white noise (m, every axis)"
    )
    parser.add_argument("--json", type=Path, default=None, metavar="PATH", help="append every run to PATH (JSON lines)")
    parser.add_argument(
        "--models", nargs="+", default=["drone", "phone2"], choices=[m for m in RECEIVERS if m != "rtk"]
    )
    parser.add_argument("--bias-model", nargs="+", default=["off", "on"], choices=["off", "on"])
    parser.add_argument("--poses", default="given", choices=["given", "removed"])
    parser.add_argument(
        "--surveyed", nargs="+", default=[], metavar="CAMERA", help="with --poses removed, these keep their poses"
    )
    parser.add_argument("--through", default="synchronize", choices=["synchronize", "stages"])
    parser.add_argument("--slow", type=float, default=1.0, help="fly the path this many times slower")
    parser.add_argument(
        "--hover", type=float, default=0.0, metavar="S", help=f"hold still S seconds every {HOVER_EVERY_S:g} s"
    )
    parser.add_argument(
        "--max-speed", type=float, default=None, metavar="V", help="stretch the parts flown faster than V m/s to V"
    )
    parser.add_argument(
        "--only-slower", type=float, default=None, metavar="V", help="cut each track to where the drone is slower (m/s)"
    )
    parser.add_argument(
        "--crop", type=float, default=None, metavar="SHARE", help="cut each video to this share of its visit"
    )
    parser.add_argument("--cameras", nargs="+", default=None, help="the cameras kept (default: all)")
    parser.add_argument(
        "--count", type=int, default=None, metavar="N", help="repeat the cameras under new names to make N"
    )
    parser.add_argument(
        "--jobs", type=int, default=1, metavar="N", help="with --through stages: `tlsync run -j N` (default 1)"
    )
    parser.add_argument("--runs", action="store_true", help="print every run")
    parser.add_argument("--bound", action="store_true", help="print the first-order bound instead of running")
    args = parser.parse_args()
    if not (args.data / "project.toml").exists():
        print(f"{args.data}: no project.toml; skipped")
        sys.exit(0)
    variant = Variant(
        args.slow,
        args.hover,
        args.max_speed,
        args.only_slower,
        args.crop,
        None if args.cameras is None else tuple(args.cameras),
        args.poses,
        args.count,
        tuple(args.surveyed),
    )
    if args.bound:
        posed, _ = flight(args.data, dataclasses.replace(variant, poses="given"))
        print(f"{args.data}, {variant.describe()}: first-order bound (bench/gps_bound.py), {BOUND_PX:g} px tracking")
        print("| receiver | poses | median pair's eps_t, median over draws (90 %) | worst pair's eps_t |")
        print("|---|---|---|---|")
        for receiver in args.models:
            print(bound(posed, receiver, args.poses == "removed", args.white), flush=True)
        return
    slowed, params = flight(args.data, variant)
    white = "" if args.white is None else f", the receiver's white noise {args.white:g} m"
    print(
        f"{args.data}, through {args.through}, {variant.describe()}; seeds {args.first_seed}-"
        f"{args.first_seed + args.seeds - 1} per receiver{white}"
    )
    cpu = "CPU of `tlsync run` a run (s)" if args.through == "stages" else "sync CPU a run (s)"
    print(
        "| receiver | bias model | runs with every camera | cameras synchronized | median pair's eps_t, median "
        f"(max) | worst pair's eps_t, median (max) | 95 % intervals that contain the truth | pairs beyond 3x theirs | "
        f"cameras answered beyond 3x theirs | right lines refused | {cpu} | "
        f"peak memory of a run{', its process tree: Pss (RSS)' if args.through == 'stages' else ''} (MB) | "
        "refused (cause) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for receiver in args.models:
        for bias in args.bias_model:
            runs = []
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                runs.append(run_one(slowed, params, receiver, seed, bias == "on", args.through, args.jobs, args.white))
                if args.runs:
                    r = runs[-1]
                    print(
                        f"  {receiver} bias {bias} seed {seed}: {r['synchronized']}/{r['cameras']}, median "
                        f"{r['median']:.2f}, worst {r['worst']:.2f}, covered {sum(s <= Z95 for s in r['z'])}/"
                        f"{len(r['z'])}, beyond 3x {r['beyond']}, {r['cpu_s']:.0f} s, {r['peak_mb']:.0f} MB "
                        f"({r['rss_mb']:.0f} RSS), {r['statuses']}, wrong {r['wrong'] or '-'}, right lines refused "
                        f"{r['refused_right'] or '-'}, {r['codes'] or ''} {r['refused'] or ''}, track from the "
                        f"drawn log (px) {_pixels(r['drawn_px'])}",
                        file=sys.stderr,
                        flush=True,
                    )
                if args.json is not None:
                    with args.json.open("a", encoding="utf-8") as out:
                        row = {"receiver": receiver, "bias": bias, "variant": variant.describe(), **runs[-1]}
                        out.write(json.dumps(row, default=float) + "\n")
            print(summary(receiver, bias == "on", runs), flush=True)
    print(f"Peak resident memory of this bench's process: {peak_rss_mb():.0f} MB.")


if __name__ == "__main__":
    main()
