"""The timeline: every camera's line, the line in R^(N+1) and all pairwise relations.

Camera lines map target samples to the camera's clock, clock = alpha *
sample + beta (samples on the trajectory grid; the clock is the 0-based
frame index, or presentation time x fps for a variable-frame-rate camera:
sync/model/clock.py). A pairwise relation "A->B" maps frames of A to frames of B:
frame_B = alpha * frame_A + beta, exact between constant-rate cameras and
approximate otherwise; ``Timeline.match`` is the exact mapping.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.artefacts.identification import IdentificationSummary
from tlsync_pipeline.artefacts.kinds import artefact_path
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.sync.clock_prior import CLOCK_FLAG, ClockCheck, clock_reason
from tlsync_pipeline.sync.model.clock import FRAME, CameraClock, FrameTimes, Segment
from tlsync_pipeline.sync.model.params import ParamsTable
from tlsync_pipeline.sync.model.status import (
    AMBIGUOUS,
    FAILED,
    HALF_95,
    LOW_SPEED_M_S,
    LOW_SPEED_REMEDY,
    WEAK,
    WIDE_FRAMES,
    WIDE_REMEDIES,
    WIDE_REMEDY,
    CameraStatus,
    Reason,
    failure,
    line_reasons,
    status_of,
)
from tlsync_pipeline.trajectory import Trajectory
from trackers.breaks import Break

FORMAT_VERSION = 1


@dataclass(frozen=True)
class Relation:
    """frame_B = alpha * frame_A + beta (0-based frames)."""

    alpha: float
    beta: float

    def __call__(self, frame_a):
        return self.alpha * np.asarray(frame_a, dtype=np.float64) + self.beta

    def inverse(self) -> Relation:
        return Relation(1.0 / self.alpha, -self.beta / self.alpha)


@dataclass(frozen=True)
class LineSearchSummary:
    """The refined method's line search: its line, the distinct frames backing it and its best rival (and that
    rival's line, None when there is none), votes kept, lines tried; rival_probability: the rival's posterior
    probability on the camera's whole track (sync/solve/rival.py), None when it was not weighed."""

    alpha: float
    beta: float
    support_frames: int
    runner_up_frames: int
    thinned_votes: int
    hypotheses: int
    rival_alpha: float | None = None
    rival_beta: float | None = None
    rival_probability: float | None = None


@dataclass(frozen=True)
class RefinementSummary:
    """The refined method's continuous-time fit: frames used, robust pixel scale, |sin| velocity/ray, solver verdict."""

    frames_used: int
    scale_px: float
    perpendicular: float
    converged: bool


@dataclass(frozen=True)
class ErrorBudget:
    """Where a camera's timing uncertainty comes from: standard deviations (frames of its clock) at the middle of the
    target's visit, from tracking (pixel noise), calibration (the model error allowed for calibration and pose) and
    the log's bias; they add in quadrature."""

    tracking_frames: float
    calibration_frames: float
    log_frames: float

    @property
    def total_frames(self) -> float:
        return math.sqrt(self.tracking_frames**2 + self.calibration_frames**2 + self.log_frames**2)

    @property
    def dominant(self) -> str:
        """ "tracking", "calibration" or "log"."""
        parts = {"tracking": self.tracking_frames, "calibration": self.calibration_frames, "log": self.log_frames}
        return max(parts, key=lambda k: parts[k])


@dataclass(frozen=True)
class LogBiasSummary:
    """The log's bias during the camera's visit (sync/solve/log_bias.py): estimate (m, ENU), posterior std (m), and its
    observability (1 - posterior / prior horizontal variance: 0, only the prior; 1, known); speed_m_s: the target's
    speed across the view as its track shows it, weighted by what each frame says of the time, and spread_frames: the
    clock's std that a bias of se_m explains at that speed (sync/solve/slow_motion.py), None when not measured."""

    estimate_m: tuple[float, float, float]
    se_m: tuple[float, float, float]
    observability: float
    speed_m_s: float | None = None
    spread_frames: float | None = None

    @classmethod
    def from_dict(cls, data: dict) -> LogBiasSummary:
        speed, spread = data.get("speed_m_s"), data.get("spread_frames")
        return cls(
            tuple(data["estimate_m"]),
            tuple(data["se_m"]),
            float(data["observability"]),
            None if speed is None else float(speed),
            None if spread is None else float(spread),
        )


