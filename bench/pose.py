"""Poses from the target: eps_t and pose error against GCP noise and without GCPs, the real flight without poses, a
crowd, speed.

    nice python bench/pose.py [--scenes 20] [--jobs 2] [--crowd 5] [--demo-draws 10] [--gnss-seeds 3] [--gnss-only]
    [--data /work/shared/real/drone2] [--no-write]

1. Pass scenes (data_fixtures/passes.py: a walker crossing three 30 fps
   views and turning inside each, RTK log 10 Hz with 2 cm noise, 2 px
   tracks, 8 GCPs per camera), ``--scenes`` seeds. Per scene, the worst
   pair's eps_t (frames) and each camera's pose error (centre, metres;
   rotation, degrees) for: the true poses ("exact"); the GCPs' own pose
   taken as exact, as tlsync did before (SQPnP + RANSAC at 8 px: "GCPs
   alone"); the pose from the target with the GCPs as a prior at the
   default gcp_sigma_m ("GCPs + target"); and from the target alone. GCP
   error: 0, 0.1, 0.5 and 2 m per horizontal axis.
2. The real flight (../shared/real/drone2), every camera's R and t removed
   (only K and the distortion given): eps_t per pair against the truth
   file, with and without the poses; skipped when the folder is absent.
3. Crowds (data_fixtures/crowd.py, 6 walkers, ``--crowd`` seeds): every
   mover detected in the rendered videos, no pose and no track given: the
   pose from the movers' tracklets, then the sync; eps_t of the worst pair
   and which cameras got a pose (the others' cause).
4. Speed: CPU seconds of the pose search and fit of one camera for 10
   minutes of 30 fps track (a walker turning in one view for 600 s).
5. The raw demo (what ``tlsync demo`` builds) with its GCPs surveyed 0.5 m
   off per horizontal axis, ``--demo-draws`` random draws of that error,
   run through the pipeline with the defaults: per draw, the cameras
   synchronized, the worst pair's eps_t, and each camera's pose source,
   measured GCP sigma and disagreeing GCPs.
6. The real flight without poses with a consumer drone's GNSS error added
   to its log (data_fixtures/log_error.py's ``drone``: Gauss-Markov 1 m /
   30 s horizontal, 2 m vertical, 0.1-0.2 m white), declared ``drone``,
   ``--gnss-seeds`` seeds: cameras synchronized, worst and median eps_t,
   interval coverage, the synchronized camera whose beta is furthest from
   the truth (truth.json's cameras_to_target) in its own sigmas, each
   refused camera's cause and the sync's CPU seconds; then the share of runs
   with every camera, the median eps_t over the runs, the intervals that hold
   and the process's peak resident memory (bench/_memory.py). ``--gnss-only``
   runs this section alone and prints it.

Writes the tables into docs/accuracy.md (block ``pose``) and the summary
into docs/calibration.md (block ``pose``) unless --no-write.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from _memory import peak_rss_mb  # noqa: E402
from _report import pair_errors  # noqa: E402

from calibration.errors import CalibrationInputError  # noqa: E402
from calibration.extrinsics import pose_from_points  # noqa: E402
from data_fixtures.passes import make_pass_scene  # noqa: E402
from tlsync_pipeline.sync.identify.identify import identify_params  # noqa: E402
from tlsync_pipeline.sync.model.choices import GCP_SIGMA_M  # noqa: E402
from tlsync_pipeline.sync.model.methods import preparation_of, prepare_trajectory  # noqa: E402
from tlsync_pipeline.sync.model.params import SyncParams  # noqa: E402
from tlsync_pipeline.sync.pose.pose import estimate_pose, rotation_between  # noqa: E402
from tlsync_pipeline.sync.pose.pose_fit import GcpPrior  # noqa: E402
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize  # noqa: E402
from tlsync_pipeline.sync.timeline import eps_t  # noqa: E402

NOISE_M = (0.0, 0.1, 0.5, 2.0)
Z95 = 1.959964
DEFAULT_DATA = Path("/work/shared/real/drone2")
CALIBRATION_DOC = Path(__file__).resolve().parent.parent / "docs" / "calibration.md"


def _worst(timeline, scene) -> float:
    """The worst pair's eps_t; inf when a camera was not synchronized."""
    if timeline.failed:
        return float("inf")
    return max(
        eps_t(timeline.relation(*k.split("->")), true, scene.n_frames[k.split("->")[0]])
        for k, true in scene.truth_pairs().items()
    )


