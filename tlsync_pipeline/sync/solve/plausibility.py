"""Whether a camera's fitted line can be believed: measures of the line against the camera's own evidence.

Pure functions of the camera, its track (positions on the camera's clock),
the trajectory the line was fitted to and the line. Each measure is what a
wrong answer cannot fake:

- coverage: the share of tracked frames the line maps inside the log (a log
  that ends before the video starts cannot explain the track);
- on path: the share of those frames whose tracked position is within the
  gate of the projected position at the line's sample (a wrong line matches
  the path only where the two cross);
- motion: over pairs of tracked frames about MOTION_WINDOW_S apart, the
  tracked displacement against the projected one under the line: the share
  that agree (same direction, comparable length) and the share that point
  against each other (a log reversed in time, or a line whose slope is off,
  moves the projection the wrong way or at the wrong speed);
- motion slope: what the votes say about the slope alone, without a line:
  at each vote, the projected speed (pixels per sample) over the tracked
  speed (pixels per frame) is frames per sample; the mode of that ratio over
  the votes whose directions agree is compared with the clock prior (fps /
  log rate): their quotient is the log's true seconds per second of ``t``
  (all cameras alike: the log's time unit) or the camera's true fps over its
  stated one (one camera alone); over the votes whose directions are
  opposite, a log reversed in time;
- line motion: at each tracked frame, the target's image velocity against
  the projected log's velocity at the line's sample. Their directions agree
  under a right line whatever the log's bias (it wanders over tens of
  seconds, not within the half second a velocity spans): a pose that is not
  the camera's (another camera's, swapped) moves the projection in other
  directions. The ratio of their speeds is the frames per sample the line's
  own pairing reads: against the clock prior, on every camera alike, the
  log's time unit (a log whose times are doubled);
- backward support: the frames backing the votes' best line running
  backwards in time, against the line's own;
- a rival: the line search's best line without the line's votes, as strong
  and far from it, that the camera's whole track, the log's bias absorbed,
  does not rule out (sync/solve/rival.py).

``judge_line`` turns the measures into reasons of the camera's status
(sync/model/status.py); ``diagnose`` looks at every camera together (a time or
length unit of the log, a track of another resolution).

Thresholds are in pixels, seconds of the camera's clock, or samples of the
trajectory grid (independent of the unit the log's times were given in).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from calibration.camera import Camera
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.sync.kernels.backward import backwards_better
from tlsync_pipeline.sync.kernels.velocity import image_velocity
from tlsync_pipeline.sync.model.clock import camera_clock, image_speed
from tlsync_pipeline.sync.model.log_model import LogModel
from tlsync_pipeline.sync.model.status import AMBIGUOUS, FAILED, WEAK, Reason
from tlsync_pipeline.sync.solve.rival import RivalOdds, rival_odds, scanned_line
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.track import Track

MOTION_WINDOW_S = 0.5  # seconds of the camera between the two frames of a displacement
MOTION_WINDOW_FRAMES = 10  # the same for a camera of unknown fps
MOVING_PX = 6.0  # a displacement shorter than this (pixels) is tracking noise, not motion
AGREE_ERROR = 0.5  # displacements agree when |d_img - d_proj| <= AGREE_ERROR x the longer one
SLOPE_BIN = math.log(1.08)  # width of the bins of log(frames per sample) the motion slope's mode is taken over
VELOCITY_HALF_S = 0.1  # seconds either side of a frame over which its tracked velocity is fitted
MIN_MOVING = 8  # displacement pairs (or votes) needed before a motion measure says anything
DRIFT_ABOVE = 2.0  # the log's direction counts where it moves at least this many times its bias's drift
MAX_SLOPE_VOTES = 200_000  # votes (evenly picked) the motion slope is taken over
MIN_SLOPE_SUPPORT = 20  # votes that must back the motion slope ...
SLOPE_SHARE = 0.15  # ... and this share of the moving votes


@dataclass(frozen=True)
class LineEvidence:
    """How a camera's line agrees with its track.

    tracked: tracked frames; covered: share of them the line maps inside the
    log's runs; on_path: share of the covered ones within the gate of the
    projection; moving: displacement pairs with measurable motion; agree /
    against: share of those that agree / point against each other.
    """

    tracked: int
    covered: float
    on_path: float
    moving: int
    agree: float
    against: float


def motion_window(fps: float | None) -> int:
    """Frames between the two ends of a displacement: MOTION_WINDOW_S of the camera's clock."""
    return max(1, round(MOTION_WINDOW_S * fps)) if fps else MOTION_WINDOW_FRAMES


