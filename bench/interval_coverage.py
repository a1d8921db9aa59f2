"""Coverage of the refined method's 95 % intervals on seeded synthetic scenes.

For each scene (two cameras, fractional betas) and each estimated quantity
(every camera's alpha and beta, every pair's beta = start offset, and every
camera's clock at the middle of the target's visit, where its evidence is),
z = (estimate - truth) / standard error; a nominal 95 % interval covers the
truth when |z| <= 1.96. Prints the coverage per quantity and overall (over
alpha, beta and the pairs' betas), the middle's apart, and the variance factor
that would give exactly 95 % (to re-calibrate [sync] model_error_px).

    nice -n 10 python bench/interval_coverage.py --scenes 200 --st 2 --sc 2 --sl 1 [--fps-unknown]
"""

from __future__ import annotations

import argparse
import multiprocessing

import numpy as np

from data_fixtures import make_scene
from tlsync_pipeline.sync.model.methods import RefinedParams
from tlsync_pipeline.sync.model.params import SyncParams
from tlsync_pipeline.sync.solve.synchronize import CameraInput, synchronize

LINES = ((2.0, 4.37), (2.0, 45.61))
Z95 = 1.959964


def scene_z(args) -> list[float]:
    """|z| of every quantity of one scene (NaN when the camera failed)."""
    seed, st, sc, sl, model_error, fps_known = args
    scene = make_scene(seed, lines=LINES, tracking_noise_px=st, projection_error_px=sc, localisation_noise_pct=sl)
    inputs = {
        k: CameraInput(scene.cameras[k], scene.tracks[k], scene.cameras[k].fps if fps_known else None)
        for k in scene.cameras
    }
    params = (
        SyncParams()
        if model_error is None
        else SyncParams(options={"refined": RefinedParams(model_error_px=model_error)})
    )
    timeline, _ = synchronize(inputs, scene.trajectory, params)
    z = []
    middles = []
    for name, true in scene.lines.items():
        line = timeline.cameras.get(name)
        if line is None:
            z += [np.nan, np.nan]
            middles.append(np.nan)
            continue
        z += [(line.alpha - true.alpha) / line.se_alpha, (line.beta - true.beta) / line.se_beta]
        middle = (float(np.median(scene.tracks[name].frame)) - true.beta) / true.alpha  # sample
        at = np.array([middle, 1.0])
        middles.append(((line.alpha - true.alpha) * middle + line.beta - true.beta) / np.sqrt(at @ line.cov @ at))
    for key, true in scene.truth_pairs().items():
        a, b = key.split("->")
        if a in timeline.cameras and b in timeline.cameras:
            z.append((timeline.relation(a, b).beta - true.beta) / np.sqrt(timeline.relation_cov(a, b)[1, 1]))
        else:
            z.append(np.nan)
    return z + middles


def coverage(
    scenes: int,
    st: float,
    sc: float,
    sl: float,
    model_error: float | None = None,
    first_seed: int = 1000,
    processes: int = 2,
    fps_known: bool = True,
) -> dict:
    """Coverage per quantity and overall, and the variance factor for exactly 95 %.

    model_error: [sync] model_error_px (None: the default); fps_known: the cameras' frame rates given (their slope
    prior; exact in these scenes, whose fps are the true rates) or not (the slope from the track alone).
    """
    jobs = [(first_seed + k, st, sc, sl, model_error, fps_known) for k in range(scenes)]
    with multiprocessing.Pool(processes) as pool:
        z = np.abs(np.array(pool.map(scene_z, jobs, chunksize=4)))
    names = [f"{n} {q}" for n in ("cam0", "cam1") for q in ("alpha", "beta")] + ["cam0->cam1 beta", "cam1->cam0 beta"]
    names += ["cam0 middle", "cam1 middle"]
    finite = np.isfinite(z)
    lines, middles = z[:, :6], z[:, 6:]
    return {
        "per_quantity": {n: float(np.mean(z[finite[:, k], k] <= Z95)) for k, n in enumerate(names)},
        "overall": float(np.mean(lines[finite[:, :6]] <= Z95)),
        "factor_for_95": float((np.quantile(lines[finite[:, :6]], 0.95) / Z95) ** 2),
        "middle": float(np.mean(middles[finite[:, 6:]] <= Z95)),
        "middle_factor_for_95": float((np.quantile(middles[finite[:, 6:]], 0.95) / Z95) ** 2),
        "failed": int((~finite).any(axis=1).sum()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=200)
    parser.add_argument("--st", type=float, default=2.0, help="tracking noise S_t (px)")
    parser.add_argument("--sc", type=float, default=2.0, help="projection error S_c (px)")
    parser.add_argument("--sl", type=float, default=1.0, help="localisation noise S_l (%% of the field of view)")
    parser.add_argument(
        "--model-error", type=float, default=None, help="[sync] model_error_px (default: the project default)"
    )
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument(
        "--fps-unknown",
        action="store_true",
        help="cameras without a frame rate: no slope prior (the scenes' fps are the true rates, a prior exact by "
        "construction, which the intervals take as uncertain as a real clock's)",
    )
    args = parser.parse_args()
    result = coverage(
        args.scenes,
        args.st,
        args.sc,
        args.sl,
        args.model_error,
        processes=args.processes,
        fps_known=not args.fps_unknown,
    )
    model = RefinedParams().model_error_px if args.model_error is None else args.model_error
    print(
        f"S_t={args.st} S_c={args.sc} S_l={args.sl} model_error_px={model:g} scenes={args.scenes} (failed "
        f"{result['failed']}){' fps unknown' if args.fps_unknown else ''}"
    )
    for name, value in result["per_quantity"].items():
        print(f"  {name:16s} {100 * value:5.1f} %")
    print(
        f"  overall          {100 * result['overall']:5.1f} %   (variance factor for exactly 95 %: "
        f"x{result['factor_for_95']:.2f} of the current)"
    )
    print(f"  middles          {100 * result['middle']:5.1f} %   (x{result['middle_factor_for_95']:.2f})")


if __name__ == "__main__":
    main()