def _z(timeline, scene) -> list[float]:
    """|error| / std of the start offset of every synchronized pair (inf without an interval): <= 1.96 is covered."""
    if timeline is None:
        return []
    out = []
    for key, truth in scene.truth_pairs().items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            cov = timeline.relation_cov(a, b)
            out.append(
                abs(timeline.relation(a, b).beta - truth.beta) / np.sqrt(cov[1, 1]) if cov is not None else np.inf
            )
    return out


def _pose_errors(results, scene) -> list[tuple[float, float]]:
    out = []
    for name, result in results.items():
        camera = result.pose.camera if result.pose is not None else None
        if camera is not None:
            truth = scene.true_cameras[name]
            out.append((float(np.linalg.norm(camera.center - truth.center)), rotation_between(camera.R, truth.R)))
    return out


def pass_scene(seed: int) -> dict:
    """Every setting on one seeded scene: worst eps_t, pose errors, cameras without a pose, CPU seconds of the poses."""
    rows: dict = {}
    params = SyncParams()
    base = make_pass_scene(seed)
    scene = base.scene
    exact = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.true_cameras.items()}
    timeline, _ = synchronize(exact, scene.trajectory, params)
    rows["exact"] = {"worst": _worst(timeline, scene), "errors": [], "missing": 0, "z": _z(timeline, scene)}
    start = time.process_time()
    timeline, results = synchronize(
        {n: CameraInput(c.without_pose(), scene.tracks[n], c.fps) for n, c in scene.true_cameras.items()},
        scene.trajectory,
        params,
    )
    rows["target"] = {
        "worst": _worst(timeline, scene),
        "errors": _pose_errors(results, scene),
        "missing": len(timeline.failed),
        "cpu_s": time.process_time() - start,
        "z": _z(timeline, scene),
    }
    for noise in NOISE_M:
        gcps = make_pass_scene(seed, gcp_noise_m=noise).gcps
        alone, missing = {}, 0
        for n, c in scene.true_cameras.items():
            g = gcps[n]
            try:
                pose = pose_from_points(g.uv, g.xyz, c.K, c.dist, c.dist_model, 8.0)
            except CalibrationInputError:
                missing += 1
                continue
            alone[n] = CameraInput(replace(c, R=pose.R, t=pose.t), scene.tracks[n], c.fps)
        errors = [
            (
                float(np.linalg.norm(i.camera.center - scene.true_cameras[n].center)),
                rotation_between(i.camera.R, scene.true_cameras[n].R),
            )
            for n, i in alone.items()
        ]
        timeline, _ = synchronize(alone, scene.trajectory, params) if alone else (None, {})
        rows[("alone", noise)] = {
            "worst": _worst(timeline, scene) if timeline is not None and not missing else float("inf"),
            "errors": errors,
            "missing": missing,
            "z": _z(timeline, scene),
        }
        inputs = {
            n: CameraInput(
                c.without_pose(), scene.tracks[n], c.fps, gcps=GcpPrior(gcps[n].uv, gcps[n].xyz, GCP_SIGMA_M)
            )
            for n, c in scene.true_cameras.items()
        }
        timeline, results = synchronize(inputs, scene.trajectory, params)
        rows[("joint", noise)] = {
            "worst": _worst(timeline, scene),
            "errors": _pose_errors(results, scene),
            "missing": len(timeline.failed),
            "z": _z(timeline, scene),
        }
    return rows