@dataclass(frozen=True)
class ScanSummary:
    """How the camera's video was read (the scan and track stages, sync/identify/scan.py).

    mode: "windows" (every frame only where a coarse pass over the keyframes
    put the target in view) or "full" (every frame); reason: why every
    frame (empty for windows); frames: frames in the video;
    keyframes_decoded: frames the coarse pass decoded; frames_decoded:
    frames the track stage decoded.
    """

    mode: str
    reason: str
    frames: int
    keyframes_decoded: int
    frames_decoded: int


POSE_SOURCES = ("target", "second_pass", "bias_refit", "target+bias_refit", "second_pass+bias_refit")


@dataclass(frozen=True, eq=False)
class LinePose:
    """The pose a camera's line was fitted with where the sync found it itself (the camera's camera.json holds
    another, or none): world -> camera rotation R (3x3) and translation t (metres), X_cam = R X_world + t.

    source: "target" (the camera came without a pose: posed from the target
    in the pass that gave the line), "second_pass" (searched again on the log
    corrected for its bias: Timeline.log_correction, sync/solve/pose_joint.py),
    "bias_refit" (the pose from the target refitted under the log's bias that
    every camera's line estimates: sync/solve/posed_bias.py), or one of the
    first two followed by the refit ("target+bias_refit",
    "second_pass+bias_refit").
    """

    R: np.ndarray
    t: np.ndarray
    source: str

    @classmethod
    def of(cls, camera: Camera, source: str) -> LinePose:
        """The pose of ``camera``."""
        return cls(np.array(camera.R, dtype=np.float64), np.array(camera.t, dtype=np.float64), source)

    def on(self, camera: Camera) -> Camera:
        """``camera`` (its intrinsics, size, fps) with this pose."""
        return replace(camera, R=self.R, t=self.t, to_estimate=tuple(k for k in camera.to_estimate if k != "pose"))

    @property
    def center(self) -> np.ndarray:
        """The camera centre (metres, world frame): -R^T t."""
        return -self.R.T @ self.t

    def to_dict(self) -> dict:
        return {
            "source": self.source,
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "camera_center_m": self.center.tolist(),
        }

    @classmethod
    def from_dict(cls, entry: dict) -> LinePose:
        """A camera entry's ``pose`` block back (ValueError when malformed)."""
        R, t = np.asarray(entry["R"], dtype=np.float64), np.asarray(entry["t"], dtype=np.float64)
        if R.shape != (3, 3) or t.shape != (3,) or entry["source"] not in POSE_SOURCES:
            raise ValueError("pose: expected R (3x3), t (3) and a source of " + ", ".join(POSE_SOURCES))
        return cls(R, t, entry["source"])


LOG_CORRECTION_SOURCES = ("second_pass", "bias_refit", "second_pass+bias_refit", "log_bias", "second_pass+log_bias")


