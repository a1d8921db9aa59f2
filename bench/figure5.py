"""The paper's Section 4.2 sweep (Figure 5), both methods on the same scenes.

Each noise source (S_t tracking px, S_c projection px, S_l localisation %
of the field of view) goes from 1 to 10 with the other two at the fixed
values S_t = 2 px, S_c = 2 px, S_l = 1 %; 100 scenes per point. A scene has
two cameras with random lines: alpha uniform in [1.6, 2.4] (so camera fps
is not a multiple of the trajectory rate) and a fractional beta uniform in
[0, 50], so that votes do not sit on the frame lattice. For every run the
worst eps_t over the scene's two pairs is kept, over the lines each method
fitted whatever their status (the methods' accuracy); apart, the share of
runs where the plausibility checks left a camera not synchronized
("refused"), and where a synchronized pair is more than 5 frames off (a
confident wrong answer). Writes the table (percentage
of runs with eps_t <= 1 and <= 5 frames, median eps_t) and the plot
(docs/figure5.png) into docs/accuracy.md. Multiprocessing over --processes
cores (2 by default).

    nice -n 10 python bench/figure5.py            # full sweep
    python bench/figure5.py --scenes 5 --no-write # smoke run
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import time
from pathlib import Path

import numpy as np

from data_fixtures import make_scene
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize
from tlsync_pipeline.sync.timeline import eps_t

FIXED = {"S_t": 2.0, "S_c": 2.0, "S_l": 1.0}
WRONG = 5.0  # frames: a synchronized pair further off is a confident wrong answer
LEVELS = range(1, 11)
METHODS = ("paper", "refined")
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figure5.png"


def scene_for(seed: int, st: float, sc: float, sl: float):
    """The seeded scene of one run (lines drawn from the seed)."""
    rng = np.random.default_rng(seed)
    lines = tuple((float(rng.uniform(1.6, 2.4)), float(rng.uniform(0, 50))) for _ in range(2))
    return make_scene(seed, lines=lines, tracking_noise_px=st, projection_error_px=sc, localisation_noise_pct=sl)


def run_one(job) -> tuple[str, int, int, dict[str, tuple[float, bool, bool]]]:
    """Per method: the worst eps_t of its fitted lines (inf when a camera has none), whether the checks refused a
    camera, whether a synchronized pair is more than WRONG frames off."""
    varied, level, seed = job
    noise = dict(FIXED, **{varied: float(level)})
    scene = scene_for(seed, noise["S_t"], noise["S_c"], noise["S_l"])
    inputs = {k: CameraInput(scene.cameras[k], scene.tracks[k], scene.cameras[k].fps) for k in scene.cameras}
    out = {}
    for method in METHODS:
        timeline, _ = synchronize(inputs, scene.trajectory, SyncParams(method=method))
        fitted = dataclasses.replace(timeline, cameras={**timeline.cameras, **timeline.rejected})
        errors = {
            k: eps_t(fitted.relation(*k.split("->")), true, scene.n_frames[k.split("->")[0]])
            for k, true in scene.truth_pairs().items()
            if set(k.split("->")) <= set(fitted.cameras)
        }
        worst = max(errors.values()) if len(errors) == len(scene.truth_pairs()) else float("inf")
        wrong = any(e > WRONG and set(k.split("->")) <= set(timeline.cameras) for k, e in errors.items())
        out[method] = (worst, bool(timeline.rejected), wrong)
    return varied, level, seed, out


def sweep(scenes: int, processes: int) -> dict:
    """results[varied][level][method] = (runs, 3) array: worst eps_t, refused (0/1), wrong and synchronized (0/1)."""
    jobs = [
        (varied, level, 10_000 * (i + 1) + 100 * level + k)
        for i, varied in enumerate(FIXED)
        for level in LEVELS
        for k in range(scenes)
    ]
    results: dict = {v: {lv: {m: [] for m in METHODS} for lv in LEVELS} for v in FIXED}
    with multiprocessing.Pool(processes) as pool:
        for varied, level, _, outcome in pool.imap_unordered(run_one, jobs, chunksize=4):
            for method, value in outcome.items():
                results[varied][level][method].append(value)
    return {
        v: {lv: {m: np.array(x, dtype=float).reshape(-1, 3) for m, x in d.items()} for lv, d in levels.items()}
        for v, levels in results.items()
    }


def table(results: dict, scenes: int, seconds: float) -> str:
    units = {"S_t": "px", "S_c": "px", "S_l": "%"}
    lines = [
        f"{scenes} scenes per point, fixed values S_t = {FIXED['S_t']:g} px, S_c = {FIXED['S_c']:g} px, S_l = "
        f"{FIXED['S_l']:g} %; "
        f"worst eps_t of the two pairs per scene; {seconds / 60:.1f} min on this machine.",
        "",
        "| varied | level | paper <= 1 | refined <= 1 | paper <= 5 | refined <= 5 | paper median | refined median | "
        "refused: paper / refined | wrong, synchronized: paper / refined |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for varied, levels in results.items():
        for level, r in levels.items():
            p, f = r["paper"][:, 0], r["refined"][:, 0]
            lines.append(
                f"| {varied} | {level} {units[varied]} | {100 * np.mean(p <= 1):.0f} % | {100 * np.mean(f <= 1):.0f} "
                f"% | "
                f"{100 * np.mean(p <= 5):.0f} % | {100 * np.mean(f <= 5):.0f} % | {np.median(p):.3f} | "
                f"{np.median(f):.3f} | "
                f"{100 * r['paper'][:, 1].mean():.0f} % / {100 * r['refined'][:, 1].mean():.0f} % | "
                f"{100 * r['paper'][:, 2].mean():.0f} % / {100 * r['refined'][:, 2].mean():.0f} % |"
            )
    return "\n".join(lines)


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5), sharex=True)
    for col, (varied, levels) in enumerate(results.items()):
        x = list(levels)
        for method, style in (("paper", "o-"), ("refined", "s-")):
            within = [100 * np.mean(levels[lv][method][:, 0] <= 1) for lv in x]
            within5 = [100 * np.mean(levels[lv][method][:, 0] <= 5) for lv in x]
            axes[0, col].plot(x, within, style, label=f"{method}, eps_t <= 1")
            axes[0, col].plot(x, within5, style, alpha=0.4, label=f"{method}, eps_t <= 5")
            axes[1, col].semilogy(x, [np.median(levels[lv][method][:, 0]) for lv in x], style, label=method)
        axes[0, col].set_title(f"varying {varied}")
        axes[0, col].set_ylim(0, 102)
        axes[1, col].set_xlabel(f"{varied} ({'%' if varied == 'S_l' else 'px'})")
    axes[0, 0].set_ylabel("% of runs")
    axes[1, 0].set_ylabel("median eps_t (frames)")
    axes[0, 0].legend(fontsize=7)
    axes[1, 0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100)
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--no-write", action="store_true", help="print only; leave docs/ alone")
    args = parser.parse_args()
    start = time.perf_counter()
    results = sweep(args.scenes, args.processes)
    text = table(results, args.scenes, time.perf_counter() - start)
    print(text)
    if not args.no_write:
        from _report import write_block

        plot(results, FIGURE)
        write_block("figure5", text + f"\n\n![Figure 5 sweep]({FIGURE.name})")


if __name__ == "__main__":
    main()