def pass_table(all_rows: list[dict]) -> str:
    def line(label, key):
        worst = np.array([r[key]["worst"] for r in all_rows])
        errors = (
            np.array([e for r in all_rows for e in r[key]["errors"]])
            if any(r[key]["errors"] for r in all_rows)
            else np.zeros((0, 2))
        )
        missing = sum(r[key]["missing"] for r in all_rows)
        pose = (
            f"{np.median(errors[:, 0]):.3f} / {np.quantile(errors[:, 0], 0.9):.3f} | {np.median(errors[:, 1]):.3f}"
            if len(errors)
            else "- | -"
        )
        z = np.array([v for r in all_rows for v in r[key]["z"]])
        coverage = f"{100 * np.mean(z <= Z95):.0f} % of {len(z)}" if len(z) else "-"
        return (
            f"| {label} | {np.median(worst):.3f} | {np.quantile(worst, 0.9, method='higher'):.3f} | {pose} | "
            f"{missing} / {3 * len(all_rows)} | {coverage} |"
        )

    lines = [
        "| poses | median eps_t | p90 eps_t | pose centre error, median / p90 (m) | rotation error, median (deg) | "
        "cameras without a pose | 95 % intervals that contain the truth (synchronized pairs) |",
        "|---|---|---|---|---|---|---|",
        line("exact (the true poses)", "exact"),
        line("from the target, no GCPs", "target"),
    ]
    for noise in NOISE_M:
        lines.append(line(f"GCPs {noise:g} m off, alone (as before)", ("alone", noise)))
        lines.append(line(f"GCPs {noise:g} m off + target (sigma measured; stated {GCP_SIGMA_M:g})", ("joint", noise)))
    return "\n".join(lines)


def real_flight(data: Path) -> str | None:
    """eps_t per pair on the real flight with and without the poses; None when the data is absent."""
    if not (data / "project.toml").exists():
        return None
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.stages.sync import load_inputs
    from tlsync_pipeline.sync.timeline import read_truth

    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    out = {}
    seconds = {}
    for label, inputs in (
        ("given poses", cameras),
        ("poses removed", {n: replace(c, camera=c.camera.without_pose()) for n, c in cameras.items()}),
    ):
        start = time.process_time()
        timeline, results = synchronize(inputs, trajectory, project.sync)
        seconds[label] = time.process_time() - start
        out[label] = {
            k: eps_t(timeline.relation(*k.split("->")), r, n_frames.get(k.split("->")[0]) or 1)
            for k, r in truth.items()
        }
        if label == "poses removed":
            moved = {
                n: (
                    float(np.linalg.norm(r.pose.camera.center - cameras[n].camera.center)),
                    rotation_between(r.pose.camera.R, cameras[n].camera.R),
                )
                for n, r in results.items()
                if r.pose
            }
    rows = [f"| {k} | {out['given poses'][k]:.3f} | {out['poses removed'][k]:.3f} |" for k in truth]
    a, b = np.array(list(out["given poses"].values())), np.array(list(out["poses removed"].values()))
    poses = ", ".join(f"{n} {d:.3f} m / {r:.3f} deg" for n, (d, r) in moved.items())
    return "\n".join(
        [
            f"Real flight {data.name}: {len(cameras)} cameras, sync CPU {seconds['given poses']:.1f} s with the "
            f"poses, {seconds['poses removed']:.1f} s without (the poses from the target included).",
            "",
            "| pair | eps_t, given poses | eps_t, poses removed |",
            "|---|---|---|",
            *rows,
            f"| **median** | **{np.median(a):.3f}** | **{np.median(b):.3f}** |",
            f"| max | {a.max():.3f} | {b.max():.3f} |",
            "",
            f"Poses from the target against the given ones: {poses}.",
        ]
    )