@dataclass(frozen=True, eq=False)
class LogCorrection:
    """The log as the lines' poses were fitted on it: offset_m (K, 3) metres at knots (K,) sample coordinates, linear
    between them and constant beyond; the true position is the log's plus it.

    source: "second_pass" (what the sync took out of the log before the
    pass that gave the timeline: its later passes, sync/solve/synchronize.py,
    each adding the log's bias fitted with the poses from the target free,
    sync/solve/pose_joint.py; that pass's votes, poses and lines are on the
    log so corrected), "bias_refit" (the bias the poses from the target were
    last refitted on where that pass kept their refit under the log's bias,
    sync/solve/posed_bias.py), "log_bias" (the bias every line of that pass
    was fitted together with, none of its poses from the target), or either
    after "second_pass+" (the two summed).
    """

    knots: np.ndarray
    offset_m: np.ndarray
    source: str = "second_pass"

    def at(self, samples: np.ndarray) -> np.ndarray:
        """(N, 3) offsets (metres) at sample coordinates."""
        return np.column_stack([np.interp(samples, self.knots, self.offset_m[:, k]) for k in range(3)])

    def plus(self, other: LogCorrection) -> LogCorrection:
        """This correction and ``other`` (one fitted on the log this one corrected) together: exact on the union of
        their knots, both being linear between knots and constant beyond; its source both's, each once, in order."""
        knots = np.union1d(self.knots, other.knots)
        source = "+".join(dict.fromkeys([*self.source.split("+"), *other.source.split("+")]))
        return LogCorrection(knots, self.at(knots) + other.at(knots), source)

    def applied(self, trajectory: Trajectory) -> Trajectory:
        """The log ``trajectory`` corrected (its samples, rate and times unchanged)."""
        return replace(trajectory, xyz=trajectory.xyz + self.at(trajectory.sample))

    def to_dict(self) -> dict:
        return {"source": self.source, "samples": self.knots.tolist(), "offset_m": self.offset_m.tolist()}

    @classmethod
    def from_dict(cls, entry: dict) -> LogCorrection:
        """timeline.json's ``log_correction`` back (ValueError when malformed); a missing source reads as
        "second_pass", the only one older versions wrote."""
        knots = np.asarray(entry["samples"], dtype=np.float64)
        offsets = np.asarray(entry["offset_m"], dtype=np.float64).reshape(-1, 3)
        source = entry.get("source", "second_pass")
        if knots.ndim != 1 or len(knots) != len(offsets) or not len(knots) or (np.diff(knots) <= 0).any():
            raise ValueError("log_correction: expected increasing samples and one offset_m [x, y, z] each")
        if source not in LOG_CORRECTION_SOURCES:
            raise ValueError("log_correction: expected a source of " + ", ".join(LOG_CORRECTION_SOURCES))
        return cls(knots, offsets, source)


