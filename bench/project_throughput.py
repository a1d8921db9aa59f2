"""Whole-project throughput: `tlsync run` against the decode-only floor of its videos, in the same run.

    python bench/project_throughput.py [--quick] [--cameras 4] [--seconds 60] [--size 1920x1080]
        [--look-alikes 6] [--trackers blob,blob-full,csrt] [--scene long|textured] [--keep DIR] [--jobs N] [--rounds 1]
        [--workload long-recording|short-720p]

1. Makes a raw project (data_fixtures.raw_project: per camera an H.264 video,
   checkerboard photos and GCPs; a GPX log of the target). The scene renderer
   is pluggable (``--scene``, the SCENES table): ``long`` renders 1080p
   minutes quickly (data_fixtures.long_video), with ``--look-alikes``
   discs like the target wandering each view at its speed (6 by default,
   the crowd the default tracker is built for); ``textured`` is the tests'
   renderer (data_fixtures.video, slower, no look-alikes). Cameras run at
   30, 25, 50 and 29.97 fps in turn. ``--keep DIR`` keeps the project there and reuses it
   when the same one is asked for again. ``--workload`` names one of WORKLOADS
   instead: ``long-recording`` (3 cameras recording 9 minutes of 720p at the
   same time, the target in each view for 65 s, about 12 % of the frames,
   6 look-alikes all the time) or ``short-720p`` (3 cameras, 2,400, 2,000
   and 1,200 frames, the target in view a third of the time).
2. Decode-only floor: every video decoded with PyAV (luma plane, FFmpeg's
   own threads as the pipeline uses them), as many processes as cores,
   longest videos first.
3. For each tracker kind: the whole `tlsync run` in a fresh work folder (a
   child process; its CPU time includes its workers), the run time and CPU
   time per stage (sums of the stage's tasks' own figures from the
   manifests; CPU/run above 1 means FFmpeg's decoding threads overlap the
   Python tracker), the run's worst eps_t against the project's truth (a
   fast run that found a look-alike is no result), the frames it decoded
   (keyframes of the coarse pass and frames of the track stage, from
   timeline.json; the cameras read whole and why), and a cached re-run
   (nothing to do). A kind "<kind>-full" runs with ``[track] scan =
   "full"`` (every frame read): the runs of that kind also give their
   worst pair against it; it runs once, in the first round and with this
   tree only (the reference). With ``--compare``, the other tree's runs
   give their worst pair against this tree's. The trees' bytecode is compiled
   once into the run's temporary folder first (PYTHONPYCACHEPREFIX), as
   pip compiles an installed package's; ``--no-bytecode-cache``: every
   process compiles what it imports (under PYTHONDONTWRITEBYTECODE: about
   0.3 s of CPU a process).
4. ``--rounds N``: N - 1 more rounds of the floor and a fresh run of each
   tracker but the full passes, in turn, and each run's ratios to its round's floor with their
   median: on a shared machine one round's ratios move by 0.1-0.3.

Prints wall times, CPU times, CPU utilisation (CPU s / (wall s x cores)),
peak RSS of the largest process, the ratios to the floor and the load
average (``os.getloadavg``) around each measurement: on a shared machine
the ratios are the figures to compare, not the seconds.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import functools
import inspect
import json
import multiprocessing
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from _memory import peak_rss_mb  # noqa: E402

from data_fixtures.raw_project import RawProjectSpec, make_raw_project  # noqa: E402
from tlsync_pipeline.pipeline.graph import STAGES  # noqa: E402
from tlsync_pipeline.sync.timeline import eps_t, read_timeline, read_truth  # noqa: E402

FPS_CYCLE = (30.0, 25.0, 50.0, 30000 / 1001)
TARGET_RATE = 10.0  # Hz, the GPX log


def _scenes():
    from data_fixtures.long_video import render_long_camera_video
    from data_fixtures.video import render_camera_video

    return {"long": render_long_camera_video, "textured": render_camera_video}


@dataclass(frozen=True)
class Workload:
    """cameras, seconds (each video), size, scene renderer and look-alikes per view; fps: per camera (default
    FPS_CYCLE).

    starts_s: the cameras record at the same time, each starting at these
    seconds of the log (None: one after the other, each sharing the target
    with the next); stay_s: then the target stays in each view for at most
    this long (None: the cameras share its time equally)."""

    cameras: int
    seconds: float
    size: tuple[int, int]
    scene: str
    look_alikes: int = 0
    stay_s: float | None = None
    starts_s: tuple[float, ...] | None = None
    fps: tuple[float, ...] = FPS_CYCLE

    def renderer(self):
        """The scene renderer for make_raw_project."""
        render = _scenes()[self.scene]
        return functools.partial(render, look_alikes=self.look_alikes) if self.look_alikes else render

    def spec(self) -> RawProjectSpec:
        """Cameras at FPS_CYCLE rates; each video ``seconds`` long; see the class docstring for when they record."""
        lines, n_frames = [], []
        for k in range(self.cameras):
            fps = self.fps[k % len(self.fps)]
            alpha = fps / TARGET_RATE
            n = int(round(self.seconds * fps))
            if self.starts_s is not None:
                lines.append((alpha, -fps * self.starts_s[k % len(self.starts_s)]))
            else:
                lines.append((alpha, -alpha * (k * self.seconds * TARGET_RATE) + 0.1 * n))
            n_frames.append(n)
        window = self.stay_s * TARGET_RATE if self.stay_s is not None else None
        return RawProjectSpec(
            lines=tuple(lines),
            n_frames=tuple(n_frames),
            image_size=self.size,
            target_rate=TARGET_RATE,
            boards=8,
            gcps=8,
            window_samples=window,
        )


# Named workloads (--workload): the long recording of issue 26 (the target in view about 12 % of each video, look-alikes
# all the time) and the short 720p project in which it is in view in a third of the frames.
WORKLOADS = {
    "long-recording": Workload(
        cameras=3,
        seconds=540.0,
        size=(1280, 720),
        scene="long",
        look_alikes=6,
        stay_s=65.0,
        starts_s=(-20.0, 15.0, 40.0),
    ),
    "short-720p": Workload(
        cameras=3,
        seconds=80.0,
        size=(1280, 720),
        scene="long",
        look_alikes=6,
        starts_s=(0.0, 2.0, 4.0),
        fps=(30.0, 25.0, 15.0),
    ),
}


QUICK = Workload(cameras=2, seconds=10.0, size=(320, 240), scene="textured")


def make_project(workload: Workload, folder: Path) -> tuple[Path, float]:
    """The raw project in ``folder`` (reused when it was made for the same workload); returns (project.toml, seconds
    spent making it).
    """
    marker = folder / "workload.json"
    wanted = json.dumps(asdict(workload), sort_keys=True)
    project = folder / "project.toml"
    if project.exists() and marker.exists() and marker.read_text() == wanted:
        return project, 0.0
    if folder.exists():
        shutil.rmtree(folder)
    start = time.perf_counter()
    _, scene = make_raw_project(folder, workload.spec(), render=workload.renderer())
    (folder / INIT_BOXES).write_text(json.dumps(init_boxes(scene, workload.size, workload.size[0] / 160)))
    marker.write_text(wanted)
    return project, time.perf_counter() - start


INIT_BOXES = "init_boxes.json"  # per camera, CSRT's start among look-alikes: [init_frame, [x, y, w, h]]


def init_boxes(scene, size: tuple[int, int], radius: float) -> dict[str, list]:
    """Per camera, a box (pixels, top-left corner and size) around the target in the first frame where the whole box is
    in view, and that 0-based frame.
    """
    out = {}
    side = 2.5 * radius
    for name, track in scene.tracks.items():
        inside = np.all((track.xy >= side) & (track.xy <= np.array(size) - 1 - side), axis=1)
        k = int(np.argmax(inside))
        x, y = track.xy[k]
        out[name] = [
            int(track.frame[k]),
            [round(x - side / 2, 1), round(y - side / 2, 1), round(side, 1), round(side, 1)],
        ]
    return out


def decode_luma(path: str) -> tuple[int, float]:
    """Decode every frame of ``path`` to its luma plane (a numpy view of the decoder's buffer, as the trackers get it);
    (frames, CPU s of this process, FFmpeg's threads included)."""
    import av
    import numpy as np

    cpu = time.process_time()
    n = 0
    with av.open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        for frame in container.decode(stream):
            plane = frame.planes[0]
            np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)[: frame.height, : frame.width]
            n += 1
    return n, time.process_time() - cpu


def _warm_up(_: int) -> None:
    """Import what decoding needs, so that the timed part is decoding only."""
    import av  # noqa: F401
    import numpy  # noqa: F401

    time.sleep(0.2)  # long enough for every worker to get one


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


@dataclass
class Measure:
    wall: float
    cpu: float
    load: tuple[float, float]  # 1-minute load average before and after
    peak_mb: float = 0.0
    notes: list[str] = field(default_factory=list)

    def utilisation(self, cores: int) -> float:
        return self.cpu / (self.wall * cores)


def decode_floor(videos: list[Path], jobs: int) -> tuple[Measure, int]:
    """Decode all videos, ``jobs`` processes (started beforehand), largest files first; (measure, frames decoded).

    The CPU time is the decoding's only (the workers' start-up is not counted).
    """
    order = sorted(videos, key=lambda p: p.stat().st_size, reverse=True)
    with cf.ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        list(pool.map(_warm_up, range(jobs)))
        load, start = os.getloadavg()[0], time.perf_counter()
        done = list(pool.map(decode_luma, [str(p) for p in order]))
        wall = time.perf_counter() - start
    return Measure(wall, sum(cpu for _, cpu in done), (load, os.getloadavg()[0])), sum(n for n, _ in done)


def child_env(code: Path, pycache: Path | None) -> dict[str, str]:
    """The environment of a run of the source tree ``code``: with ``pycache``, its bytecode cached there (as an
    installed package has it compiled: PYTHONDONTWRITEBYTECODE dropped) instead of compiled in every process."""
    env = dict(os.environ, PYTHONPATH=str(code))
    if pycache is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(pycache)
    return env


# What a run's processes import, and the blob detector's compiled passes on a keyframe of the video in argv[1].
_FIRST_RUN = """
import importlib, sys
import tlsync_pipeline.cli.main
from tlsync_pipeline.pipeline.graph import worker_modules
for module in worker_modules():
    importlib.import_module(module)
from trackers.tracking import detect_keyframe_movers
detect_keyframe_movers(sys.argv[1], indices=[0])
"""


def prepare_trees(trees: list[Path], pycache: Path | None, video: Path) -> None:
    """Before the timed runs, leave each source tree as an installed package is after its first run: its modules and
    the libraries a run imports compiled into ``pycache`` (None: left to every process), the blob detector's passes
    in numba's cache (beside the tree's sources) for ``video``'s frames. Else the first run of a session pays for
    them (a few seconds of CPU), whichever tree runs first."""
    for code in trees:
        env = child_env(code, pycache)
        if pycache is not None:
            subprocess.run([sys.executable, "-m", "compileall", "-q", str(code)], env=env, check=True, cwd=code)
        subprocess.run([sys.executable, "-c", _FIRST_RUN, str(video)], env=env, check=True, cwd=code)


def tlsync_run(project: Path, work: Path, jobs: int, code: Path = REPOSITORY, pycache: Path | None = None) -> Measure:
    """`tlsync run` of the source tree ``code`` in a child process; CPU time and peak RSS of it and its workers.

    pycache: where the tree's bytecode is cached (None: every process compiles what it imports, as under
    PYTHONDONTWRITEBYTECODE)."""
    # The run reports its own peak: this process's RUSAGE_CHILDREN keeps the largest child it ever had (the
    # project's renderers and the floor's decoders included), and a child's own ru_maxrss starts at its parent's
    # RSS when it was forked, so the run's process reads its high-water mark from /proc (VmHWM: this program only)
    # (bench/_memory.py) and takes its workers' from RUSAGE_CHILDREN (forked from it, so never above its own peak).
    report_peak = (
        "import atexit, resource; atexit.register(lambda: print('peak-rss-mb', max(peak_rss_mb(), "
        "resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024), file=sys.stderr))"
    )
    command = [
        sys.executable,
        "-c",
        f"import sys\n{inspect.getsource(peak_rss_mb)}{report_peak}\nfrom tlsync_pipeline.cli.main import "
        f"main\nsys.exit(main())",
        "run",
        str(project),
        "--work",
        str(work),
        "--quiet",
        "--jobs",
        str(jobs),
    ]
    env = child_env(code, pycache)
    load = os.getloadavg()[0]
    cpu, start = _children_cpu(), time.perf_counter()
    done = subprocess.run(
        command, capture_output=True, text=True, env=env, cwd=code
    )  # "-c" puts the working folder first on sys.path
    wall = time.perf_counter() - start
    if done.returncode not in (0, 1):  # 1: ran through, some camera not synchronized
        raise SystemExit(f"tlsync run failed (exit {done.returncode}):\n{done.stdout}\n{done.stderr}")
    peak = max(
        (float(line.split()[1]) for line in done.stderr.splitlines() if line.startswith("peak-rss-mb ")), default=0.0
    )
    missed = [line for line in done.stdout.splitlines() if line.startswith("not synchronized")]
    return Measure(
        wall,
        _children_cpu() - cpu,
        (load, os.getloadavg()[0]),
        peak,
        missed + [worst_error(project.parent, work), frames_decoded(work)],
    )


def frames_decoded(work: Path) -> str:
    """What the run decoded, from timeline.json's per-camera ``scan``: keyframes and frames against
    the videos' frames.
    """
    timeline_file = work / "timeline.json"
    if not timeline_file.exists():
        return "frames decoded: no timeline.json"
    scans = {name: line.scan for name, line in read_timeline(timeline_file).cameras.items() if line.scan is not None}
    if not scans:
        return "frames decoded: not recorded"
    frames = sum(s.frames for s in scans.values())
    keys, decoded = sum(s.keyframes_decoded for s in scans.values()), sum(s.frames_decoded for s in scans.values())
    full = [f"{name} ({s.reason})" for name, s in scans.items() if s.mode == "full"]
    return f"decoded {keys} keyframes + {decoded} frames = {(keys + decoded) / frames:.1%} of {frames} frames" + (
        f"; every frame: {', '.join(full)}" if full else ""
    )


def against_run(work: Path, reference: Path, n_frames: dict[str, int], what: str) -> str:
    """The worst pair of the run against another run of the same project (``what`` names it): eps_t, frames."""
    a_file, b_file = work / "timeline.json", reference / "timeline.json"
    if not (a_file.exists() and b_file.exists()):
        return f"against {what}: a timeline is missing"
    run, other = read_timeline(a_file), read_timeline(b_file)
    names = [n for n in other.names if n in run.names]
    errors = {
        f"{a}->{b}": eps_t(run.relation(a, b), other.relation(a, b), n_frames[a])
        for a in names
        for b in names
        if a != b
    }
    if not errors:
        return f"against {what}: no pair in both"
    key = max(errors, key=errors.get)
    return f"against {what}: worst eps_t {errors[key]:.4f} frame ({key}; {len(errors)} pairs)"


def worst_error(folder: Path, work: Path) -> str:
    """The run's worst pair against the project's truth.json: eps_t (eq. 5), frames."""
    timeline_file = work / "timeline.json"
    if not timeline_file.exists():
        return "no timeline.json: nothing synchronized"
    timeline = read_timeline(timeline_file)
    truth, n_frames = read_truth(folder / "truth.json")
    errors = {
        key: eps_t(timeline.relation(*key.split("->")), rel, n_frames[key.split("->")[0]])
        for key, rel in truth.items()
        if set(key.split("->")) <= set(timeline.names)
    }
    if not errors:
        return "no pair synchronized"
    key = max(errors, key=errors.get)
    return f"worst eps_t {errors[key]:.3f} frame ({key}; {len(errors)} of {len(truth)} pairs)"


def stage_seconds(work: Path) -> dict[str, tuple[float, float, int]]:
    """Per stage: the sums of its tasks' run seconds and CPU seconds as the manifests record them (CPU NaN when not
    recorded), and the number of tasks.
    """
    out: dict[str, tuple[float, float, int]] = {}
    for path in work.rglob("*.manifest.json"):
        manifest = json.loads(path.read_text())
        total, cpu, count = out.get(manifest["stage"], (0.0, 0.0, 0))
        cpu += float(manifest["cpu_seconds"]) if manifest.get("cpu_seconds") is not None else float("nan")
        out[manifest["stage"]] = (total + float(manifest.get("seconds") or 0.0), cpu, count + 1)
    return out


def with_tracker(project: Path, variant: str, folder: Path) -> Path:
    """A copy of project.toml (same folder, so relative paths hold) with every camera's tracker kind set.

    variant: the kind, or "<kind>-full" for ``[track] scan = "full"`` (every
    frame read, no coarse pass). CSRT, which follows one target from a box,
    starts from INIT_BOXES: the default tracker finds the target among the
    look-alikes by itself.
    """
    kind, _, scan = variant.partition("-")
    boxes = json.loads((folder / INIT_BOXES).read_text()) if kind == "csrt" and (folder / INIT_BOXES).exists() else {}
    blocks = project.read_text().split("[[cameras]]")
    for k, block in enumerate(blocks[1:], start=1):
        name = re.search(r'name = "([^"]+)"', block).group(1)
        start = f"\ninit = {boxes[name][1]}\ninit_frame = {boxes[name][0]}" if name in boxes else ""
        blocks[k] = re.sub(r'kind = "\w+"', lambda _, start=start: f'kind = "{kind}"{start}', block)
    text = "[[cameras]]".join(blocks) + (f'\n[track]\nscan = "{scan}"\n' if scan else "")
    out = folder / f"project_{variant}.toml"
    out.write_text(text)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="CI-size inputs (2 cameras, 320x240, 10 s)")
    parser.add_argument(
        "--workload",
        choices=sorted(WORKLOADS),
        help="a named workload (WORKLOADS) instead of --cameras, --seconds, --size, --scene, --look-alikes",
    )
    parser.add_argument("--cameras", type=int, default=4)
    parser.add_argument("--seconds", type=float, default=60.0, help="length of each camera's video")
    parser.add_argument("--size", default="1920x1080")
    parser.add_argument("--scene", default="long", choices=sorted(_scenes()))
    parser.add_argument(
        "--look-alikes", type=int, default=6, help="discs like the target wandering each view (scene 'long')"
    )
    parser.add_argument(
        "--trackers",
        default="blob,blob-full,csrt",
        help='tracker kinds; "<kind>-full": with [track] scan = "full" (every frame read), the reference of the runs '
        "of that kind",
    )
    parser.add_argument("--keep", type=Path, help="make (or reuse) the project in this folder")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument(
        "--compare",
        type=Path,
        help="also run the tlsync of this source tree (e.g. a `git archive` of main), for before/after in one session",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=1,
        help="rounds of the floor and a fresh run of each tracker, in turn (ratios and their median)",
    )
    parser.add_argument(
        "--no-bytecode-cache",
        action="store_true",
        help="let every process of a run compile the tree's modules (the environment's PYTHONDONTWRITEBYTECODE) "
        "instead of caching their bytecode as an installed package has it",
    )
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    if args.quick:
        workload = QUICK
    elif args.workload:
        workload = WORKLOADS[args.workload]
    else:
        workload = Workload(
            args.cameras, args.seconds, (width, height), args.scene, args.look_alikes if args.scene == "long" else 0
        )
    cores = args.jobs
    with tempfile.TemporaryDirectory(prefix="tlsync-throughput-") as tmp:
        folder = args.keep or Path(tmp) / "project"
        print(f"machine: {os.cpu_count()} cores, {_cpu_model()}; {cores} processes; load average at start {_load()}")
        project, made = make_project(workload, folder)
        videos = sorted(folder.glob("*/video.mp4"))
        minutes = sum(_duration(v) for v in videos) / 60
        print(
            f"project: {workload.cameras} cameras, {workload.size[0]}x{workload.size[1]}, {minutes:.1f} min of video, "
            f"scene {workload.scene!r}, {workload.look_alikes} look-alikes"
            + (f", made in {made:.0f} s" if made else ", reused")
        )
        floor, frames = decode_floor(videos, cores)
        print(
            f"decode floor: {frames} frames in {floor.wall:.1f} s wall, {floor.cpu:.1f} s CPU "
            f"({floor.utilisation(cores):.0%} of {cores} cores), load {floor.load[0]:.1f} -> {floor.load[1]:.1f}"
        )
        rows = [(f"decode floor (PyAV luma, {cores} processes)", floor, None)]
        stages = {}
        trees = [("", REPOSITORY)] + ([(f" ({args.compare.name})", args.compare)] if args.compare else [])
        pycache = None if args.no_bytecode_cache else Path(tmp) / "pycache"
        prepare_trees([code for _, code in trees], pycache, videos[0])
        print(
            "bytecode: "
            + ("compiled in every process (--no-bytecode-cache)" if pycache is None else f"cached in {pycache}")
        )
        for kind in args.trackers.split(","):
            variant = with_tracker(project, kind, folder)
            for suffix, code in trees if not kind.endswith("-full") else trees[:1]:
                work = Path(tmp) / f"work_{kind}{suffix.strip(' ()')}"
                run = tlsync_run(variant, work, cores, code, pycache)
                stages[kind + suffix] = stage_seconds(work)
                again = tlsync_run(variant, work, cores, code, pycache)
                rows += [(f"tlsync run, {kind}{suffix}", run, kind), (f"cached re-run, {kind}{suffix}", again, None)]
        n_frames = {name: int(v) for name, v in json.loads((folder / "truth.json").read_text())["n_frames"].items()}
        for name, measure, kind in rows:
            if kind and not kind.endswith("-full") and (Path(tmp) / f"work_{kind}-full").exists():
                measure.notes.append(
                    against_run(
                        Path(tmp) / f"work_{kind}",
                        Path(tmp) / f"work_{kind}-full",
                        n_frames,
                        "the full pass (every frame read)",
                    )
                )
            if kind and args.compare and name.endswith(f"{kind}{trees[-1][0]}"):
                measure.notes.append(
                    against_run(
                        Path(tmp) / f"work_{kind}",
                        Path(tmp) / f"work_{kind}{trees[-1][0].strip(' ()')}",
                        n_frames,
                        f"this tree's run (--compare {args.compare.name})",
                    )
                )
        ratios = {name: [(m.wall / floor.wall, m.cpu / floor.cpu)] for name, m, kind in rows if kind}
        for round_ in range(2, args.rounds + 1):
            again_floor, _ = decode_floor(videos, cores)
            for kind in [k for k in args.trackers.split(",") if not k.endswith("-full")]:
                for suffix, code in trees:
                    work = Path(tmp) / f"work_{kind}{suffix.strip(' ()')}_{round_}"
                    run = tlsync_run(folder / f"project_{kind}.toml", work, cores, code, pycache)
                    shutil.rmtree(work, ignore_errors=True)
                    ratios[f"tlsync run, {kind}{suffix}"].append(
                        (run.wall / again_floor.wall, run.cpu / again_floor.cpu)
                    )
                    print(
                        f"round {round_}: {kind}{suffix} {run.wall / again_floor.wall:.2f}x wall, "
                        f"{run.cpu / again_floor.cpu:.2f}x CPU (floor {again_floor.wall:.1f} s wall, "
                        f"{again_floor.cpu:.1f} s CPU); {'; '.join(run.notes[-2:])}",
                        flush=True,
                    )
        print(
            f"\n{'':38} {'wall s':>7} {'x floor':>7} {'CPU s':>7} {'x floor':>7} {'CPU use':>7} {'peak MB':>7} "
            f"{'load':>10}"
        )
        for name, m, _ in rows:
            peak = f"{m.peak_mb:7.0f}" if m.peak_mb else " " * 7
            print(
                f"{name:38} {m.wall:7.1f} {m.wall / floor.wall:7.2f} {m.cpu:7.1f} {m.cpu / floor.cpu:7.2f} "
                f"{m.utilisation(cores):7.0%} {peak} {m.load[0]:4.1f}->{m.load[1]:<4.1f}"
            )
            for note in m.notes:
                print(f"    {note}")
        for kind, per_stage in stages.items():
            print(
                f"\nstages, {kind} (sums over the stage's tasks as the manifests record them; x floor: of the floor's "
                f"wall and CPU):"
            )
            for stage in [s for s in STAGES if s in per_stage]:
                seconds, cpu, count = per_stage[stage]
                print(
                    f"  {stage:10} {seconds:7.1f} s {seconds / floor.wall:6.2f}x  CPU {cpu:7.1f} s "
                    f"{cpu / floor.cpu:6.2f}x  CPU/run {cpu / seconds if seconds else float('nan'):5.2f}  ({count} "
                    f"task{'s' if count > 1 else ''})"
                )
        if args.rounds > 1:
            print(
                f"\nx floor over {args.rounds} rounds (each run against its round's floor), wall | CPU, and their "
                f"medians:"
            )
            for name, values in ratios.items():
                walls, cpus = (sorted(v[k] for v in values) for k in (0, 1))
                print(
                    f"  {name:30} {' '.join(f'{w:.2f}' for w, _ in values)} -> {walls[len(walls) // 2]:.2f}  |  "
                    f"{' '.join(f'{c:.2f}' for _, c in values)} -> {cpus[len(cpus) // 2]:.2f}"
                )
        print(f"\nload average at the end {_load()}")


def _duration(path: Path) -> float:
    from trackers.video import probe_video

    info = probe_video(path)
    return info.n_frames / info.fps if info.fps else 0.0


def _load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


if __name__ == "__main__":
    main()