def demo_draws(draws: int) -> str:
    """The raw demo with its GCPs 0.5 m off, ``draws`` draws of the survey error, through the pipeline (section 5)."""
    import json
    import subprocess

    from data_fixtures.raw_project import RawProjectSpec, make_raw_project, rewrite_gcps
    from tlsync_pipeline.sync.timeline import read_timeline, read_truth

    rows = [
        "| draw | cameras synchronized | worst eps_t | per camera: pose source, measured GCP sigma (m), GCPs that "
        "disagree |",
        "|---|---|---|---|",
    ]
    worst_all = []
    with tempfile.TemporaryDirectory() as tmp:
        project_file, scene = make_raw_project(Path(tmp) / "demo", RawProjectSpec(gcp_noise_m=0.5))
        truth, n_frames = read_truth(project_file.parent / "truth.json")
        for draw in range(draws):
            rewrite_gcps(project_file.parent, RawProjectSpec(gcp_noise_m=0.5, gcp_draw=draw))
            subprocess.run(
                [sys.executable, "-m", "tlsync_pipeline.cli", "run", str(project_file), "-j", "1", "-q"],
                capture_output=True,
                check=False,
            )
            timeline = read_timeline(project_file.parent / "work" / "timeline.json")
            errors = [
                eps_t(timeline.relation(*k.split("->")), r, n_frames[k.split("->")[0]])
                for k, r in truth.items()
                if all(c in timeline.cameras for c in k.split("->"))
            ]
            worst = max(errors) if len(timeline.cameras) == len(scene.true_cameras) else float("inf")
            worst_all.append(worst)
            poses = []
            for name in scene.true_cameras:
                target = (
                    json.loads(
                        (project_file.parent / "work" / "cameras" / name / "calibration_report.json").read_text(
                            encoding="utf-8"
                        )
                    ).get("target_pose")
                    or {}
                )
                poses.append(
                    f"{name} {target.get('cause') or target.get('source')} "
                    f"{target.get('gcp_sigma_m', float('nan')):.2f} "
                    f"{','.join(target.get('gcps_disagree') or []) or '-'}"
                )
            rows.append(
                f"| {draw} | {len(timeline.cameras)} / {len(scene.true_cameras)} | {worst:.3f} | {'; '.join(poses)} |"
            )
    synced = sum(np.isfinite(w) for w in worst_all)
    return "\n".join(
        [
            f"Raw demo with its GCPs 0.5 m off (per horizontal axis), {draws} draws, defaults: every camera "
            f"synchronized in {synced} of {draws}; worst pair {max(worst_all):.3f} frames.",
            "",
            *rows,
        ]
    )