@dataclass(frozen=True)
class CameraLine:
    """One camera's fitted line clock = alpha * sample + beta, with its support.

    The clock is frame indices, or presentation time x fps for a
    variable-frame-rate camera (``clock``). votes: votes cast; inliers:
    votes on the line; residual_rms: clock units (frames); fps: nominal
    frame rate or None. What a method does not report is None: cov (2x2 of
    alpha, beta), flags (weak cases), warnings, refined (whether the
    refinement's line was kept), line_search and refinement summaries;
    identification: how the target was found, for a camera that brought
    every mover rather than a track; scan: how its video was read (None:
    the project brought its track or detections); breaks: where its
    recording leaves its steady clock (trackers/breaks.py; its segments are
    the clock's); pose: the pose the line was fitted with when the sync found
    it itself (None: the camera's camera.json's).
    """

    name: str
    alpha: float
    beta: float
    votes: int
    inliers: int
    residual_rms: float
    fps: float | None = None
    cov: np.ndarray | None = None
    flags: tuple[str, ...] | None = None
    warnings: tuple[str, ...] | None = None
    refined: bool | None = None
    line_search: LineSearchSummary | None = None
    refinement: RefinementSummary | None = None
    clock: CameraClock = CameraClock()
    identification: IdentificationSummary | None = None
    budget: ErrorBudget | None = None
    log_bias: LogBiasSummary | None = None
    checks: tuple[Reason, ...] | None = None
    scan: ScanSummary | None = None
    clock_check: ClockCheck | None = None
    breaks: tuple[Break, ...] | None = None
    pose: LinePose | None = None

    def __post_init__(self):
        if not self.clock.vfr and self.clock.fps is None and self.fps is not None:
            object.__setattr__(
                self, "clock", replace(self.clock, fps=self.fps)
            )  # a frame clock runs at the camera's fps

    @property
    def se_alpha(self) -> float | None:
        return None if self.cov is None else float(np.sqrt(self.cov[0, 0]))

    @property
    def se_beta(self) -> float | None:
        return None if self.cov is None else float(np.sqrt(self.cov[1, 1]))

    def sample_at(self, frames, times: FrameTimes | None = None) -> np.ndarray:
        """Target sample(s) at 0-based (fractional) frames (exact with the camera's presentation times)."""
        return (self.clock.clock_at(frames, times) - self.beta) / self.alpha

    def to_dict(self) -> dict:
        """The camera's entry in timeline.json, without the offsets to the reference."""
        entry: dict[str, Any] = {
            "alpha": self.alpha,
            "beta": self.beta,
            "votes": self.votes,
            "inliers": self.inliers,
            "residual_rms": self.residual_rms,
            "fps": self.fps,
        }
        if self.cov is not None:
            entry.update(se_alpha=self.se_alpha, se_beta=self.se_beta, cov=np.asarray(self.cov).tolist())
        for key in ("flags", "warnings"):
            if getattr(self, key) is not None:
                entry[key] = list(getattr(self, key))
        if self.refined is not None:
            entry["refined"] = self.refined
        for key in ("line_search", "refinement", "identification", "scan", "budget", "log_bias"):
            if getattr(self, key) is not None:
                entry[key] = asdict(getattr(self, key))
        if self.checks is not None:
            entry["checks"] = [r.to_dict() for r in self.checks]
        if self.clock_check is not None:
            entry["clock_prior"] = self.clock_check.to_dict()
        if self.clock.vfr:
            entry.update(
                clock=self.clock.kind,
                clock_fps=self.clock.fps,
                time_jitter_frames=self.clock.jitter_frames,
                clock_origin_s=self.clock.origin_s,
            )
        if self.clock.segments:
            entry["segments"] = [seg.to_dict() for seg in self.clock.segments]
        if self.breaks:
            entry["breaks"] = [b.to_dict() for b in self.breaks]
        if self.pose is not None:
            entry["pose"] = self.pose.to_dict()
        return entry

    @classmethod
    def from_dict(cls, name: str, entry: dict) -> CameraLine:
        """A camera entry of timeline.json back into a CameraLine (KeyError/TypeError when malformed)."""
        clock = CameraClock(FRAME, entry.get("fps"))
        if entry.get("clock", FRAME) != FRAME:
            clock = CameraClock(
                entry["clock"],
                float(entry["clock_fps"]),
                float(entry.get("clock_origin_s", 0.0)),
                float(entry["time_jitter_frames"]),
            )
        if entry.get("segments"):
            clock = replace(clock, segments=tuple(Segment.from_dict(seg) for seg in entry["segments"]))
        optional: dict[str, Any] = {
            "cov": None if entry.get("cov") is None else np.asarray(entry["cov"], dtype=np.float64),
            "flags": None if entry.get("flags") is None else tuple(entry["flags"]),
            "warnings": None if entry.get("warnings") is None else tuple(entry["warnings"]),
            "refined": entry.get("refined"),
            "line_search": None if entry.get("line_search") is None else LineSearchSummary(**entry["line_search"]),
            "refinement": None if entry.get("refinement") is None else RefinementSummary(**entry["refinement"]),
            "identification": None
            if entry.get("identification") is None
            else IdentificationSummary.from_dict(entry["identification"]),
            "checks": None if entry.get("checks") is None else tuple(Reason.from_dict(r) for r in entry["checks"]),
            "scan": None if entry.get("scan") is None else ScanSummary(**entry["scan"]),
            "budget": None if entry.get("budget") is None else ErrorBudget(**entry["budget"]),
            "log_bias": None if entry.get("log_bias") is None else LogBiasSummary.from_dict(entry["log_bias"]),
            "clock_check": None if entry.get("clock_prior") is None else ClockCheck.from_dict(entry["clock_prior"]),
            "breaks": None if not entry.get("breaks") else tuple(Break.from_dict(b) for b in entry["breaks"]),
            "pose": None if entry.get("pose") is None else LinePose.from_dict(entry["pose"]),
        }
        base = {k: entry[k] for k in ("alpha", "beta", "votes", "inliers")}
        base["residual_rms"] = float("nan") if entry["residual_rms"] is None else entry["residual_rms"]
        return cls(name, fps=entry.get("fps"), clock=clock, **base, **optional)


@dataclass(frozen=True)
class StageWarning:
    """One warning of a run: the stage that raised it, the camera of its task (None: a project-wide
    stage) and the text.
    """

    stage: str
    camera: str | None
    text: str

    def to_dict(self) -> dict:
        return {"stage": self.stage, "camera": self.camera, "text": self.text}


