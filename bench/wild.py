"""The wild bench: scenes drawn from wide families, every plausibility check's false refusals and misses, accuracy.

    nice python bench/wild.py [--scenes 6] [--families walk phone pass loops crowd] [--trap-scenes 1] [--jobs 1] [--seed
    0]

Each scene is drawn, from its seed, out of one family built by the fixture
generators of data_fixtures/:

- ``walk`` (data_fixtures/walk.py): a walker (or a drone at 5 m/s) through
  3 views, the route turning in each view or straight; the log of one
  receiver (data_fixtures/log_error.py: RTK, white 0.3 m, a drone's
  Gauss-Markov 1 m / 30 s, phones 1 or 2 m / 60 s) declared as a user would
  ([target] log_model), undeclared (a trajectory the project brings: "none")
  or declared wrong (a phone's log said to be RTK, an RTK log said to be a
  phone's); videos that start and end 5-30 s or 5-300 s around the walk;
- ``phone``: walks that turn, phone GNSS (1 or 2 m / 60 s), declared
  ``phone``: the consumer case of issue 33;
- ``pass`` (data_fixtures/passes.py): a walker or a drone zig-zagging
  through 3 views (random polylines) or crossing some straight, RTK or white
  0.3 m log, the poses from the target with GCPs surveyed 0, 0.5 or 2 m off
  as a prior;
- ``nopose``: walks that turn (data_fixtures/walk.py), a drone's log (1 m /
  30 s, 5 m/s) or a phone's (1 or 2 m / 60 s), declared, and no camera
  with a pose or GCPs: every pose from the target under the log's bias;
- ``nopose-exact``: the same walks (route, speed, cameras) under an RTK
  log, declared: what the walks' geometry leaves open whatever the log's
  error (each camera sees one corner rounded over 2 m between straight legs,
  and the route has 8-11 corners of 60-110 degrees): a bound for
  ``nopose``; not in the default run;
- ``loops`` (data_fixtures/scene.py): paths that hover and fly back through
  the hover point 1-3 times (repeated passes, a path crossing itself);
- ``crowd`` (data_fixtures/crowd.py): two surveillance videos with 2-8
  look-alike walkers, every mover detected, the target identified (RTK or a
  phone's log, declared): the slowest family, rendered and tracked.

Printed: per family, the share of cameras answered (ok or weak), the median
and p90 of the worst synchronized pair's eps_t (frames, eq. 5) and, where
the scene has a log error model, the median first-order bound
(bench/gps_bound.py) and their ratio; the share of the synchronized pairs
whose 95 % interval of the start offset holds the truth, and those outside
three times it. Per plausibility check (each reason code that can stop a
camera, sync/solve/plausibility.py, sync/model/status.py): the cameras whose line was
right (within max(1 frame, 3 x its 95 % interval) of the truth at the
middle of its visit) that it refused, over every right line (its false
refusals), and the wrong lines it stopped. With ``--trap-scenes N``, the
trap suite (data_fixtures/traps.py) on N walk scenes with a phone's log
declared, each trap run by the ``tlsync`` command as bench/traps.py does:
per trap, runs caught (a non-zero exit naming a cause, nothing wrong
synchronized), right (exit 0, nothing wrong) and missed (a pair
synchronized wrong: further than a frame and than three times its 95 %
interval of the start offset from the truth); per check, the trap runs it
named.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _report import BEYOND, RIGHT_FRAMES, Z95, camera_error, is_right  # noqa: E402
from gps_bound import worst_pair_draws  # noqa: E402
from traps import run as run_tlsync  # noqa: E402

from data_fixtures.log_error import PRESETS as RECEIVERS  # noqa: E402
from data_fixtures.passes import make_pass_scene  # noqa: E402
from data_fixtures.scene import Scene, make_scene, write_scene  # noqa: E402
from data_fixtures.traps import TRAPS, edit_key  # noqa: E402
from data_fixtures.walk import WalkSpec, make_walk_scene  # noqa: E402
from tlsync_pipeline.sync.model.choices import GCP_SIGMA_M  # noqa: E402
from tlsync_pipeline.sync.model.log_model import PRESETS as LOG_MODELS  # noqa: E402
from tlsync_pipeline.sync.model.log_model import LogModel  # noqa: E402
from tlsync_pipeline.sync.model.params import SyncParams  # noqa: E402
from tlsync_pipeline.sync.model.status import AMBIGUOUS, FAILED  # noqa: E402
from tlsync_pipeline.sync.pose.pose_fit import GcpPrior  # noqa: E402
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize  # noqa: E402
from tlsync_pipeline.sync.timeline import Timeline, eps_t, read_timeline, read_truth  # noqa: E402
from tlsync_pipeline.trajectory import Trajectory  # noqa: E402

BOUND_DRAWS = 200
FAMILIES = ("walk", "phone", "pass", "nopose", "nopose-exact", "loops", "crowd")
NOT_BY_DEFAULT = ("nopose-exact", "crowd")
STOPPING = (AMBIGUOUS, FAILED)


@dataclass
class Case:
    """One drawn scene: what the sync is given (cameras, log, declared log model) and the truth (the Scene)."""

    label: str
    scene: Scene
    inputs: dict[str, CameraInput]
    trajectory: Trajectory
    declared: LogModel
    bound: bool = False


def _declaration(rng, receiver: str) -> tuple[str, str]:
    """(how the log is declared, the log_model name): as a user of that receiver would, undeclared, or wrong."""
    how = rng.choice(["declared", "declared", "undeclared", "wrong"])
    if how == "declared":
        return how, "phone" if receiver.startswith("phone") else receiver
    if how == "undeclared":
        return how, "none"
    return how, "rtk" if receiver in ("phone", "phone2", "drone") else "phone"


def walk_case(seed: int, phone_only: bool = False) -> Case:
    rng = np.random.default_rng([seed, 1])
    receiver = str(rng.choice(["phone", "phone2"] if phone_only else list(RECEIVERS)))
    route = "turns" if phone_only else str(rng.choice(["turns", "turns", "straight"]))
    how, declared = ("declared", "phone") if phone_only else _declaration(rng, receiver)
    lead = float(rng.choice([30.0, 300.0]))
    speed = 5.0 if receiver == "drone" else 1.4
    scene = make_walk_scene(seed, WalkSpec(route=route, log=RECEIVERS[receiver], speed_mps=speed, lead_s=lead))
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    label = f"{route} {receiver} {how} {declared}, videos {lead:g} s around"
    return Case(label, scene, inputs, scene.trajectory, LOG_MODELS[declared], bound=True)


def pass_case(seed: int) -> Case:
    rng = np.random.default_rng([seed, 2])
    paths = tuple(str(p) for p in rng.choice(["turn", "turn", "straight"], 3))
    drone = bool(rng.random() < 0.3)
    log_noise = float(rng.choice([0.02, 0.3]))
    gcp_noise = float(rng.choice([0.0, 0.5, 2.0]))
    base = make_pass_scene(seed, paths=paths, drone=drone, log_noise_m=log_noise, gcp_noise_m=gcp_noise)
    scene = base.scene
    inputs = {}
    for n, c in scene.true_cameras.items():
        unposed = c.without_pose()
        inputs[n] = CameraInput(
            unposed, scene.tracks[n], c.fps, gcps=GcpPrior(base.gcps[n].uv, base.gcps[n].xyz, GCP_SIGMA_M)
        )
    declared = "rtk" if log_noise < 0.1 else "white"
    label = (
        f"{'drone' if drone else 'walker'} {'/'.join(paths)}, log {log_noise:g} m ({declared}), GCPs "
        f"{gcp_noise:g} m off"
    )
    return Case(label, scene, inputs, scene.trajectory, LOG_MODELS[declared])


def nopose_case(seed: int, exact: bool = False) -> Case:
    """A turning walk under a drone's or a phone's log, declared, with no pose: each camera's pose from the target;
    exact: the same walk (route, speed, cameras) under an RTK log, declared ``rtk``."""
    rng = np.random.default_rng([seed, 5])
    drawn = str(rng.choice(["drone", "phone", "phone2"]))
    speed = 5.0 if drawn == "drone" else 1.4
    receiver = "rtk" if exact else drawn
    scene = make_walk_scene(seed, WalkSpec(route="turns", log=RECEIVERS[receiver], speed_mps=speed))
    inputs = {n: CameraInput(c.without_pose(), scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    declared = "phone" if receiver.startswith("phone") else receiver
    label = f"turns {receiver} declared {declared}, no pose" + (f" (drawn {drawn}, {speed:g} m/s)" if exact else "")
    return Case(label, scene, inputs, scene.trajectory, LOG_MODELS[declared])


def loops_case(seed: int) -> Case:
    rng = np.random.default_rng([seed, 3])
    crossings = int(rng.integers(1, 4))
    hover = float(rng.choice([0.2, 0.4]))
    scene = make_scene(
        seed,
        lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)),
        n_frames=(512, 512, 300),
        tracking_noise_px=1.0,
        hover_fraction=hover,
        crossings=crossings,
    )
    inputs = {n: CameraInput(c, scene.tracks[n], c.fps) for n, c in scene.cameras.items()}
    return Case(f"hover {hover:g}, {crossings} crossings", scene, inputs, scene.trajectory, LOG_MODELS["none"])


def crowd_case(seed: int) -> Case:
    from data_fixtures.crowd import CrowdSpec, make_crowd_scene
    from trackers.tracking import detect_movers

    rng = np.random.default_rng([seed, 4])
    distractors = int(rng.integers(2, 9))
    receiver = str(rng.choice(["rtk", "phone"]))
    log_error = None if receiver == "rtk" else RECEIVERS[receiver]
    with tempfile.TemporaryDirectory() as tmp:
        crowd = make_crowd_scene(
            CrowdSpec(
                seed=seed,
                distractors=distractors,
                log_rate=10.0 if log_error is None else log_error.rate_hz,
                log_error=log_error,
            ),
            tmp,
        )
        detections = {
            n: detect_movers(video, progress=False)
            for n in crowd.scene.cameras
            if (video := crowd.truth[n].video) is not None
        }
    scene = crowd.scene
    inputs = {n: CameraInput(c, None, c.fps, detections[n]) for n, c in scene.cameras.items()}
    return Case(
        f"{distractors} walkers, {receiver} log",
        scene,
        inputs,
        scene.trajectory,
        LOG_MODELS["phone" if receiver == "phone" else "none"],
        bound=log_error is not None,
    )


BUILDERS = {
    "walk": walk_case,
    "phone": lambda seed: walk_case(seed, phone_only=True),
    "pass": pass_case,
    "nopose": nopose_case,
    "nopose-exact": lambda seed: nopose_case(seed, exact=True),
    "loops": loops_case,
    "crowd": crowd_case,
}


def run_case(job: tuple[str, int]) -> dict:
    """One scene: its family, label, per camera (answered, right, stopping codes), pairs (eps_t, |z|), bound draws."""
    family, seed = job
    case = BUILDERS[family](seed)
    start = time.process_time()
    timeline, _ = synchronize(case.inputs, case.trajectory, SyncParams(), log_model=case.declared)
    seconds = time.process_time() - start
    cameras = []
    for name, status in timeline.statuses(list(case.scene.cameras)).items():
        line = timeline.cameras.get(name) or timeline.rejected.get(name)
        right = (
            is_right(*camera_error(line, case.scene.lines[name], case.scene.tracks[name].frame))
            if line is not None
            else None
        )
        codes = sorted({r.code for r in status.reasons if r.severity in STOPPING})
        cameras.append({"name": name, "answered": status.synchronized, "right": right, "codes": codes})
    pairs = []
    for key, truth in case.scene.truth_pairs().items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            cov = timeline.relation_cov(a, b)
            z = (
                abs(timeline.relation(a, b).beta - truth.beta) / np.sqrt(cov[1, 1])
                if cov is not None and cov[1, 1] > 0
                else np.inf
            )
            pairs.append((eps_t(timeline.relation(a, b), truth, case.scene.n_frames[a]), z))
    worst = max((e for e, _ in pairs), default=np.nan) if len(timeline.cameras) == len(case.scene.cameras) else np.nan
    bound = (
        worst_pair_draws(case.scene, SyncParams().rate_sigma, BOUND_DRAWS, np.random.default_rng(seed))
        if case.bound and "log" in case.scene.noise
        else np.array([])
    )
    return {
        "family": family,
        "seed": seed,
        "label": case.label,
        "cameras": cameras,
        "pairs": pairs,
        "worst": worst,
        "bound": bound,
        "seconds": seconds,
    }


def family_table(rows: list[dict]) -> list[str]:
    out = [
        "| family | scenes | cameras answered | scenes with a camera refused | median eps_t (all answered) | p90 | "
        "first-order bound (median) | eps_t / bound | 95 % intervals holding the truth | pairs beyond 3x | CPU s / "
        "scene |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for family in dict.fromkeys(r["family"] for r in rows):
        mine = [r for r in rows if r["family"] == family]
        cams = [c for r in mine for c in r["cameras"]]
        answered = np.mean([c["answered"] for c in cams])
        refused = sum(not all(c["answered"] for c in r["cameras"]) for r in mine)
        worst = np.array([r["worst"] for r in mine])
        worst = worst[np.isfinite(worst)]
        z = np.array([z for r in mine for _, z in r["pairs"]])
        draws = [r["bound"] for r in mine if len(r["bound"])]
        bound = float(np.median(np.concatenate(draws))) if draws else np.nan
        median = float(np.median(worst)) if len(worst) else np.nan
        p90 = float(np.quantile(worst, 0.9)) if len(worst) else np.nan
        coverage = f"{100 * np.mean(z <= Z95):.0f} % of {len(z)}" if len(z) else "-"
        beyond = int(np.sum(z > BEYOND * Z95))
        ratio = f"{median / bound:.2f}" if np.isfinite(bound) and bound > 0 and np.isfinite(median) else "-"
        seconds = np.median([r["seconds"] for r in mine])
        out.append(
            f"| {family} | {len(mine)} | {100 * answered:.0f} % | {refused} | {median:.2f} | {p90:.2f} | {bound:.2f} "
            f"| {ratio} | {coverage} | {beyond} | {seconds:.1f} |"
        )
    return out


def check_table(rows: list[dict]) -> list[str]:
    cams = [c for r in rows for c in r["cameras"]]
    right = [c for c in cams if c["right"]]
    wrong = [c for c in cams if c["right"] is False]
    codes = sorted({code for c in cams for code in c["codes"]})
    out = [
        f"Right lines: {len(right)}; wrong lines: {len(wrong)} (of which reported synchronized: "
        f"{sum(c['answered'] for c in wrong)}); cameras without a line: {sum(c['right'] is None for c in cams)}.",
        "",
        "| check (reason code) | false refusals (right lines it stopped) | wrong lines it stopped |",
        "|---|---|---|",
    ]
    for code in codes:
        false = sum(code in c["codes"] for c in right)
        caught = sum(code in c["codes"] for c in wrong)
        out.append(
            f"| {code} | {false} / {len(right)} ({100 * false / max(len(right), 1):.1f} %) | {caught} / {len(wrong)} |"
        )
    return out


def odd_cameras(rows: list[dict]) -> list[str]:
    """The cameras refused (with their codes) and those synchronized with a wrong line, one line each."""
    out = []
    for r in rows:
        for c in r["cameras"]:
            if not c["answered"]:
                out.append(
                    f"- {r['family']} seed {r['seed']} ({r['label']}): {c['name']} refused: "
                    f"{', '.join(c['codes']) or 'no line'}{' (its line was right)' if c['right'] else ''}"
                )
            elif c["right"] is False:
                out.append(
                    f"- {r['family']} seed {r['seed']} ({r['label']}): {c['name']} synchronized with a wrong line"
                )
    return out


def trap_run(job: tuple[int, str]) -> dict:
    """One trap on a walk scene with a phone's log declared, run by the tlsync command: outcome and the codes named."""
    seed, trap = job
    case = walk_case(seed, phone_only=True)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "project"
        write_scene(replace(case.scene, noise={}), root)  # truth.json: the lines; the log model's arrays are not JSON
        edit_key(root, None, "log_model", "phone")
        try:
            TRAPS[trap](root)
        except (KeyError, IndexError):
            return {"trap": trap, "outcome": "n/a", "codes": []}
        code, _, output = run_tlsync(root, "sync")
        timeline_file = root / "work" / "timeline.json"
        if code == 2 or not timeline_file.exists():
            return {
                "trap": trap,
                "outcome": "caught" if code != 0 else "missed",
                "codes": ["bad_input" if code == 2 else f"exit {code}"],
            }
        timeline = read_timeline(timeline_file)
        truth, n_frames = read_truth(root / "truth.json")
        wrong = any(_pair_wrong(timeline, key, relation, n_frames) for key, relation in truth.items())
        codes = sorted({r.code for s in timeline.statuses().values() for r in s.reasons if r.severity in STOPPING})
        outcome = "missed" if wrong else "right" if code == 0 else "caught"
        return {"trap": trap, "outcome": outcome, "codes": codes}