def gnss_without_poses(data: Path, seeds: int) -> str | None:
    """The real flight without poses, a drone's GNSS error added to its log, declared ``drone`` (section 6); None
    without the data.
    """
    if not (data / "project.toml").exists():
        return None
    import dataclasses

    from data_fixtures.log_error import PRESETS as RECEIVERS
    from data_fixtures.log_error import log_errors
    from tlsync_pipeline.pipeline.project import load_project
    from tlsync_pipeline.pipeline.stages.sync import load_inputs
    from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS
    from tlsync_pipeline.sync.timeline import read_truth

    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    to_target = json.loads((data / "truth.json").read_text())["cameras_to_target"]
    rows = [
        "| seed | cameras synchronized | worst eps_t | median eps_t | 95 % intervals that contain the truth | a "
        "camera's beta off the truth, most (sigmas) | refused (cause) | sync CPU (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    synced, every, medians, all_z = 0, 0, [], []
    for seed in range(seeds):
        errors, _ = log_errors(np.random.default_rng(seed), trajectory.sample / trajectory.rate, RECEIVERS["drone"])
        inputs = {n: replace(c, camera=c.camera.without_pose()) for n, c in cameras.items()}
        start = time.process_time()
        timeline, _ = synchronize(
            inputs,
            dataclasses.replace(trajectory, xyz=trajectory.xyz + errors),
            project.sync,
            log_model=LOG_MODELS["drone"],
        )
        seconds = time.process_time() - start
        pairs = pair_errors(timeline, truth, n_frames)
        eps, z = [e for e, _ in pairs], [score for _, score in pairs]
        causes = (
            ", ".join(
                f"{n} ({why.split('(', 2)[1].split(')')[0] if '(' in why else why[:40]})"
                for n, why in timeline.failed.items()
            )
            or "-"
        )
        worst = f"{max(eps):.2f} | {np.median(eps):.2f}" if eps else "- | -"
        cover = f"{100 * np.mean(np.array(z) <= Z95):.0f} % of {len(z)}" if z else "-"
        off = [
            abs(line.beta - to_target[n]["beta"]) / np.sqrt(line.cov[1, 1]) if line.cov is not None else np.inf
            for n, line in timeline.cameras.items()
        ]
        most = f"{max(off):.2f}" if off else "-"
        rows.append(
            f"| {seed} | {len(timeline.cameras)} / {len(cameras)} | {worst} | {cover} | {most} | {causes} | "
            f"{seconds:.0f} |"
        )
        synced += len(timeline.cameras)
        every += len(timeline.cameras) == len(cameras)
        medians += [float(np.median(eps))] if eps else []
        all_z += z
    held = f"{100 * np.mean(np.array(all_z) <= Z95):.0f} % of {len(all_z)}" if all_z else "none of 0"
    summary = (
        f"Every camera synchronized in {every} of {seeds} runs ({synced} of {len(cameras) * seeds} cameras); "
        f"median eps_t over the runs {np.median(medians) if medians else float('nan'):.2f} frames; {held} intervals "
        f"hold; "
        f"peak resident memory of this bench's process {peak_rss_mb():.0f} MB."
    )
    return "\n".join(
        [
            f"Real flight {data.name} without poses, a drone's GNSS error added to its log (declared `drone`), "
            f"{seeds} seeds:",
            "",
            *rows,
            "",
            summary,
        ]
    )


def crowd_scene(seed: int) -> dict:
    """One 6-walker crowd scene: every mover detected, no pose, no track: worst eps_t and each camera's outcome."""
    from data_fixtures.crowd import CrowdSpec, make_crowd_scene
    from trackers.tracking import detect_movers

    with tempfile.TemporaryDirectory() as tmp:
        crowd = make_crowd_scene(CrowdSpec(seed=seed, distractors=6), tmp)
        scene = crowd.scene
        detections = {n: detect_movers(crowd.truth[n].video, progress=False) for n in scene.cameras}
    start = time.process_time()
    timeline, results = synchronize(
        {n: CameraInput(c.without_pose(), None, c.fps, detections[n]) for n, c in scene.cameras.items()},
        scene.trajectory,
        SyncParams(),
    )
    seconds = time.process_time() - start
    errors = _pose_errors(results, scene)
    outcome = {
        n: (
            "posed"
            if n in results
            else timeline.failed[n].split("(", 2)[1].split(")")[0]
            if "(" in timeline.failed[n]
            else "failed"
        )
        for n in scene.cameras
    }
    return {"worst": _worst(timeline, scene), "errors": errors, "outcome": outcome, "cpu_s": seconds}


def crowd_table(rows: list[dict]) -> str:
    lines = [
        "| seed | worst eps_t | cameras (10 fps, 5 fps) | pose centre error (m) | rotation error (deg) | CPU s |",
        "|---|---|---|---|---|---|",
    ]
    for seed, r in enumerate(rows):
        errors = ", ".join(f"{d:.2f}" for d, _ in r["errors"]) or "-"
        angles = ", ".join(f"{a:.2f}" for _, a in r["errors"]) or "-"
        worst = "not synchronized" if not np.isfinite(r["worst"]) else f"{r['worst']:.3f}"
        lines.append(
            f"| {seed} | {worst} | {', '.join(r['outcome'].values())} | {errors} | {angles} | {r['cpu_s']:.0f} |"
        )
    return "\n".join(lines)


def speed(rounds: int = 2) -> tuple[float, int]:
    """CPU seconds (the faster of ``rounds``) of one camera's pose search and fit on 10 minutes of 30 fps track, and its
    frames.
    """
    scene = make_pass_scene(0, paths=("turn",), view_walk_s=600.0).scene
    camera, track = scene.true_cameras["cam0"], scene.tracks["cam0"]
    params = SyncParams()
    prepared = prepare_trajectory(scene.trajectory, preparation_of(params))
    times = []
    for _ in range(rounds):
        start = time.process_time()
        estimate_pose(camera.without_pose(), track, None, prepared, camera.fps, identify_params(params))
        times.append(time.process_time() - start)
    return min(times), len(track)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20)
    parser.add_argument("--crowd", type=int, default=5, metavar="N", help="crowd scenes (0: none)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument(
        "--demo-draws", type=int, default=10, metavar="N", help="draws of the raw demo's GCP error (0: none)"
    )
    parser.add_argument(
        "--gnss-seeds",
        type=int,
        default=3,
        metavar="N",
        help="seeds of the real flight with a drone's GNSS error, without poses (0: none)",
    )
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/ alone")
    parser.add_argument(
        "--gnss-only",
        action="store_true",
        help="only the real flight with a drone's GNSS error, without poses; print it, leave docs/ alone",
    )
    args = parser.parse_args()
    if args.gnss_only:
        print(
            gnss_without_poses(args.data, args.gnss_seeds)
            or f"drone GNSS without poses: skipped ({args.data} not found)"
        )
        return
    started = time.time()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(pass_scene, range(args.scenes)))
        crowd = list(pool.map(crowd_scene, range(args.crowd))) if args.crowd else []
    passes = pass_table(rows)
    pose_cpu = np.array([r["target"]["cpu_s"] / 3 for r in rows])
    print(passes)
    flight = real_flight(args.data)
    print(flight or f"real flight: skipped ({args.data} not found)")
    crowds = crowd_table(crowd) if crowd else ""
    print(crowds)
    demo = demo_draws(args.demo_draws) if args.demo_draws else ""
    print(demo)
    gnss = (
        (gnss_without_poses(args.data, args.gnss_seeds) or f"drone GNSS without poses: skipped ({args.data} not found)")
        if args.gnss_seeds
        else ""
    )
    print(gnss)
    seconds, frames = speed()
    pace = (
        f"Speed: the pose search and fit of one camera on {frames} frames (10 minutes at 30 fps; a walker turning "
        f"in its view): {seconds:.1f} s CPU (the faster of 2 runs). On the pass scenes (500-900 frames a camera): "
        f"{np.median(pose_cpu):.1f} s a camera (median, with its sync)."
    )
    print(pace)
    text = "\n".join(
        [
            f"`python bench/pose.py --scenes {args.scenes} --crowd {args.crowd} --demo-draws {args.demo_draws} "
            f"--gnss-seeds {args.gnss_seeds}` ({time.strftime('%Y-%m-%d')}, {(time.time() - started) / 60:.0f} min on "
            f"this machine).",
            "",
            f"Pass scenes, {args.scenes} seeds (3 cameras each; worst pair per scene, frames):",
            "",
            passes,
            "",
            flight or f"Real flight: skipped ({args.data} not found).",
            "",
            f"Crowds, 6 walkers per view, no pose and no track given (the pose from every mover's tracklets), "
            f"{args.crowd} seeds:"
            if crowd
            else "",
            "",
            crowds,
            "",
            demo,
            "",
            gnss,
            "",
            pace,
        ]
    )
    if not args.no_write:
        from _report import write_block

        write_block("pose", text)
        write_block("pose", text, CALIBRATION_DOC)


if __name__ == "__main__":
    main()