@dataclass(frozen=True)
class Timeline:
    """All cameras' lines on one target grid (rate in samples/s, t0 in s).

    cameras: the synchronized cameras' lines (status ok or weak, sync/model/status.py);
    failed: every camera that is not synchronized, with why in one line;
    warnings: those of the run's stages that made its inputs, then the sync
    stage's own, in pipeline order (the same list report.html shows);
    rejected: the lines of the cameras not synchronized that have one
    (ambiguous, or contradicted by the plausibility checks): for diagnosis,
    never for exports; log_correction: the log on which the lines' poses are
    drawn: what the sync took out of the log before the pass whose lines
    these are, plus the bias that pass's kept refit of the poses from the
    target was fitted on (LogCorrection.source; None: the log as given).
    """

    cameras: dict[str, CameraLine]
    target_rate: float | None = None
    target_t0: float | None = None
    method: str = "paper"
    params: ParamsTable = field(default_factory=ParamsTable)  # the [sync] table of the fit
    failed: dict[str, str] = field(default_factory=dict)
    warnings: tuple[StageWarning, ...] = ()
    # Covariance between two cameras' (alpha, beta) through an error they share (the log's bias), "A|B" -> 2x2 (rows:
    # A's).
    shared_cov: dict[str, np.ndarray] = field(default_factory=dict)
    log_model: dict | None = None  # the log's error model the fit assumed (sync/model/log_model.py), or None
    rejected: dict[str, CameraLine] = field(default_factory=dict)
    log_correction: LogCorrection | None = None  # the log the lines' poses were fitted on, as corrected

    def cross_cov(self, a: str, b: str) -> np.ndarray:
        """2x2 covariance between camera a's and camera b's (alpha, beta) (zeros when independent)."""
        if f"{a}|{b}" in self.shared_cov:
            return self.shared_cov[f"{a}|{b}"]
        if f"{b}|{a}" in self.shared_cov:
            return self.shared_cov[f"{b}|{a}"].T
        return np.zeros((2, 2))

    @property
    def names(self) -> list[str]:
        return list(self.cameras)

    def status(self, name: str) -> CameraStatus:
        """The camera's status (sync/model/status.py): its line's checks, flags, warnings and interval, or why it
        failed.
        """
        line = self.cameras.get(name) or self.rejected.get(name)
        if line is None:
            return status_of(name, [failure(self.failed.get(name, "not synchronized"))])
        reasons = line_reasons(line.flags, line.warnings, line.checks)
        if line.clock_check is not None and line.clock_check.agrees is False:  # the flag's reason with its numbers
            reasons = [clock_reason(line.clock_check) if r.code == CLOCK_FLAG else r for r in reasons]
        if name in self.cameras:
            wide = self._wide_interval(name)
            if wide is not None:
                reasons.append(wide)
        elif not any(r.severity in (AMBIGUOUS, FAILED) for r in reasons):
            reasons.append(failure(self.failed.get(name, "not synchronized")))
        return status_of(name, reasons)

    def _wide_interval(self, name: str) -> Reason | None:
        """WEAK when the camera's start, against the reference's, is known to more than WIDE_FRAMES of its own frames
        (95 %); for the reference, when every other camera's start is so known against it (``_wide_reference``);
        ``low_speed`` instead (for the reference too) when the log's bias at the target's slow speed in this view
        alone makes it so.
        """
        line = self.cameras[name]
        slow = _slow_motion(line)
        if slow is not None:
            return slow
        reference = self.names[0]
        if name == reference:
            return self._wide_reference()
        half = self._start_half_width(reference, name)
        if half is None or not half[0] > WIDE_FRAMES:
            return None
        seconds = "" if half[1] is None else f"±{half[1]:.2g} s, "
        return Reason(
            "wide_interval", WEAK, f"start known to {seconds}±{half[0]:.1f} of its frames only", _wide_remedy(line)
        )

    def _start_half_width(self, reference: str, name: str) -> tuple[float, float | None] | None:
        """The 95 % half-width of camera ``name``'s start against ``reference``'s: (frames of ``name``, seconds or
        None); None without covariances."""
        se = self.start_offset_se(reference, name)
        if se is None:
            return None
        fps = self.cameras[name].fps
        return HALF_95 * (se[1] * fps if se[1] is not None and fps else se[0]), (
            None if se[1] is None else HALF_95 * se[1]
        )

    def _wide_reference(self) -> Reason | None:
        """WEAK ``wide_interval`` for the reference when there is another synchronized camera and every other one's
        start is known against the reference's to more than WIDE_FRAMES of that camera's frames (95 %): every offset
        the reference gives is wide, whichever camera's line makes it so; the text gives the narrowest of them in the
        reference's frames. None otherwise."""
        reference, others = self.names[0], self.names[1:]
        halves = [self._start_half_width(reference, other) for other in others]
        if not others or any(h is None or not h[0] > WIDE_FRAMES for h in halves):
            return None
        se = min((self.start_offset_se(reference, other) for other in others), key=lambda e: e[0])  # type: ignore[index]
        assert se is not None, "every pair has covariances"
        seconds = "" if se[1] is None else f"±{HALF_95 * se[1]:.2g} s, "
        return Reason(
            "wide_interval",
            WEAK,
            f"reference of the offsets, each of them wide: the other cameras' starts are known against this one's "
            f"to {seconds}±{HALF_95 * se[0]:.1f} of its frames at best",
            _wide_remedy(self.cameras[reference]),
        )

    def statuses(self, names: list[str] | None = None) -> dict[str, CameraStatus]:
        """Every camera's status by name: ``names`` in that order (default: the synchronized, then the rejected, then
        the failed).
        """
        names = names or list(dict.fromkeys([*self.cameras, *self.rejected, *self.failed]))
        return {name: self.status(name) for name in names}

    def clock_relation(self, a: str, b: str) -> Relation:
        """clock_B = alpha * clock_A + beta, through the target's grid (exact; clocks as in CameraLine)."""
        la, lb = self.cameras[a], self.cameras[b]
        alpha = lb.alpha / la.alpha
        return Relation(alpha, lb.beta - alpha * la.beta)

    def relation(self, a: str, b: str) -> Relation:
        """frame_B = alpha * frame_A + beta: ``match`` without presentation-time tables.

        Exact between constant-rate cameras; for a variable-frame-rate camera
        the linear approximation of its clock (``pairs`` in timeline.json).
        """
        rel = self.clock_relation(a, b)
        offset_a = self.cameras[a].clock.clock_at(0.0)
        offset_b = self.cameras[b].clock.clock_at(0.0)
        return Relation(rel.alpha, float(rel.alpha * offset_a + rel.beta - offset_b))

    def match(self, a: str, b: str, frames_a, times: dict[str, FrameTimes | None] | None = None) -> np.ndarray:
        """Fractional frames of B taken at the instants of A's (fractional) frames.

        The one mapping between cameras' frames: through each camera's clock,
        exact with the cameras' presentation times (``times`` by name; frame
        clocks need none).
        """
        times = times or {}
        clock_a = self.cameras[a].clock.clock_at(frames_a, times.get(a))
        return self.cameras[b].clock.frames_at(self.clock_relation(a, b)(clock_a), times.get(b))

    def approximate(self, a: str, b: str) -> bool:
        """Whether relation(a, b) only approximates ``match`` (a variable-frame-rate camera)."""
        return self.cameras[a].clock.vfr or self.cameras[b].clock.vfr

    def relation_cov(self, a: str, b: str) -> np.ndarray | None:
        """2x2 covariance of relation(a, b)'s (alpha, beta), with what the cameras share (cross_cov); None without
        covariances.
        """
        la, lb = self.cameras[a], self.cameras[b]
        if la.cov is None or lb.cov is None:
            return None
        ratio = lb.alpha / la.alpha
        grad = np.array(
            [
                [-ratio / la.alpha, 0.0, 1.0 / la.alpha, 0.0],
                [ratio * la.beta / la.alpha, -ratio, -la.beta / la.alpha, 1.0],
            ]
        )
        joint = np.zeros((4, 4))
        joint[:2, :2], joint[2:, 2:] = la.cov, lb.cov
        joint[:2, 2:] = self.cross_cov(a, b)
        joint[2:, :2] = joint[:2, 2:].T
        return grad @ joint @ grad.T

    def seconds_relation(self, a: str, b: str) -> Relation | None:
        """time_B = alpha * time_A + beta in seconds of each camera's clock (frame 0 or time_s = 0 at 0 s); None without
        both fps.
        """
        fa, fb = self.cameras[a].fps, self.cameras[b].fps
        if not fa or not fb:
            return None
        rel = self.clock_relation(a, b)
        return Relation(rel.alpha * fa / fb, rel.beta / fb)

    def pairs(self) -> dict[str, Relation]:
        """Every ordered pair "A->B" of distinct cameras."""
        return {f"{a}->{b}": self.relation(a, b) for a in self.cameras for b in self.cameras if a != b}

    def start_offset(self, a: str, b: str) -> tuple[float, float | None]:
        """When B's frame 0 was taken, on A's clock: (frames of A, seconds or None).

        Positive: B started after A. Seconds need A's fps.
        """
        frames = float(self.relation(b, a).beta)
        fps = self.cameras[a].fps
        return frames, (frames / fps if fps else None)

    def start_offset_se(self, a: str, b: str) -> tuple[float, float | None] | None:
        """Standard error of start_offset(a, b): (frames of A, seconds or None); None without covariances."""
        cov = self.relation_cov(b, a)
        if cov is None:
            return None
        frames = float(np.sqrt(cov[1, 1]))
        fps = self.cameras[a].fps
        return frames, (frames / fps if fps else None)

    def _offset_errors(self, a: str, b: str) -> dict:
        se = self.start_offset_se(a, b)
        return {} if se is None else {"se_start_offset_frames": se[0], "se_start_offset_s": se[1]}

    def line(self) -> dict:
        """The timeline as a line in R^(N+1): point + s * direction over (sample, frames...)."""
        return {
            "axes": ["target"] + self.names,
            "point": [0.0] + [c.beta for c in self.cameras.values()],
            "direction": [1.0] + [c.alpha for c in self.cameras.values()],
        }

    def to_dict(self) -> dict:
        """The ``timeline.json`` content (contract in docs/formats.md); a number that is not finite
        is written as null.
        """
        return _finite(self._document())

    def _document(self) -> dict:
        first = self.names[0] if self.cameras else None
        cameras = {}
        for name, c in self.cameras.items():
            entry = c.to_dict()
            if first is not None:
                entry["start_offset_frames"], entry["start_offset_s"] = self.start_offset(first, name)
                if name != first:
                    entry.update(self._offset_errors(first, name))
            cameras[name] = entry
        pairs: dict[str, dict[str, Any]] = {}
        for key, rel in self.pairs().items():
            a, b = key.split("->")
            frames, seconds = self.start_offset(a, b)
            pairs[key] = {
                "alpha": rel.alpha,
                "beta": rel.beta,
                "start_offset_frames": frames,
                "start_offset_s": seconds,
            }
            cov = self.relation_cov(a, b)
            if cov is not None:
                pairs[key]["se_alpha"], pairs[key]["se_beta"] = float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))
                pairs[key].update(self._offset_errors(a, b))
            timed = self.seconds_relation(a, b)
            if timed is not None:
                pairs[key]["seconds"] = {"alpha": timed.alpha, "beta": timed.beta}
            if self.approximate(a, b):
                pairs[key].update(approximate=True, exact=artefact_path("frame_map"))
        return {
            "format": "tlsync-timeline",
            "version": FORMAT_VERSION,
            "method": self.method,
            "params": self.params.table(),
            "target": {"rate": self.target_rate, "t0": self.target_t0},
            "reference": first,
            "cameras": cameras,
            "failed": self.failed,
            "status": {name: status.to_dict() for name, status in self.statuses().items()},
            "rejected": {name: line.to_dict() for name, line in self.rejected.items()},
            "warnings": [w.to_dict() for w in self.warnings],
            "line": self.line(),
            "pairs": pairs,
            **(
                {
                    "log_error": {
                        "model": self.log_model,
                        "shared_cov": {k: np.asarray(v).tolist() for k, v in self.shared_cov.items()},
                    }
                }
                if self.log_model
                else {}
            ),
            **({"log_correction": self.log_correction.to_dict()} if self.log_correction is not None else {}),
        }


