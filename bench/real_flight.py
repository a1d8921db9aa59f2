"""Both methods on the real drone flight (../shared/real/drone2), eps_t per pair.

The truth (truth.json) holds each pair's fitted relation; eps_t (eq. 5) is
taken over the first camera's frames. For the refined method the table also
gives the 95 % interval half-width of the pair's beta and whether it covers
the truth. Writes the table and docs/real_flight.png into docs/accuracy.md;
skips cleanly when the folder is absent.

    python bench/real_flight.py [--data /work/shared/real/drone2] [--no-write] [--movers N]

--movers N: the tracks handed to identification instead, as every mover's
detections (each track cut into 5 tracklets) among N synthetic movers per
camera (straight walks at the drone's image speed, 100-400 frames each);
prints the refined method's median and max eps_t per seed, writes nothing.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from tlsync_pipeline.pipeline.project import load_project
from tlsync_pipeline.pipeline.stages.sync import load_inputs
from tlsync_pipeline.sync.solve.synchronize import synchronize
from tlsync_pipeline.sync.timeline import eps_t, read_truth

DEFAULT = Path("/work/shared/real/drone2")
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "real_flight.png"
Z95 = 1.959964


def evaluate(data: Path) -> tuple[str, dict]:
    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    errors, rows, seconds = {}, [], {}
    timelines = {}
    for method in ("paper", "refined"):
        start = time.perf_counter()
        params = dataclasses.replace(project.sync, method=method)
        timelines[method], _ = synchronize(cameras, trajectory, params)
        seconds[method] = time.perf_counter() - start
        errors[method] = {
            key: eps_t(timelines[method].relation(*key.split("->")), rel, n_frames.get(key.split("->")[0]) or 1)
            for key, rel in truth.items()
        }
    refined = timelines["refined"]
    covered = 0
    for key, rel in truth.items():
        a, b = key.split("->")
        half = Z95 * float(np.sqrt(refined.relation_cov(a, b)[1, 1]))
        inside = abs(refined.relation(a, b).beta - rel.beta) <= half
        covered += inside
        rows.append(
            f"| {key} | {errors['paper'][key]:.3f} | {errors['refined'][key]:.3f} | ±{half:.2f} | "
            f"{'yes' if inside else 'no'} |"
        )
    p, r = np.array(list(errors["paper"].values())), np.array(list(errors["refined"].values()))
    text = "\n".join(
        [
            f"Project {data} ({len(cameras)} cameras, {len(trajectory)} trajectory samples at {trajectory.rate:g} Hz); "
            f"paper {seconds['paper']:.1f} s, refined {seconds['refined']:.1f} s.",
            "",
            "| pair | paper eps_t | refined eps_t | refined 95 % interval of beta | covers truth |",
            "|---|---|---|---|---|",
            *rows,
            f"| **median** | **{np.median(p):.3f}** | **{np.median(r):.3f}** | | {covered}/{len(truth)} |",
            f"| max | {p.max():.3f} | {r.max():.3f} | | |",
        ]
    )
    return text, errors


def among_movers(data: Path, movers: int, seeds: int = 3) -> None:
    """The refined method with each camera's target identified among its track's tracklets and ``movers`` synthetic
    movers.
    """
    from tlsync_pipeline.sync.solve.synchronize import CameraInput
    from trackers.detections import make_detections

    project = load_project(data / "project.toml")
    cameras, trajectory = load_inputs(project)
    truth, n_frames = read_truth(data / "truth.json")
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        inputs = {}
        for name, given in cameras.items():
            track = given.track
            rows = [
                (
                    int(track.frame[i]),
                    float("nan"),
                    k,
                    float(track.x[i]),
                    float(track.y[i]),
                    float("nan"),
                    float("nan"),
                    1.0,
                )
                for k, idx in enumerate(np.array_split(np.arange(len(track)), 5))
                for i in idx
            ]
            width, height = given.camera.image_size
            speed = float(np.median(np.linalg.norm(np.diff(track.xy, axis=0), axis=1)))
            last = int(track.frame.max())
            for j in range(movers):
                start, length = int(rng.integers(0, max(1, last - 100))), int(rng.integers(100, 400))
                p0, heading = rng.uniform([0, 0], [width, height]), rng.uniform(0, 2 * np.pi)
                v = speed * rng.uniform(0.7, 1.3) * np.array([np.cos(heading), np.sin(heading)])
                for f in range(start, min(last + 1, start + length)):
                    x, y = p0 + v * (f - start)
                    if 0 <= x < width and 0 <= y < height:
                        rows.append((f, float("nan"), 100 + j, float(x), float(y), float("nan"), float("nan"), 1.0))
            rows.sort(key=lambda r: (r[0], r[2]))
            inputs[name] = CameraInput(given.camera, None, given.fps, make_detections(rows))
        timeline, results = synchronize(inputs, trajectory, project.sync)
        if timeline.failed:
            print(f"seed {seed}: not synchronized: {timeline.failed}")
            continue
        errors = np.array(
            [
                eps_t(timeline.relation(*key.split("->")), rel, n_frames.get(key.split("->")[0]) or 1)
                for key, rel in truth.items()
            ]
        )
        kept = ", ".join(f"{n} {len(r.identification.track)}/{len(cameras[n].track)}" for n, r in results.items())
        print(
            f"seed {seed}, {movers} movers per camera: median eps_t {np.median(errors):.3f}, max {errors.max():.3f}; "
            f"identified frames {kept}"
        )


def plot(errors: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = list(errors["paper"])
    x = np.arange(len(keys))
    fig, ax = plt.subplots(figsize=(10, 3.5))
    ax.bar(x - 0.2, [errors["paper"][k] for k in keys], 0.4, label="paper")
    ax.bar(x + 0.2, [errors["refined"][k] for k in keys], 0.4, label="refined")
    ax.set_xticks(x, keys, rotation=45, ha="right", fontsize=8)
    ax.set_ylabel("eps_t (frames)")
    ax.set_title("real flight drone2: eps_t per pair")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/ alone")
    parser.add_argument(
        "--movers",
        type=int,
        default=None,
        metavar="N",
        help="identify each camera's target among its track's tracklets and N synthetic movers",
    )
    args = parser.parse_args()
    if not (args.data / "project.toml").exists():
        print(f"skipped: {args.data} not found")
        sys.exit(0)
    if args.movers is not None:
        among_movers(args.data, args.movers)
        return
    text, errors = evaluate(args.data)
    print(text)
    if not args.no_write:
        from _report import write_block

        plot(errors, FIGURE)
        write_block("real_flight", text + f"\n\n![real flight]({FIGURE.name})")


if __name__ == "__main__":
    main()