def line_evidence(
    camera: Camera,
    track: Track,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    gate_px: float,
    fps: float | None,
) -> LineEvidence:
    """The line clock = alpha * sample + beta against the track (``clock``: each tracked frame's clock value)."""
    n = len(track)
    s = (np.asarray(clock, dtype=np.float64) - beta) / alpha
    run = path.run_of(s)
    inside = run >= 0
    uv = np.full((n, 2), np.nan)
    if inside.any():
        uv[inside], _ = camera.project(path(s[inside], run[inside]))
    xy = track.xy
    near = np.linalg.norm(uv - xy, axis=1) <= gate_px  # NaN (outside the log or the image) compares False
    covered = int(inside.sum())
    i, j = _pairs(np.asarray(clock, dtype=np.float64), motion_window(fps))
    both = inside[i] & inside[j] & np.isfinite(uv[i, 0]) & np.isfinite(uv[j, 0])
    i, j = i[both], j[both]
    d_img, d_proj = xy[j] - xy[i], uv[j] - uv[i]
    agree, against, moving = _compare(d_img, d_proj)
    return LineEvidence(
        n, covered / n if n else 0.0, float(near.sum()) / covered if covered else 0.0, moving, agree, against
    )


def _pairs(clock: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) of tracked frames about ``window`` clock units apart (between window and 1.5 window)."""
    j = np.searchsorted(clock, clock + window)
    ok = j < len(clock)
    i = np.flatnonzero(ok)
    j = j[ok]
    keep = clock[j] - clock[i] <= 1.5 * window
    return i[keep], j[keep]


def _compare(d_img: np.ndarray, d_proj: np.ndarray) -> tuple[float, float, int]:
    """(share of the moving pairs that agree, share pointing against each other, moving pairs)."""
    l_img, l_proj = np.linalg.norm(d_img, axis=1), np.linalg.norm(d_proj, axis=1)
    longer = np.maximum(l_img, l_proj)
    moving = longer >= MOVING_PX
    m = int(moving.sum())
    if m == 0:
        return 0.0, 0.0, 0
    d_img, d_proj, l_img, l_proj, longer = d_img[moving], d_proj[moving], l_img[moving], l_proj[moving], longer[moving]
    agree = np.linalg.norm(d_img - d_proj, axis=1) <= AGREE_ERROR * longer
    with np.errstate(invalid="ignore", divide="ignore"):
        against = np.einsum("ij,ij->i", d_img, d_proj) / (l_img * l_proj) < -0.5
    return float(agree.mean()), float(against.mean()), m


@dataclass(frozen=True)
class SlopeMode:
    """The mode of frames per sample over some votes: its value (NaN when too few votes), the votes near it, the votes
    it was taken over.
    """

    alpha: float
    support: int
    votes: int

    @property
    def reliable(self) -> bool:
        """Whether enough of the moving votes agree on it for it to mean something."""
        return (
            bool(np.isfinite(self.alpha))
            and self.support >= MIN_SLOPE_SUPPORT
            and self.support >= SLOPE_SHARE * self.votes
        )


@dataclass(frozen=True)
class MotionSlope:
    """What the moving votes' speeds say about the slope: along, over the votes whose tracked and projected motions
    point the same way; against, over those pointing opposite ways (a log reversed in time)."""

    along: SlopeMode
    against: SlopeMode


@dataclass(frozen=True)
class LineMotion:
    """The target's image velocity against the projected log's under a line, over the tracked frames where the target
    moves (at least MOVING_PX over 2 x VELOCITY_HALF_S) and the line maps inside the log: frames, the median cosine
    between the two velocities, and the median ratio of projected speed (pixels per sample) over tracked speed (pixels
    per clock unit): clock units per sample. NaN with fewer than MIN_MOVING frames. beyond_drift, direction_beyond:
    the same frames where the log itself moves faster than DRIFT_ABOVE times its bias's drift (``log_drift``), and
    their median cosine (NaN with fewer than MIN_MOVING; every moving frame for a log without a bias)."""

    frames: int
    direction: float
    speed: float
    beyond_drift: int = 0
    direction_beyond: float = float("nan")

    @property
    def measured(self) -> bool:
        return self.frames >= MIN_MOVING and bool(np.isfinite(self.direction))

    @property
    def moves_along(self) -> bool:
        """Whether the target moves the log's way under the line (median cosine at least MOVES_ALONG), over every
        moving frame or over those where the log's own motion stands above its bias's drift: where a hovering target
        creeps slower than the log's bias wanders, the log's velocity is its bias's, and only the frames where the log
        outruns it say which way it goes."""
        if not self.measured:
            return False
        beyond = self.beyond_drift >= MIN_MOVING and self.direction_beyond >= MOVES_ALONG
        return self.direction >= MOVES_ALONG or beyond


def line_motion(
    camera: Camera,
    track: Track,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    alpha: float,
    beta: float,
    fps: float | None,
    drift: float = 0.0,
) -> LineMotion:
    """Tracked against projected velocity under the line clock = alpha * sample + beta (``LineMotion``); drift: the
    log's bias's drift (metres per sample, ``log_drift``)."""
    clock = np.asarray(clock, dtype=np.float64)
    half = _velocity_half(fps)
    velocity = image_velocity(clock, track.xy, half)
    s = (clock - beta) / alpha
    run = path.run_of(s)
    ok = (run >= 0) & np.isfinite(velocity[:, 0])
    if ok.sum() < MIN_MOVING:
        return LineMotion(int(ok.sum()), float("nan"), float("nan"))
    moving, cos, log_ratio = _velocities_compared(velocity[ok], _projected_velocity(camera, path, s[ok], run[ok]), half)
    m = int(moving.sum())
    if m < MIN_MOVING:
        return LineMotion(m, float("nan"), float("nan"))
    beyond = moving & (np.linalg.norm(path(s[ok], run[ok], nu=1), axis=1) >= DRIFT_ABOVE * drift)
    b = int(beyond.sum())
    return LineMotion(
        m,
        float(np.median(cos[moving])),
        float(np.exp(np.median(log_ratio[moving]))),
        b,
        float(np.median(cos[beyond])) if b >= MIN_MOVING else float("nan"),
    )


def _velocities_compared(v_img: np.ndarray, v_proj: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tracked (pixels per clock unit, fitted over ``half`` either side) against projected (pixels per sample)
    velocities, (N, 2) each: where the target moves (MOVING_PX over the window, a projected motion), the cosine
    between them and the log of their speeds' ratio (clock units per sample)."""
    l_img, l_proj = np.linalg.norm(v_img, axis=1), np.linalg.norm(v_proj, axis=1)
    moving = np.isfinite(l_proj) & (l_img * 2 * half >= MOVING_PX) & (l_proj > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("ij,ij->i", v_img, v_proj) / (l_img * l_proj)
        log_ratio = np.log(l_proj / l_img)
    return moving, cos, log_ratio


def _velocity_half(fps: float | None) -> int:
    """Clock units either side of a frame its tracked velocity is fitted over: VELOCITY_HALF_S of the camera."""
    return max(1, round(VELOCITY_HALF_S * fps)) if fps else 2


def _projected_velocity(camera: Camera, path: PiecewiseTrajectory, s: np.ndarray, run: np.ndarray) -> np.ndarray:
    """(N, 2) image velocity (pixels per sample) of the path model's projection at samples s (in runs ``run``)."""
    position = path(s, run)
    step = 1e-3
    uv, _ = camera.project(np.concatenate([position, position + step * path(s, run, nu=1)]))
    return (uv[len(s) :] - uv[: len(s)]) / step


def motion_slope(
    camera: Camera,
    track: Track,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    vote_clock: np.ndarray,
    vote_sample: np.ndarray,
    fps: float | None,
) -> MotionSlope:
    """Frames per sample from the votes' speeds: tracked pixels per clock unit (a line through VELOCITY_HALF_S
    either side) against projected pixels per sample (the path model's derivative)."""
    clock = np.asarray(clock, dtype=np.float64)
    half = _velocity_half(fps)
    velocity = image_velocity(clock, track.xy, half)
    every = max(
        1, math.ceil(len(vote_clock) / MAX_SLOPE_VOTES)
    )  # a mode needs no more votes: memory and time stay bounded
    at = np.clip(np.searchsorted(clock, np.asarray(vote_clock[::every], dtype=np.float64)), 0, len(clock) - 1)
    s = np.asarray(vote_sample[::every], dtype=np.float64)
    run = path.run_of(s)
    ok = (run >= 0) & np.isfinite(velocity[at, 0])
    m = int(ok.sum())
    if m < MIN_MOVING:
        none = SlopeMode(float("nan"), 0, m)
        return MotionSlope(none, none)
    samples, which = np.unique(s[ok], return_inverse=True)  # votes share their samples: project each once
    v_proj = _projected_velocity(camera, path, samples, path.run_of(samples))[which.ravel()]
    moving, cos, log_ratio = _velocities_compared(velocity[at[ok]], v_proj, half)
    n = int(moving.sum())
    return MotionSlope(_mode(log_ratio[moving & (cos > 0.9)], n), _mode(log_ratio[moving & (cos < -0.9)], n))


def _mode(log_ratio: np.ndarray, votes: int) -> SlopeMode:
    """The densest window of three SLOPE_BIN bins of log(frames per sample): the median inside it, and its votes."""
    if len(log_ratio) < MIN_MOVING:
        return SlopeMode(float("nan"), len(log_ratio), votes)
    bins = np.floor(log_ratio / SLOPE_BIN).astype(np.int64)
    values, counts = np.unique(bins, return_counts=True)
    padded = np.zeros(values.max() - values.min() + 3, dtype=np.int64)
    padded[values - values.min() + 1] = counts
    k = int(np.argmax(padded[:-2] + padded[1:-1] + padded[2:]))
    centre = (k + values.min() + 0.5) * SLOPE_BIN
    inside = np.abs(log_ratio - centre) <= 1.5 * SLOPE_BIN
    return SlopeMode(float(np.exp(np.median(log_ratio[inside]))), int(inside.sum()), votes)


# What the measures must show for a line to stand (drone2, the demo and the Figure 5 cells against the trap suite:
# docs/accuracy.md, "Plausibility checks").
GATE_EPS = 2.0  # on path: within GATE_EPS x eps_px of the projection
EVIDENCE_MIN = 0.95  # on-path share + agreeing-motion share below this: the line is contradicted
COVERED_MIN = 0.5  # share of the tracked frames the line must map inside the log ...
COVERED_WEAK = 0.9  # ... and below this, the camera is weak
AGAINST_MIN = 0.3  # share of displacements against the projected path that names the direction as a reason
RIVAL_RATIO = 0.5  # a rival line with this share of the line's support ...
RIVAL_SECONDS = 1.0  # ... further than this from it (median over the tracked frames) makes the camera ambiguous
RIVAL_SAMPLES = 10.0  # the same, in samples, without frame rates
RIVAL_PROBABILITY = 0.01  # ... unless the joint evidence (sync/solve/rival.py) leaves the rival less than this
RIVAL_BAND_FRAMES = 300.0  # a line's intercept is profiled over at most this many frames either side
SLOPE_OFF = 1.3  # motion slope / clock prior beyond this factor (either way): the clock is wrong
DIRECTION_MIN = 0.5  # median cosine of tracked and projected velocities under a line below this: it moves another way
MOVES_ALONG = 0.9  # ... at least this: it moves the log's way, which a log reversed in time would move against
PACE_OFF = 1.6  # the cameras' line speeds over their clock priors (geometric mean) beyond this: the log's time unit


def judge_line(
    camera: Camera,
    track: Track,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    line,
    eps_px: float,
    fps: float | None,
    alpha_prior: float | None,
    slope: MotionSlope | None,
    support: tuple[int, int | None] = (0, None),
    rate: float | None = None,
    motion: LineMotion | None = None,
) -> tuple[Reason, ...]:
    """The plausibility checks of one camera's line (a sync.timeline.CameraLine): the reasons they find, or ().

    alpha_prior: the clock prior's slope (fps / log rate), None when unknown
    or the slope is free; slope: what the votes' motion says (``motion_slope``);
    support: the frames whose votes back the line, and those backing the best
    line running backwards in time (kernels/backward.py's ``backward_support``; None: not measured);
    rate: the log's samples per second (None: starts are given in samples);
    motion: the tracked against the projected velocities under the line (``line_motion``; None: not checked).
    """
    evidence = line_evidence(camera, track, clock, path, line.alpha, line.beta, GATE_EPS * eps_px, fps)
    reasons = []
    outside = 1.0 - evidence.covered
    if evidence.covered < COVERED_MIN:
        reasons.append(
            Reason(
                "coverage",
                FAILED,
                f"the line puts {outside:.0%} of the frames where the target is tracked outside the log",
                "give the log that covers this video (another flight's log, or a log that ends before the video "
                "starts?)",
            )
        )
    elif evidence.covered < COVERED_WEAK:
        reasons.append(
            Reason(
                "partial_coverage",
                WEAK,
                f"the log covers {evidence.covered:.0%} of the frames where the target is tracked",
                "a log that covers the whole pass",
            )
        )
    if evidence.moving < MIN_MOVING:
        if evidence.on_path < 0.5:
            reasons.append(_off_path(evidence, eps_px, "the target barely moves in the image"))
        else:
            reasons.append(
                Reason(
                    "motion_unchecked",
                    WEAK,
                    f"the target barely moves in the image ({evidence.moving} displacements): its timing rests on its "
                    f"position alone",
                    "a pass of the target across the view",
                )
            )
    elif evidence.on_path + evidence.agree < EVIDENCE_MIN:
        reasons.append(_off_path(evidence, eps_px))
        if evidence.against >= AGAINST_MIN and evidence.against > evidence.agree:
            reasons.append(
                Reason(
                    "against_path",
                    FAILED,
                    f"the target moves against the projected path's direction in {evidence.against:.0%} of its "
                    f"displacements",
                    "check the log's time order (reversed?) and the camera's pose (mirrored?)",
                )
            )
    if (
        motion is not None
        and motion.measured
        and motion.direction < DIRECTION_MIN
        and not any(r.code == "off_path" for r in reasons)
    ):
        reasons.append(_direction(motion))
    if alpha_prior is not None and not _near_one(line.alpha / alpha_prior):
        reasons.append(
            Reason(
                "slope",
                FAILED,
                f"the line's slope {line.alpha:.4g} frames per sample is {line.alpha / alpha_prior:.3g} times what "
                f"fps and the log's rate give ({alpha_prior:.4g})",
                "check the camera's fps and the log's times",
            )
        )
    contradicted = any(r.severity == FAILED for r in reasons)
    if contradicted and slope is not None and alpha_prior is not None:
        along, against = slope.along.alpha / alpha_prior, slope.against.alpha / alpha_prior
        if slope.along.reliable and not _near_one(along):
            fps_text = f"this video runs at about {fps * along:.4g} fps, not {fps:g}, or " if fps else ""
            reasons.append(
                Reason(
                    "clock",
                    FAILED,
                    f"the target's speed in the image says {fps_text}one unit of the log's t is {along:.3g} s",
                    "set the camera's fps, or [target] time_unit",
                )
            )
        if slope.against.reliable and _near_one(against) and not (slope.along.reliable and _near_one(along)):
            reasons.append(
                Reason(
                    "reversed",
                    FAILED,
                    "the target moves along the logged path backwards, at the logged speed: the log looks reversed in "
                    "time",
                    "check the log's time order",
                )
            )
    if not any(r.code == "clock" for r in reasons):
        stated = _stated_fps_unbacked(track, fps, alpha_prior, slope)
        if stated is not None:
            reasons.append(stated)
    forward, backward = support
    along = motion is not None and motion.moves_along
    if (
        backward is not None
        and backwards_better(forward, backward)
        and not along
        and not any(r.code == "reversed" for r in reasons)
    ):
        reasons.append(
            Reason(
                "reversed",
                FAILED,
                f"the votes back a line running backwards in time better ({backward} frames, against {forward} "
                f"forwards): the log looks reversed in time",
                "check the log's time order",
            )
        )
    rival = _rival(line, track, clock, fps, eps_px, rate)
    if rival is not None:
        reasons.append(rival)
    return tuple(reasons)


def times_fps(track: Track) -> float | None:
    """The frame rate (frames per second) the track's presentation times run at: the least-squares slope of time_s
    over the frame index; None without times."""
    if track.time_s is None or len(track) < 3 or np.ptp(track.frame) <= 0:
        return None
    slope = float(np.polyfit(track.frame.astype(np.float64), np.asarray(track.time_s, dtype=np.float64), 1)[0])
    return 1.0 / slope if slope > 0 else None


def _stated_fps_unbacked(
    track: Track, fps: float | None, alpha_prior: float | None, slope: MotionSlope | None
) -> Reason | None:
    """``clock`` (FAILED) when the camera's stated fps and the rate its track's presentation times run at (the
    container's) are more than SLOPE_OFF apart on a frame clock, and the target's motion (``motion_slope``, reliable
    and within SLOPE_OFF of the clock prior) does not back the stated one. A stated fps the motion backs stands (a
    time-lapse whose container runs faster than it records); otherwise the line rests on a rate two witnesses dispute,
    and a log whose error widens the vote radius cannot settle it by the line's fit (a phone's metres hide a slope off
    by 2). On a presentation-time clock the stated fps only names the clock's unit and nothing is checked."""
    rate = times_fps(track)
    if rate is None or not fps or camera_clock(track, fps).vfr or _near_one(fps / rate):
        return None
    if slope is not None and alpha_prior and slope.along.reliable and _near_one(slope.along.alpha / alpha_prior):
        return None
    return Reason(
        "clock",
        FAILED,
        f"the track's presentation times say this video runs at about {rate:.4g} fps, not {fps:g}, "
        f"and the target's motion does not back {fps:g}",
        f"set the camera's fps to the rate it records at (its frames' times: {rate:.4g})",
    )


def _near_one(factor: float) -> bool:
    return 1 / SLOPE_OFF <= factor <= SLOPE_OFF


def _direction(motion: LineMotion) -> Reason:
    angle = math.degrees(math.acos(max(-1.0, min(1.0, motion.direction))))
    return Reason(
        "direction",
        FAILED,
        f"under this line the target moves in the image another way than the projected log: {angle:.0f} degrees "
        f"apart (median over {motion.frames} frames), which the log's error, wandering over tens of seconds, cannot "
        f"turn",
        "check the camera's pose (its camera.json: another camera's pose? K, R, t swapped?) and that the track is "
        "this camera's",
    )


def _off_path(evidence: LineEvidence, eps_px: float, why: str = "") -> Reason:
    moves = f"moves with it in {evidence.agree:.0%} of its displacements" if evidence.moving >= MIN_MOVING else why
    return Reason(
        "off_path",
        FAILED,
        f"under this line the target is within {GATE_EPS * eps_px:g} px of its projected position in "
        f"{evidence.on_path:.0%} of its frames and {moves}",
        "check the camera's pose (GCPs), its track and fps, and that the log is this flight's, in seconds and metres",
    )


def _rival_apart(
    line, track: Track, clock: np.ndarray, fps: float | None, eps_px: float, beyond_band: bool = True
) -> float | None:
    """How far (clock units, median over the tracked frames) the line search's rival lies from its line, when it has
    comparable support (RIVAL_RATIO) and lies apart: further than RIVAL_SECONDS, and (``beyond_band``) further than
    the target takes to cross the band of one pass's votes (+-eps_px, the vote radius) in the image: within it, the
    log's error moves the line as far (the same pass, not a second one). None otherwise."""
    search = line.line_search
    if search is None or search.rival_alpha is None or search.runner_up_frames < RIVAL_RATIO * search.support_frames:
        return None
    clock = np.asarray(clock, dtype=np.float64)
    sample = (clock - search.beta) / search.alpha
    apart = float(np.median(np.abs(search.rival_alpha * sample + search.rival_beta - clock)))
    speed = image_speed(clock, track.xy, quantile=0.5)
    if beyond_band and speed is not None and apart <= 2.0 * eps_px / speed:  # within one pass's band (+-eps_px)
        return None
    if (apart / fps <= RIVAL_SECONDS) if fps else (apart / line.alpha <= RIVAL_SAMPLES):
        return None
    return apart


def rival_odds_of(
    camera: Camera,
    track: Track,
    clock: np.ndarray,
    path: PiecewiseTrajectory,
    line,
    eps_px: float,
    fps: float | None,
    model: LogModel,
    rate: float | None,
) -> RivalOdds | None:
    """The rival's posterior against the line search's line on the camera's whole track, the log's bias absorbed
    (sync/solve/rival.py), when the rival has comparable support and lies further than RIVAL_SECONDS
    (``_rival_apart``); None otherwise. A rival within the band of one pass's votes is weighed too: it makes no
    refusal (``_rival``), but where the whole track prefers it the camera is refitted on it (a hovering target's
    band spans tens of seconds, and the line search's best line there may be the wrong end of it).

    Under a log with a bias, on a camera whose pose does not come from the target (that pose was fitted with its
    timing), the track is scanned too (rival.scanned_line): the scan's best line, beyond the band of the line search's,
    is weighed the same way, and is the rival (``RivalOdds.scanned``) when the track leaves it more probable than the
    line search's rival.

    Each line's intercept is profiled over the band one pass's votes span (eps_px over the image speed, in clock units).
    """
    search = line.line_search
    if search is None:
        return None
    speed = image_speed(np.asarray(clock, dtype=np.float64), track.xy, quantile=0.5) or 1.0
    band = min(eps_px / speed, RIVAL_BAND_FRAMES)
    odds = None
    if _rival_apart(line, track, clock, fps, eps_px, beyond_band=False) is not None:
        best, rival = (search.alpha, search.beta), (search.rival_alpha, search.rival_beta)
        odds = rival_odds(camera, clock, track.xy, path, best, rival, model, fps, rate, band)
    from_target = camera.pose_info is not None and "target" in camera.pose_info.source
    if not (model.has_bias and fps and len(clock)) or from_target:
        return odds
    beta = scanned_line(camera, clock, track.xy, path, search.alpha, model, fps, rate)
    if beta is None or abs(beta - search.beta) <= band:
        return odds
    scanned = rival_odds(
        camera, clock, track.xy, path, (search.alpha, search.beta), (search.alpha, beta), model, fps, rate, band
    )
    if odds is None or scanned.rival_probability > odds.rival_probability:
        return replace(scanned, scanned=(search.alpha, scanned.rival.beta))
    return odds


def _rival(
    line, track: Track, clock: np.ndarray, fps: float | None, eps_px: float, rate: float | None = None
) -> Reason | None:
    """AMBIGUOUS when the line search's rival passes the gates of ``_rival_apart`` and, when its joint odds were
    weighed (LineSearchSummary.rival_probability, ``rival_odds_of``), keeps at least RIVAL_PROBABILITY of the posterior:
    the reason gives both lines' starts (the log's time at the video's first frame) with their probabilities."""
    apart = _rival_apart(line, track, clock, fps, eps_px)
    if apart is None:
        return None
    search = line.line_search
    probability = search.rival_probability
    if probability is not None and probability < RIVAL_PROBABILITY:
        return None
    distance = f"{apart / fps:.3g} s" if fps else f"{apart:.0f} frames"
    text = (
        f"a second line {distance} away has comparable support ({search.runner_up_frames} against "
        f"{search.support_frames} frames)"
    )
    if probability is not None:
        starts = [(-line.beta / line.alpha, 1.0 - probability), (-search.rival_beta / search.rival_alpha, probability)]
        unit = (lambda s: f"{s / rate:.2f} s") if rate else (lambda s: f"sample {s:.1f}")
        text += (
            ", and the track under each, the log's bias absorbed, leaves both possible: the video's first frame at "
            + " or at ".join(f"{unit(s)} of the log ({p:.0%})" for s, p in starts)
        )
        key = "pick_start_s" if rate else "pick_start_sample"
        remedy = (
            f"a longer pass through this view with a turn in it, or a more accurate log (RTK), settles it; or "
            f"pick one: [[cameras]] {key} = one of these starts (docs/project.md)"
        )
    else:
        remedy = (
            "the target passes through this view alike more than once: give the tracker an init box on the right "
            "pass, or a log of that pass only"
        )
    return Reason("ambiguous", AMBIGUOUS, text, remedy)


PATH_POINTS = 400_000  # most points of the path model projected to measure a path share


def path_share(camera: Camera, xy: np.ndarray, path: PiecewiseTrajectory, gate_px: float) -> float:
    """Share of tracked positions within gate_px of the trajectory's projection anywhere (any time): the path, not the
    timing.

    The path model is evaluated every quarter sample (coarser for a log so
    long that this would exceed PATH_POINTS points).
    """
    if len(xy) == 0 or not path.runs:
        return 0.0
    span = sum(hi - lo for lo, hi, _ in path.runs)
    step = max(0.25, span / PATH_POINTS)
    s = np.concatenate([np.arange(lo, hi + step / 2, step) for lo, hi, _ in path.runs])
    uv, valid = camera.project(path.positions(s))
    if not valid.any():
        return 0.0
    dist, _ = cKDTree(uv[valid]).query(xy, k=1, distance_upper_bound=gate_px)
    return float(np.mean(np.isfinite(dist)))


class LogUnitError(InputError):
    """The log's times or positions are not in seconds and metres, as every camera's evidence says; ``column``:
    the trajectory's column(s) at fault. The message names the column and the fix, not the file (the caller adds it)."""

    def __init__(self, column: str, message: str):
        super().__init__(f"column {column}: {message}")
        self.column = column


# Length units a log's positions are often written in by mistake: metres per unit, the length_unit value.
LENGTH_SUSPECTS = ((0.3048, "ft"), (0.01, "cm"), (0.001, "mm"))
SCALE_FIT = 0.6  # mean path share a rescaled log or track must reach ...
SCALE_GAIN = 3.0  # ... leaving this many times fewer frames off the path than as given
UNIT_AGREEMENT = 1.15  # cameras' motion slopes within this factor of each other agree on a time unit
RATE_ROUNDING = 0.03  # a log rate the motion slope puts within this fraction of a whole number of hertz is that number


@dataclass(frozen=True)
class Judged:
    """What ``diagnose`` needs of one camera: its calibration, track, motion slope, clock prior's slope, whether it was
    contradicted (its line by the checks, or it has none), and the frames per sample its line's pairing reads from the
    target's image speed (``LineMotion.speed``) when the line moves the projection the track's way (None otherwise)."""

    camera: Camera
    track: Track | None
    slope: MotionSlope | None
    alpha_prior: float | None
    contradicted: bool
    line_speed: float | None = None


def diagnose(judged: dict[str, Judged], prepared: Trajectory, eps_px: float) -> dict[str, Reason]:
    """Causes that only the cameras together (or a rescaled input) reveal.

    Raises LogUnitError when every camera with a clock prior and a reliable
    motion slope (at least two) was contradicted and they agree on one factor
    away from 1 (the log's time unit), or when the target's image speed under
    each camera's line says the same, contradicted or not (``_paced_unit``: a
    metre-level log's vote radius hides a slope off by 2), or when every camera was contradicted
    and the log rescaled to metres from a usual wrong unit fits their tracks.
    Returns a reason per camera whose track, rescaled by 2 or 1/2, fits the
    projected path (a track of another resolution).
    """
    timed = {
        n: j for n, j in judged.items() if j.alpha_prior is not None and j.slope is not None and j.slope.along.reliable
    }
    factors = np.array([j.slope.along.alpha / j.alpha_prior for j in timed.values()])  # type: ignore[union-attr,operator]
    if (
        len(timed) >= 2
        and all(j.contradicted for j in timed.values())
        and factors.max() / factors.min() <= UNIT_AGREEMENT
    ):
        factor = float(np.exp(np.mean(np.log(factors))))
        if not _near_one(factor):
            raise LogUnitError("t", _time_unit_message(factor, len(timed)))
    paced = _paced_unit(judged)
    if paced is not None:
        raise LogUnitError("t", _time_unit_message(paced, sum(j.line_speed is not None for j in judged.values())))
    tracked = {n: j for n, j in judged.items() if j.track is not None and len(j.track)}
    gate = GATE_EPS * eps_px
    path = PiecewiseTrajectory(prepared)
    if tracked and all(j.contradicted for j in tracked.values()):
        given = float(np.mean([path_share(j.camera, j.track.xy, path, gate) for j in tracked.values()]))  # type: ignore[union-attr]
        for scale, unit in LENGTH_SUSPECTS:
            scaled = PiecewiseTrajectory(replace(prepared, xyz=prepared.xyz * scale))
            share = float(np.mean([path_share(j.camera, j.track.xy, scaled, gate) for j in tracked.values()]))  # type: ignore[union-attr]
            if _fits_better(given, share):
                raise LogUnitError(
                    "x, y, z",
                    f"not metres: x {scale:g} they lie on the tracks in {share:.0%} of the frames, as given in "
                    f'{given:.0%} ({unit}?); set [target] length_unit = "{unit}"',
                )
    reasons = {}
    for name, j in tracked.items():
        if not j.contradicted:
            continue
        given = path_share(j.camera, j.track.xy, path, gate)  # type: ignore[union-attr]
        for scale in (2.0, 0.5):
            share = path_share(j.camera, j.track.xy * scale, path, gate)  # type: ignore[union-attr]
            if _fits_better(given, share):
                reasons[name] = Reason(
                    "track_scale",
                    FAILED,
                    f"the track's x, y look like another resolution: x {scale:g} they lie on the projected path in "
                    f"{share:.0%} of the frames, as given in {given:.0%}",
                    "give the track in the pixels of the camera's image_size (or the camera.json of the video the "
                    "track was made on)",
                )
                break
    return reasons


NAMED_UNITS = (0.5, 2.0, 0.25, 4.0, 0.1, 10.0)  # seconds per unit of t a mistaken time column is often scaled by


def _paced_unit(judged: dict[str, Judged]) -> float | None:
    """The log's seconds per unit of t when every camera's line speed says its time axis is scaled
    (``Judged.line_speed`` over the clock prior): at least two cameras, each beyond SLOPE_OFF on the same side of 1,
    their geometric mean beyond PACE_OFF (one camera's fps wrong leaves the others at 1). The value is the median over
    those cameras of their votes' motion slope (``motion_slope``, the mode over every vote: a line paired off the
    target's pass reads a speed of another part of the path), or of their line speeds without one, snapped to a value
    of NAMED_UNITS within SLOPE_OFF of it (a metre-level log reads the speeds to 10-30 %). None otherwise, and when that
    value is within SLOPE_OFF of 1 (lines paired off the target, a wrong track, move at other speeds than its own)."""
    speeds = {n: (j.line_speed, j.alpha_prior) for n, j in judged.items() if j.line_speed is not None and j.alpha_prior}
    factors = np.array([speed / prior for speed, prior in speeds.values()])
    if len(factors) < 2 or not (np.all(factors < 1 / SLOPE_OFF) or np.all(factors > SLOPE_OFF)):
        return None
    if 1 / PACE_OFF <= float(np.exp(np.mean(np.log(factors)))) <= PACE_OFF:
        return None
    slopes = [judged[n].slope for n in speeds]
    modes = [
        s.along.alpha / speeds[n][1] for n, s in zip(speeds, slopes) if s is not None and np.isfinite(s.along.alpha)
    ]
    value = float(np.median(modes if modes else factors))
    if abs(math.log(value)) <= math.log(SLOPE_OFF):  # the votes' own motion reads seconds: not the log's unit
        return None
    named = min(NAMED_UNITS, key=lambda unit: abs(math.log(unit / value)))
    return named if abs(math.log(named / value)) <= math.log(SLOPE_OFF) else value


def _fits_better(given: float, rescaled: float) -> bool:
    """Whether a rescaled log or track lies on the other's path clearly better than as given (shares of frames on it);
    never when it lies on it as given already (a gate as wide as a metre-level log's puts it there whatever moves)."""
    return rescaled >= SCALE_FIT and rescaled > given and SCALE_GAIN * (1.0 - rescaled) <= 1.0 - given


def _time_unit_message(factor: float, cameras: int) -> str:
    """What every camera's motion says about the log's time unit (factor: seconds per unit of t), with the fix."""
    named = {1e-3: ("ms", "milliseconds"), 1e-6: ("us", "microseconds"), 60.0: ("min", "minutes")}
    close = next(
        (names for value, names in named.items() if abs(math.log(factor / value)) < math.log(UNIT_AGREEMENT)), None
    )
    if close is not None:
        what, fix = close[1], f'"{close[0]}"'
    elif factor < 1:
        rate = 1.0 / factor
        whole = round(rate)
        if whole >= 1 and abs(rate / whole - 1.0) < RATE_ROUNDING:
            rate, factor = float(whole), 1.0 / whole
        what, fix = f"sample numbers at {rate:.3g} Hz", f"{factor:.6g}"
    else:
        what, fix = f"units of {factor:.3g} s", f"{factor:.4g}"
    return (
        f"not seconds: in every camera ({cameras}) the target moves as if a unit of t were {factor:.3g} s "
        f"({what}?); set [target] time_unit = {fix}"
    )