def _wide_remedy(line: CameraLine) -> str:
    """What narrows a camera's wide interval: by what dominates its own error budget (WIDE_REMEDIES), or WIDE_REMEDY."""
    if line.budget is not None and line.budget.total_frames > 0:
        return WIDE_REMEDIES[line.budget.dominant]
    return WIDE_REMEDY


def _slow_motion(line: CameraLine) -> Reason | None:
    """The ``low_speed`` reason of a camera whose target crosses the view slower than LOW_SPEED_M_S, where the log's
    bias explains more than WIDE_FRAMES of its clock (95 %; LogBiasSummary.spread_frames), or None."""
    bias = line.log_bias
    if bias is None or bias.speed_m_s is None or bias.spread_frames is None or not bias.speed_m_s < LOW_SPEED_M_S:
        return None
    frames = HALF_95 * bias.spread_frames
    if not frames > WIDE_FRAMES:
        return None
    seconds = f"±{frames / line.fps:.2g} s, " if line.fps else ""
    horizontal = math.hypot(bias.se_m[0], bias.se_m[1]) / math.sqrt(2.0)
    return Reason(
        "low_speed",
        WEAK,
        f"the target crosses this view at {bias.speed_m_s:.2g} m/s, where the log's bias (±{horizontal:.2g} m) "
        f"makes its start known to {seconds}±{frames:.1f} of its frames only",
        LOW_SPEED_REMEDY,
    )


