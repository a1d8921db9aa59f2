"""What a contradicted camera's track says about the cause, so the message names the fix that works.

Pure functions of the cameras (``plausibility.Judged``) and the prepared
trajectory. Each hypothesis moves one input and asks whether the tracks then
lie on the projected path (``plausibility.path_share``: the path at any time,
so the timing plays no part), as plausibility's rescaled-unit tests do:

- heights: the log raised or lowered by dz metres. Within HEIGHT_NEAR_M of
  zero it is the logged point riding above (or below) the tracked one (a GPS
  antenna on a backpack or a drone's top): ``[sync] logged_point_above_m``;
  further, heights on another reference (mean sea level against the
  ellipsoid, tens of metres) or none in the log:
  ``[target] altitude_reference`` / ``altitude_offset_m``;
- an image offset: the track shifted by one constant (dx, dy) pixels (a
  tracker on the target's shadow, or on a point of its box other than the
  one the log describes);
- neither, and the track lies on the projected path nowhere: the tracker
  follows another object (or the pose is off), not a log that ends early;
  unless the log's fixes scatter as a consumer receiver's and the track lies
  on it within the radius such a receiver's metres of error span from this
  camera (the phone preset's, sync/model/log_model.py), the declared model's
  being narrower: then the log's error is larger than declared (a white-only
  model of a receiver that wanders), and declaring it is the fix.

Each camera's tracks are compared with the path within GATE_EPS times its
vote radius (the log's error as the camera sees it), as the checks do.

One height offset (of at least HEIGHT_MIN_M) that fits every contradicted
camera together is the cause of each (when every camera with a track is
contradicted: the log's, LogUnitError, bad input). Otherwise only the
tracks off the path (on it, at any time, in under ON_PATH_GIVEN of their
frames) are explained camera by camera: a track on the path has its timing
at fault.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy.spatial import cKDTree

from calibration.camera import Camera
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel
from tlsync_pipeline.sync.model.status import FAILED, Reason
from tlsync_pipeline.sync.solve.plausibility import GATE_EPS, Judged, LogUnitError, _fits_better, path_share
from tlsync_pipeline.sync.vote.log_error import vote_radius
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory

HEIGHT_NEAR_M = (
    5.0  # a height offset within this is the logged point above the tracked one, beyond it another reference
)
HEIGHT_STEPS_M = (
    0.5,
    0.75,
    1.0,
    1.25,
    1.5,
    2.0,
    2.5,
    3.0,
    4.0,
    5.0,
    7.0,
    10.0,
    15.0,
    20.0,
    25.0,
    30.0,
    35.0,
    40.0,
    45.0,
    50.0,
    55.0,
    60.0,
    70.0,
    80.0,
    90.0,
    100.0,
)  # |dz| tried (both signs), then refined between neighbours
HEIGHT_MIN_M = 0.4  # a height offset found under this is no cause
HEIGHT_FIT = 0.9  # share of the frames a height offset must put on the path (a crossing path fits some by chance)
ON_PATH_GIVEN = 0.5  # a track on the projected path (any time) in this share of its frames is not off it: its timing is
OFF_PATH_SHARE = 0.2  # a track on the projected path (any time) in fewer of its frames than this follows something else
OFFSET_ROUNDS = 6  # rounds of matching each tracked position to the nearest projected one to find a constant offset


def explain(
    judged: dict[str, Judged],
    prepared: Trajectory,
    eps_px: float,
    above_m: float = 0.0,
    radius_px: Mapping[str, float] | None = None,
    log_model: LogModel | None = None,
) -> dict[str, Reason]:
    """A reason per contradicted camera with a track whose cause one of the hypotheses (module notes) finds.

    above_m: the project's [sync] logged_point_above_m already applied to ``prepared``; radius_px: each camera's vote
    radius (pixels; eps_px for a camera without one); log_model: the log's error model the radii come from (None: an
    exact log). Raises LogUnitError when every camera with a track is contradicted and one height offset puts all their
    tracks on the path.
    """
    tracked = {n: j for n, j in judged.items() if j.track is not None and len(j.track) and j.camera.posed}
    contradicted = {n: j for n, j in tracked.items() if j.contradicted}
    if not contradicted:
        return {}
    gates = {n: GATE_EPS * max(eps_px, (radius_px or {}).get(n, eps_px)) for n in contradicted}
    path = PiecewiseTrajectory(prepared)
    given = {n: path_share(j.camera, _xy(j), path, gates[n]) for n, j in contradicted.items()}
    shared = _height_shift(contradicted, prepared, given, gates)  # one height for every contradicted camera
    if shared is not None and len(contradicted) == 1:  # one camera alone: a constant image offset may fit it better
        ((name, j),) = contradicted.items()
        gate = gates[name]
        offset = image_offset(j.camera, _xy(j), path, gate)
        if offset is not None and path_share(j.camera, _xy(j) - offset, path, gate) > shared[1] + 0.05:
            shared = None
    if shared is not None:
        dz, share = shared
        if len(contradicted) == len(tracked):
            raise LogUnitError(
                "z", f"{_height_text(dz, share, _mean(given), prepared)}; {_height_fix(dz, above_m, prepared)}"
            )
        text, fix = _height_text(dz, share, _mean(given), prepared), _height_fix(dz, above_m, prepared)
        return {n: Reason("log_height", FAILED, text, fix) for n in contradicted}
    failing = {n: j for n, j in contradicted.items() if given[n] < ON_PATH_GIVEN}  # on the path, the timing is at fault
    reasons = {}
    for name, j in failing.items():
        one, gate = {name: j}, gates[name]
        height = _height_shift(one, prepared, {name: given[name]}, {name: gate})
        offset = image_offset(j.camera, _xy(j), path, gate)
        moved = path_share(j.camera, _xy(j) - offset, path, gate) if offset is not None else 0.0
        if height is not None and height[1] >= moved - 0.05:
            dz, share = height
            reasons[name] = Reason(
                "log_height", FAILED, _height_text(dz, share, given[name], prepared), _height_fix(dz, above_m, prepared)
            )
        elif offset is not None and _fits_better(given[name], moved):
            dx, dy = offset
            reasons[name] = Reason(
                "track_offset",
                FAILED,
                f"the track lies {np.hypot(dx, dy):.0f} px (x {dx:+.0f}, y {dy:+.0f}) off the projected path "
                f"at every frame: moved back by that it lies on the path in {moved:.0%} of its frames, "
                f"as given in {given[name]:.0%}",
                "the tracker follows something beside the target (its shadow?) or a point of its box other than "
                "the logged one: track the target itself (give the tracker an init box), or set [sync] "
                "logged_point_above_m if the log rides above it",
            )
        elif _flat(prepared):
            reasons[name] = Reason(
                "log_flat",
                FAILED,
                f"the log's z is {prepared.xyz[0, 2]:g} m at every sample (a log without heights?)",
                "if the target does not move on level ground at that height: "
                "give a log with heights (GPX <ele>, a CSV alt column)",
            )
        elif given[name] < OFF_PATH_SHARE and (
            wider := _log_wider(j, path, eps_px, gate, given[name], prepared, log_model)
        ):
            reasons[name] = wider
        elif given[name] < OFF_PATH_SHARE:
            reasons[name] = Reason(
                "track_elsewhere",
                FAILED,
                f"the track lies on the projected path (at any time) in only {given[name]:.0%} of its frames: "
                "the tracker follows another object, or the camera's pose is off",
                "check the track (give the tracker an init box on the target) and the camera's pose (GCPs)",
            )
    return reasons


def _log_wider(
    judged: Judged,
    path: PiecewiseTrajectory,
    eps_px: float,
    gate_px: float,
    given: float,
    prepared: Trajectory,
    model: LogModel | None,
) -> Reason | None:
    """``log_error`` (FAILED) when the log's fixes scatter as a consumer receiver's (its model's white noise, measured
    or stated, at least the drone preset's) and the track lies on the projected path (any time) within the gate such a
    receiver's
    error spans from this camera (GATE_EPS x the phone preset's vote radius), in HEIGHT_FIT of its frames and clearly
    better than within the gate the declared model gave (``gate_px``, where it lies on it in ``given`` of its frames;
    plausibility._fits_better), that gate being narrower: the log's error is larger than its model says, and a tracker
    on another object would not follow the logged path's shape. None otherwise."""
    if model is None or model.white_m < PRESETS["drone"].white_m:  # fixes as steady as an exact log's: not a receiver's
        return None
    consumer = GATE_EPS * vote_radius(judged.camera, prepared, eps_px, PRESETS["phone"])
    if consumer <= gate_px:
        return None
    share = path_share(judged.camera, _xy(judged), path, consumer)
    if share < HEIGHT_FIT or not _fits_better(given, share):  # a log's error moves the whole path, not part of it
        return None
    declared = f"{model.name}, {model.horizontal_m:.2g} m"
    return Reason(
        "log_error",
        FAILED,
        f"the track lies on the projected path (at any time) in {share:.0%} of its frames within {consumer:.0f} px, "
        f"the metres of error a phone's or a consumer drone's receiver has, and within {gate_px:.0f} px in under "
        f"{OFF_PATH_SHARE:.0%}: the log's error is larger than its model says ({declared})",
        'declare the log\'s receiver: [target] log_model = "phone" or "drone" (or its white_m, bias_m and tau_s)',
    )


def image_offset(camera: Camera, xy: np.ndarray, path: PiecewiseTrajectory, gate_px: float) -> np.ndarray | None:
    """The constant (dx, dy) pixels that best moves the tracked positions onto the projected path (any time), found by
    matching each position to the nearest projected one and taking the median difference, OFFSET_ROUNDS times;
    None when the path does not project into the image or the offset is within the gate."""
    if len(xy) == 0 or not path.runs:
        return None
    step = max(0.25, sum(hi - lo for lo, hi, _ in path.runs) / 100_000)
    s = np.concatenate([np.arange(lo, hi + step / 2, step) for lo, hi, _ in path.runs])
    uv, valid = camera.project(path.positions(s))
    if not valid.any():
        return None
    tree = cKDTree(uv[valid])
    offset = np.zeros(2)
    for _ in range(OFFSET_ROUNDS):
        _, nearest = tree.query(xy - offset, k=1)
        offset = np.median(xy - uv[valid][nearest], axis=0)
    return offset if np.hypot(*offset) > gate_px else None


def _height_shift(
    cameras: dict[str, Judged], prepared: Trajectory, given: dict[str, float], gates: Mapping[str, float]
) -> tuple[float, float] | None:
    """(dz metres, mean path share) of the height offset of the log that puts the cameras' tracks on the path (within
    each camera's gate, pixels) clearly better than as given (plausibility._fits_better), the best of HEIGHT_STEPS_M
    either way refined between its neighbours; None when none does."""

    def share(dz: float) -> float:
        path = PiecewiseTrajectory(
            Trajectory(prepared.sample, prepared.xyz + [0.0, 0.0, dz], prepared.rate, prepared.t0)
        )
        return _mean({n: path_share(j.camera, _xy(j), path, gates[n]) for n, j in cameras.items()})

    steps = np.array(HEIGHT_STEPS_M)
    tried = {dz: share(dz) for dz in np.r_[-steps[::-1], steps]}
    best = max(tried, key=lambda dz: tried[dz])
    k = int(np.searchsorted(steps, abs(best)))
    half = (steps[min(k + 1, len(steps) - 1)] - (steps[k - 1] if k > 0 else 0.0)) / 2
    for _ in range(2):  # two rounds between the neighbours: about 1/64 of a step
        half /= 4
        for dz in best + half * np.arange(-3, 4):
            if dz not in tried:
                tried[float(dz)] = share(float(dz))
        best = max(tried, key=lambda dz: tried[dz])
    if abs(best) < HEIGHT_MIN_M:  # within a tracker's box of the tracked point: not what contradicts the line
        return None
    return (float(best), tried[best]) if tried[best] >= HEIGHT_FIT and _fits_better(_mean(given), tried[best]) else None


def _height_text(dz: float, share: float, given: float, prepared: Trajectory) -> str:
    flat = " (0 at every sample: a log without heights?)" if _flat(prepared) else ""
    return (
        f"heights {abs(dz):.3g} m too {'high' if dz < 0 else 'low'}{flat}: moved by that the log lies on the tracks "
        f"in {share:.0%} of the frames, as given in {given:.0%}"
    )


def _height_fix(dz: float, above_m: float, prepared: Trajectory) -> str:
    """The key that fixes a log dz metres off (dz: what must be added to its heights)."""
    if _flat(prepared):
        return f"give a log with heights (GPX <ele>, a CSV alt column), or set [target] altitude_offset_m = {dz:.3g}"
    if abs(dz) <= HEIGHT_NEAR_M:
        where = f"{-dz:.3g} m above" if dz < 0 else f"{dz:.3g} m below"
        return (
            f"the logged point rides {where} the tracked one (a GPS antenna?): "
            f"set [sync] logged_point_above_m = {above_m - dz:.3g} (or, for a tracker on the target's shadow, track "
            f"the target)"
        )
    return (
        "another height reference (sea level against the ellipsoid?): "
        f"set [target] altitude_reference or altitude_offset_m = {dz:.3g}"
    )


def _xy(judged: Judged) -> np.ndarray:
    """The tracked positions of a camera with a track (the only ones explained)."""
    assert judged.track is not None
    return judged.track.xy


def _flat(prepared: Trajectory) -> bool:
    """Whether the log's heights are one value at every sample (0 from a log that has none)."""
    return len(prepared) > 1 and float(np.ptp(prepared.xyz[:, 2])) < 1e-6


def _mean(shares: dict[str, float]) -> float:
    return float(np.mean(list(shares.values()))) if shares else 0.0