def _pair_wrong(timeline: Timeline, key: str, truth, n_frames: dict[str, int]) -> bool:
    """Whether a synchronized pair is wrong: further than RIGHT_FRAMES (eps_t) and than BEYOND times its 95 % interval
    of the start offset from the truth (a phone's log leaves right answers tens of frames off, within their interval).
    """
    a, b = key.split("->")
    if not {a, b} <= set(timeline.cameras):
        return False
    relation = timeline.relation(a, b)
    if eps_t(relation, truth, n_frames.get(a) or 1) <= RIGHT_FRAMES:
        return False
    cov = timeline.relation_cov(a, b)
    return cov is None or not abs(relation.beta - truth.beta) <= BEYOND * Z95 * float(np.sqrt(cov[1, 1]))


def trap_table(results: list[dict]) -> list[str]:
    out = ["| trap | caught | right | missed |", "|---|---|---|---|"]
    for trap in dict.fromkeys(r["trap"] for r in results):
        mine = Counter(r["outcome"] for r in results if r["trap"] == trap)
        out.append(f"| {trap} | {mine['caught']} | {mine['right']} | {mine['missed']} |")
    total = Counter(r["outcome"] for r in results if r["outcome"] != "n/a")
    runs = sum(total.values())
    out.append(
        f"| **all** | {total['caught']} | {total['right']} | **{total['missed']} of {runs} "
        f"({100 * total['missed'] / max(runs, 1):.1f} %)** |"
    )
    named = Counter(code for r in results for code in r["codes"])
    out += ["", "Checks named on trap runs: " + ", ".join(f"{code} {n}" for code, n in named.most_common())]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=6, help="scenes per family")
    parser.add_argument(
        "--families", nargs="+", default=[f for f in FAMILIES if f not in NOT_BY_DEFAULT], choices=FAMILIES
    )
    parser.add_argument(
        "--trap-scenes", type=int, default=0, help="walk scenes with a phone's log the trap suite runs on"
    )
    parser.add_argument("--jobs", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    args = parser.parse_args()
    jobs = [(family, args.seed + k) for family in args.families for k in range(args.scenes)]
    start = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(run_case, jobs))
        print(
            f"wild bench: {args.scenes} scenes per family, seeds from {args.seed}, {time.perf_counter() - start:.0f} "
            f"s wall with {args.jobs} job(s)\n"
        )
        print("\n".join(family_table(rows)))
        print()
        print("\n".join(check_table(rows)))
        odd = odd_cameras(rows)
        if odd:
            print("\nCameras refused, or synchronized wrong:\n" + "\n".join(odd), flush=True)
        traps = list(
            pool.map(
                trap_run,
                [
                    (args.seed + k, t)
                    for k in range(args.trap_scenes)
                    for t in TRAPS
                    if t not in ("video_is_dev_urandom", "video_missing")
                ],
            )
        )
    if traps:
        print(f"\nTrap suite on {args.trap_scenes} walk scene(s) with a phone's log declared:\n")
        print("\n".join(trap_table(traps)))


if __name__ == "__main__":
    main()