def _finite(value):
    """``value`` (JSON-like) with every float that is not finite replaced by None: no NaN or infinity reaches a file."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def eps_t(estimated: Relation, truth: Relation, n_frames_a: int) -> float:
    """Temporal error (eq. 5): mean |estimated - true| frame of B over A's frames 0..n_frames_a-1."""
    frames = np.arange(n_frames_a, dtype=np.float64)
    return float(np.mean(np.abs(estimated(frames) - truth(frames))))


def write_timeline(timeline: Timeline, path: str | Path) -> None:
    """Write ``timeline.json`` (callers that cache use an atomic writer)."""
    Path(path).write_text(json.dumps(timeline.to_dict(), indent=1, allow_nan=False) + "\n", encoding="utf-8")


def read_timeline(path: str | Path) -> Timeline:
    """Read ``timeline.json`` back into a Timeline of typed camera lines (pairs are recomputed)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        cameras = {name: CameraLine.from_dict(name, c) for name, c in data["cameras"].items()}
        rejected = {name: CameraLine.from_dict(name, c) for name, c in data.get("rejected", {}).items()}
        target = data.get("target", {})
        warnings = tuple(StageWarning(w["stage"], w.get("camera"), w["text"]) for w in data.get("warnings", []))
        log_error, correction = data.get("log_error") or {}, data.get("log_correction")
        shared = {
            k: np.asarray(v, dtype=np.float64).reshape(2, 2) for k, v in (log_error.get("shared_cov") or {}).items()
        }
        return Timeline(
            cameras,
            target.get("rate"),
            target.get("t0"),
            data.get("method", "paper"),
            ParamsTable.from_table(data.get("params", {})),
            data.get("failed", {}),
            warnings,
            shared_cov=shared,
            log_model=log_error.get("model"),
            rejected=rejected,
            log_correction=None if correction is None else LogCorrection.from_dict(correction),
        )
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{path}: not a tlsync timeline (missing or malformed field {exc})") from None


def read_truth(path: str | Path) -> tuple[dict[str, Relation], dict[str, int]]:
    """Read ``truth.json``: its pairwise relations and each camera's frame count."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        pairs = {k: Relation(float(v["alpha"]), float(v["beta"])) for k, v in data["pairs"].items()}
        n_frames = {k: int(v) for k, v in data.get("n_frames", {}).items()}
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputError(f"{path}: not a truth file with 'pairs' {{'A->B': {{alpha, beta}}}} ({exc})") from None
    for key, rel in pairs.items():
        if not (math.isfinite(rel.alpha) and math.isfinite(rel.beta)) or "->" not in key:
            raise InputError(f"{path}: pairs[{key!r}]: expected 'A->B' with finite alpha and beta")
    return pairs, n_frames
