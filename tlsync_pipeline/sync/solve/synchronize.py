"""Synchronization of cameras against the target: votes, each camera's line, the timeline.

The same for every sync method (``[sync] method``, sync/solve/registry.py): the
method prepares the trajectory (sync/model/methods.prepare_trajectory); the votes are cast
on that trajectory (``cast_votes``: the vote stage writes these to
votes.npz, the sync stage passes them back in); each camera's votes are put
on its clock (sync/model/clock.py) and the method fits the line. A camera that
brings every mover (detections) instead of a track has its target
identified among them first (sync/identify/identify.py); its line is then fitted on
the identified track's votes (in the pipeline the identify stage writes that
track, and votes.npz holds its votes). A camera without a pose gets it from
the target before anything else (sync/pose/pose.py; in the pipeline, the
calibrate stage, whose pose's timing comes with the camera's inputs,
``CameraInput.pose_timing``): its line is then the pose fit's
(``with_pose_timing``).

Pure functions from typed values to typed values; no file I/O here.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace

import numpy as np

from calibration.camera import Camera
from tlsync_pipeline.artefacts.identification import IdentificationSummary, MoverRival
from tlsync_pipeline.errors import SyncError
from tlsync_pipeline.sync.identify.breaks import identify_in_segments, segment_reasons, with_vote_break
from tlsync_pipeline.sync.identify.followers import AMBIGUOUS_PROBABILITY as FOLLOWER_AMBIGUOUS
from tlsync_pipeline.sync.identify.followers import RIVAL_PROBABILITY as FOLLOWER_PROBABILITY
from tlsync_pipeline.sync.identify.followers import picked_line
from tlsync_pipeline.sync.identify.identify import Identification, identify_params
from tlsync_pipeline.sync.identify.segments import (
    MAX_WHOLE,
    MIN_SEGMENT_FRAMES,
    joined_at_void_breaks,
    segments_of,
    whole_frames,
)
from tlsync_pipeline.sync.kernels.backward import BACKWARD_BELOW, backward_support, line_support
from tlsync_pipeline.sync.kernels.blas import one_blas_thread
from tlsync_pipeline.sync.kernels.slope import slope_prior
from tlsync_pipeline.sync.model.clock import FrameTimes, Segment, camera_clock, image_speed
from tlsync_pipeline.sync.model.log_model import PRESETS, LogModel, log_drift
from tlsync_pipeline.sync.model.methods import method_options, params_table, preparation_of, prepare_trajectory
from tlsync_pipeline.sync.model.params import ParamsTable, SyncParams
from tlsync_pipeline.sync.model.status import AMBIGUOUS, FAILED, HALF_95, WEAK, Reason, diagnosed_failure
from tlsync_pipeline.sync.pose.pose import PoseError, TargetPose, estimate_pose, pose_info, pose_log_sigma
from tlsync_pipeline.sync.pose.pose_timing import PoseTiming
from tlsync_pipeline.sync.solve.causes import explain
from tlsync_pipeline.sync.solve.log_bias import LogBias
from tlsync_pipeline.sync.solve.methods import CameraData, CameraInput, JointMethod
from tlsync_pipeline.sync.solve.plausibility import (
    DIRECTION_MIN,
    RIVAL_BAND_FRAMES,
    RIVAL_PROBABILITY,
    Judged,
    diagnose,
    judge_line,
    line_motion,
    motion_slope,
    rival_odds_of,
)
from tlsync_pipeline.sync.solve.pose_joint import free_pose_correction
from tlsync_pipeline.sync.solve.posed_bias import (
    LATER_ROUNDS,
    ROUNDS,
    bias_correction,
    line_moves,
    refit_kept,
    refit_poses,
    track_middles,
)
from tlsync_pipeline.sync.solve.registry import get_method
from tlsync_pipeline.sync.solve.slow_motion import step_spread
from tlsync_pipeline.sync.timeline import CameraLine, LinePose, LogCorrection, Timeline
from tlsync_pipeline.sync.vote.log_error import gate_model, measured, vote_radius, with_log_noise
from tlsync_pipeline.sync.vote.votes import Votes, compute_votes
from tlsync_pipeline.trajectory import PiecewiseTrajectory, Trajectory
from trackers.track import Track

__all__ = ["CameraInput", "CameraResult", "cast_votes", "identify_and_synchronize", "synchronize", "synchronize_camera"]


@dataclass(frozen=True)
class CameraResult:
    """One camera's votes (frame indices) and fitted line; identification: how its target was found among every mover,
    or None;
    pose: the pose from the target of a camera that had none, or None."""

    votes: Votes
    line: CameraLine
    identification: Identification | None = None
    pose: TargetPose | None = None

    def track(self, inputs: CameraInput) -> Track | None:
        """The track the line was fitted to: the identified one, or the camera's own."""
        return self.identification.track if self.identification is not None else inputs.track


def cast_votes(camera: Camera, track: Track, prepared: Trajectory, eps_px: float) -> Votes:
    """One camera's votes on the prepared trajectory (eq. 3); SyncError when there is none."""
    return compute_votes(camera, track, prepared, eps_px)


def synchronize_camera(
    name: str, inputs: CameraInput, votes: Votes, prepared: Trajectory, params: SyncParams, eps_px: float | None = None
) -> CameraResult:
    """The fitted line of one camera from its votes; SyncError if it cannot be synchronized.

    eps_px: the camera's vote radius (log_error.vote_radius; None: [sync] eps_px).
    """
    track = inputs.track
    assert track is not None, "a camera without a track is identified first (identify_and_synchronize)"
    return CameraResult(
        votes,
        get_method(params.method).fit(
            camera_data(name, inputs, votes, eps_px or params.eps_px), prepared, params, method_options(params)
        ),
    )


def camera_data(
    name: str, inputs: CameraInput, votes: Votes, eps_px: float, segments: tuple[Segment, ...] = ()
) -> CameraData:
    """One camera with a track as a sync method sees it: its track and votes on its clock (with the segments' shifts:
    every frame of the track and the votes in a segment of known shift)."""
    track = inputs.track
    assert track is not None, "a camera without a track is identified first (identify_and_synchronize)"
    clock = replace(camera_clock(track, inputs.fps), segments=segments)
    times = FrameTimes.of_track(track)
    return CameraData(
        name=name,
        camera=inputs.camera,
        track=track,
        fps=clock.fps if clock.fps is not None else inputs.fps,
        votes=votes,
        clock=clock,
        track_clock=clock.clock_at(track.frame, times),
        vote_clock=clock.clock_at(votes.frame, times),
        eps_px=eps_px,
    )


def identify_and_synchronize(
    name: str, inputs: CameraInput, prepared: Trajectory, params: SyncParams, eps_px: float | None = None
) -> CameraResult:
    """A camera that brings every mover: the target identified among them, then its line fitted on the identified
    track's votes.
    """
    assert inputs.detections is not None, "a camera without a track brings every mover"
    radius = eps_px or params.eps_px
    found, breaks = identify_in_segments(
        inputs.camera,
        inputs.detections,
        prepared,
        inputs.fps,
        replace(identify_params(params), eps_px=radius),
        breaks=inputs.breaks,
        pick=picked_line(inputs.pick_start_s, inputs.fps, prepared.rate),
    )
    identified = CameraInput(inputs.camera, found.track, inputs.fps, breaks=breaks)
    result = synchronize_camera(
        name, identified, cast_votes(inputs.camera, found.track, prepared, radius), prepared, params, radius
    )
    line = replace(result.line, identification=found.summary())
    if inputs.pick_start_s is not None and found.rival is not None:
        line = replace(line, flags=(*(line.flags or ()), "picked"))
    return CameraResult(result.votes, line, found)


def _pose_from_target(camera: Camera) -> bool:
    """Whether the camera's pose was fitted to the target (camera.json's pose source "target" or "gcp+target")."""
    return camera.pose_info is not None and "target" in camera.pose_info.source


def posed(
    inputs: CameraInput,
    prepared: Trajectory,
    params: SyncParams,
    log_model: LogModel = PRESETS["none"],
    near: tuple[float, float] | None = None,
) -> tuple[CameraInput, TargetPose]:
    """The camera's inputs with its pose from the target (its ``gcps`` as a prior; the log's error model in the fit),
    and that pose; PoseError when it is not determined.

    near: a later pass's range of beta (clock units) around the line the pass before answered (``search_window``):
    the pose is searched there first, and over every offset the log allows where the pose found there is refused
    or lies near the range's edge (``well_inside``): the pass before searched every offset on a log a few metres
    from this one and found no rival."""
    if near is not None:
        try:
            pose = _pose(inputs, prepared, params, log_model, near)
        except PoseError:
            pose = None
        if pose is not None and well_inside(pose.fit.beta, near):
            return _with_pose(inputs, pose, prepared, log_model), pose
    pose = _pose(inputs, prepared, params, log_model, None)
    return _with_pose(inputs, pose, prepared, log_model), pose


SEARCH_SIGMAS = 6.0  # a later pass's pose search: this many of the line's beta stds either side of the pass before's
SEARCH_S = 30.0  # ... and at least this many seconds either side
EDGE_SHARE = 0.25  # a pose found within this share of the range's half-width from its edge is searched everywhere


def search_window(line: CameraLine, fps: float | None) -> tuple[float, float] | None:
    """The range of beta (clock units) a later pass searches the camera's pose in first: the line the pass before
    answered, SEARCH_SIGMAS of its beta std and at least SEARCH_S seconds (at ``fps``) either side; None without a
    finite covariance or a frame rate."""
    if line.cov is None or not np.isfinite(line.cov).all() or not fps:
        return None
    half = max(SEARCH_SIGMAS * math.sqrt(max(float(line.cov[1][1]), 0.0)), SEARCH_S * fps)
    return line.beta - half, line.beta + half


def well_inside(beta: float, window: tuple[float, float]) -> bool:
    """Whether ``beta`` lies farther than EDGE_SHARE of the window's half-width from both its ends."""
    margin = EDGE_SHARE * 0.5 * (window[1] - window[0])
    return window[0] + margin <= beta <= window[1] - margin


def _pose(
    inputs: CameraInput,
    prepared: Trajectory,
    params: SyncParams,
    log_model: LogModel,
    offsets: tuple[float, float] | None,
) -> TargetPose:
    """The camera's pose from the target, its offset searched within ``offsets`` (None: every one)."""
    pose, _ = estimate_pose(
        inputs.camera,
        inputs.track,
        inputs.detections,
        prepared,
        inputs.fps,
        identify_params(params),
        inputs.gcps,
        offsets=offsets,
        log_model=log_model,
        max_roll_deg=params.upright_roll_deg,
    )
    return pose


def _with_pose(inputs: CameraInput, pose: TargetPose, prepared: Trajectory, log_model: LogModel) -> CameraInput:
    """The camera's inputs with ``pose``."""
    camera = replace(
        pose.camera,
        name=inputs.camera.name,
        fps=inputs.camera.fps,
        pose_info=pose_info(pose, pose_log_sigma(prepared, log_model)),
    )
    return replace(inputs, camera=camera)


def with_pose_line(line: CameraLine, timing: PoseTiming) -> CameraLine:
    """The line of the pose from the target under a log with a bias: the pose fit's slope, the beta that the pose and
    the log's bias fitted together explain best (``PoseTiming.bias_beta``; the pose fit's without one), and the pose
    fit's covariance with the square of the two betas' distance added to beta's variance, and the square of the
    spread of the pose fits that are one timing with it (``PoseTiming.spread``: poses the track tells apart
    no better than the log's bias, one answer). The pose absorbed the
    bias's mean over the visit, and the pose fit counts its wander as error shared by blocks of frames (its beta
    std carries it); the line the votes give under that pose held fixed is pulled by the wander alone (on drone2
    under a drone's GNSS, 4-28 frames off where the pose fit was within 0.3-9). Where the line under that pose held
    fixed has the less certain beta, its covariance is taken instead of the pose fit's: a line with the pose free is
    not known better than with it fixed, and the pose fit's sandwich, on the residuals the robust loss bounds summed
    over pose_fit.BLOCKS blocks, can miss the error a log's fix shares with every frame around it (a 1 Hz log with
    0.3 m of white noise seen at 25 fps: a beta std of 0.41 frame, 3.2 frames off; the line's own 4.6). Unchanged
    when the pose fit has no finite covariance of its line."""
    if timing.cov is None or not np.isfinite(timing.cov).all():
        return line
    beta = timing.bias_beta if np.isfinite(timing.bias_beta) else timing.beta
    cov = np.array(timing.cov, dtype=np.float64)
    if line.cov is not None and np.isfinite(line.cov).all() and line.cov[1, 1] > cov[1, 1]:
        cov = np.array(line.cov, dtype=np.float64)
    cov[1, 1] += (beta - timing.beta) ** 2 + timing.spread**2
    return replace(line, alpha=timing.alpha, beta=beta, cov=cov)


def _with_pose_cov(line: CameraLine, cov: np.ndarray | None, alone: np.ndarray | None) -> CameraLine:
    """The line with the covariance of its pose's refit under the log's bias added (sync/solve/posed_bias.py: the
    joint fit holds the pose fixed), and beta's variance at least ``alone``'s, the line's covariance from its pose
    alone (with_pose_line): on drone2 flown at 1.9 m/s at most under a drone's GNSS the sum alone held 32 of 36
    pairs, the pose alone's 36 of 36. Unchanged without a refit's covariance or without one of its own."""
    if cov is None or line.cov is None:
        return line
    out = np.asarray(line.cov, dtype=np.float64) + cov
    if alone is not None and np.isfinite(alone[1, 1]):
        out[1, 1] = max(out[1, 1], float(alone[1, 1]))
    return replace(line, cov=out)


def with_pose_offset(line: CameraLine, timing: PoseTiming) -> CameraLine:
    """The line of a pose from the target under a log without a bias (with one: with_pose_line), with the pose's
    offset uncertainty added to beta's variance: the line is fitted under that pose held fixed, while the pose and the
    timing trade against each other (on a straight crossing a pose moved along the path is a time shift): the pose
    fit's beta std (clock units). And the line fitted under that pose may leave the pose fit's own line (their beta
    difference, counted as a std too: two fits of one timing on one track)."""
    if line.cov is None or not np.isfinite(timing.se_beta):
        return line
    cov = np.array(line.cov, dtype=np.float64)
    cov[1, 1] += timing.se_beta**2 + (line.beta - timing.beta) ** 2
    return replace(line, cov=cov)


def with_identification_line(line: CameraLine) -> CameraLine:
    """The line of a camera whose target was identified among every mover, with its distance from the line the
    identification's search found over every candidate's votes (IdentificationSummary.search_line) added to its
    covariance as a std (the outer product of their (alpha, beta) difference). The line is refined on the frames
    identification assigned, each the candidate nearest the projection under the line so far: frames of passers-by
    that fit a line a few tenths of a second off are picked as readily as the target's, and a track that mixes them
    fits its own line well, its sandwich narrow. Where the refined line leaves the line every mover's votes back, it
    may have followed them (crowd_inputs seed 8, a white log of 0.3 m declared: 4.3 frames off with a std of 0.47
    frame, the search's line 1.9 frames the other way, 2.4 from the truth). Another mover on the target's path that
    counts (``counted_rival``, sync/identify/followers.py) adds its line's distance, squared, times its probability:
    the line's mean squared error where the truth is one of the two lines. Unchanged without a covariance."""
    found = line.identification
    if found is None or line.cov is None:
        return line
    cov = _with_search_line(np.asarray(line.cov, dtype=np.float64), line, found)
    rival = counted_rival(line, found)
    if rival is not None:
        apart = np.array([rival.alpha - line.alpha, rival.beta - line.beta])
        cov = cov + rival.probability * np.outer(apart, apart)
    return replace(line, cov=cov)


def _with_search_line(cov: np.ndarray, line: CameraLine, found: IdentificationSummary) -> np.ndarray:
    """The covariance with the outer product of the line's (alpha, beta) distance from the identification's search
    line added (unchanged without one)."""
    if found.search_line is None:
        return cov
    gap = np.array([found.search_line[0] - line.alpha, found.search_line[1] - line.beta])
    return cov + np.outer(gap, gap)


def counted_rival(line: CameraLine, found: IdentificationSummary) -> MoverRival | None:
    """Identification's other mover on the target's path (IdentificationSummary.rival) when the log left it at least
    followers.RIVAL_PROBABILITY and its line lies outside the line's interval: the Mahalanobis distance of their
    (alpha, beta) difference, under the line's covariance with the search line's distance added, beyond HALF_95 (a
    line within it changes nothing: on the crowd scenes, passers-by a frame from the target's line). None otherwise;
    a line without a covariance counts every such rival."""
    rival = found.rival
    if rival is None or rival.probability < FOLLOWER_PROBABILITY:
        return None
    if line.cov is None or not np.isfinite(line.cov).all():
        return rival
    cov = _with_search_line(np.asarray(line.cov, dtype=np.float64), line, found)
    gap = np.array([rival.alpha - line.alpha, rival.beta - line.beta])
    return rival if float(gap @ np.linalg.pinv(cov) @ gap) > HALF_95**2 else None


def with_pose_timing(line: CameraLine, timing: PoseTiming | None, log_model: LogModel) -> CameraLine:
    """The line with the timing of its camera's pose from the target (with_pose_line under a log with a bias, else
    with_pose_offset); unchanged for a camera posed otherwise (``timing`` None)."""
    if timing is None:
        return line
    return (with_pose_line if log_model.has_bias else with_pose_offset)(line, timing)


def synchronize(
    cameras: dict[str, CameraInput],
    trajectory: Trajectory,
    params: SyncParams,
    votes: Mapping[str, Votes | SyncError] | None = None,
    log_model: LogModel = PRESETS["none"],
) -> tuple[Timeline, dict[str, CameraResult]]:
    """The timeline of all cameras that can be synchronized.

    votes: each camera's votes as the vote stage cast them (cast_votes on
    prepare_trajectory's output with each camera's vote_radius), or the
    SyncError it met; None (or a camera missing from it): cast here.
    log_model: what is known of the log's error
    (sync/model/log_model.py): it widens each camera's vote radius and, with
    a bias and a method that can (the refined one), the lines are fitted
    together with the bias, their intervals including what it leaves
    uncertain. Every line is first checked against its camera's evidence
    (sync/solve/plausibility.py): a line the checks contradict, or with a rival as
    strong, is not synchronized (``Timeline.rejected``) and takes no part in
    the joint fit. Cameras that cannot be synchronized are listed in
    ``Timeline.failed`` with the reason; a camera whose fit raises anything
    else fails alone. Raises LogUnitError (an InputError) when every
    camera's evidence says the log is not in seconds or metres.

    Where the poses from the target are refitted under the bias and the refit
    is not kept (_joint_lines), or a camera whose pose is to come from the
    target is refused under a log with a bias while others are synchronized,
    the log is corrected by the bias fitted with the synchronized cameras'
    lines and their poses from the target free (sync/solve/pose_joint.py)
    and every camera is synchronized again on it, the poses from the target
    searched again (a second pass; its votes cast here, except that a camera
    without a track keeps the vote stage's error: its target was never
    identified), first near the line the pass before answered (``posed``'s
    ``near``, ``search_window``), and refitted in LATER_ROUNDS. A pass that
    synchronizes more cameras than the one before corrects the log again for
    another, up to MAX_PASSES (``corrects_again``):
    the cameras it adds see the target from other directions, and the bias
    they fit with the others is the log's where a camera still refused needs
    it. The last pass's timeline is the answer.

    A line fitted with a pose the sync found itself (posed here, searched
    again in a later pass, refitted under the log's bias) carries it
    (``CameraLine.pose``): the pose its pictures are drawn with, on the log
    corrected as the poses were fitted on it (``Timeline.log_correction``:
    the passes' corrections in all, plus the bias the last pass's lines'
    poses were fitted on, ``drawn_on``).

    Runs with one BLAS thread (sync/kernels/blas.py), as the sync stage does.
    """
    with one_blas_thread():
        timeline, results, step = _synchronize_pass(cameras, trajectory, params, votes, log_model, None, False, {})
        again = {n: _unposed(inputs) if _pose_from_target(inputs.camera) else inputs for n, inputs in cameras.items()}
        untracked = {n: v for n, v in (votes or {}).items() if isinstance(v, SyncError) and cameras[n].track is None}
        correction = None
        for count in range(2, MAX_PASSES + 1):
            if step is None:
                break
            correction = step if correction is None else correction.plus(step)
            windows = {n: search_window(line, cameras[n].fps) for n, line in timeline.cameras.items()}
            timeline, results, step = _synchronize_pass(
                again,
                correction.applied(trajectory),
                params,
                untracked,
                log_model,
                len(timeline.cameras),
                count == MAX_PASSES,
                {n: w for n, w in windows.items() if w is not None},
            )
    return replace(timeline, log_correction=drawn_on(correction, timeline.log_correction)), results


def drawn_on(passes: LogCorrection | None, last: LogCorrection | None) -> LogCorrection | None:
    """The log's correction on which the answer's poses were fitted: the passes' (``passes``: what the sync took out
    of the log before the last pass), then the bias the last pass's lines' poses were fitted on (``last``, on the log
    the passes corrected: its kept refit's, or the joint fit's where no pose came from the target); None when
    neither."""
    if passes is None or last is None:
        return passes if last is None else last
    return passes.plus(last)


MAX_PASSES = 4  # synchronize()'s passes at most: the first, then passes on the log corrected by the one before


def corrects_again(previous: int | None, kept: bool, pose_refused: bool, synchronized: int) -> bool:
    """Whether a pass that synchronized ``synchronized`` cameras corrects the log for another pass: the first
    (``previous`` None) where its refit of the poses from the target is not ``kept`` or where, under a log with a
    bias, it refused a camera whose pose is to come from the target (``pose_refused``); a later one (``previous``: the
    cameras the pass before it synchronized) where it synchronized more cameras than the pass before: the log it ran
    on was corrected without them, and the answer is the pass on the log every answered camera corrected."""
    if previous is None:
        return not kept or pose_refused
    return synchronized > previous


def _unposed(inputs: CameraInput) -> CameraInput:
    """A camera posed from the target (by the calibrate stage) as it came: its pose to be estimated."""
    return replace(inputs, camera=inputs.camera.without_pose(), pose_timing=None)


def _synchronize_pass(
    cameras: dict[str, CameraInput],
    trajectory: Trajectory,
    params: SyncParams,
    votes: Mapping[str, Votes | SyncError] | None,
    log_model: LogModel,
    previous: int | None,
    last: bool,
    windows: Mapping[str, tuple[float, float]],
) -> tuple[Timeline, dict[str, CameraResult], LogCorrection | None]:
    """One pass of synchronize(): its timeline and results, and the log's further correction for another pass where
    this one calls for it (``corrects_again``; ``previous``: the cameras the pass before synchronized, None for the
    first; ``last``: no pass follows), or None; ``windows``: where a camera's pose from the target is searched first
    (``posed``'s ``near``), for the cameras the pass before answered. The timeline's log_correction is the bias its
    lines' poses were fitted on (_joint_lines), on the log the pass was given (None without one)."""
    declared, log_model, gated = log_model, measured(log_model, trajectory), gate_model(log_model, trajectory)
    prepared = with_log_noise(prepare_trajectory(trajectory, preparation_of(params)), log_model)
    path = PiecewiseTrajectory(prepared)
    results: dict[str, CameraResult] = {}
    failed: dict[str, str] = {}
    judged: dict[str, Judged] = {}
    radius: dict[str, float] = {}
    used: dict[str, CameraInput] = {}
    for name, inputs in cameras.items():
        prior = slope_prior(inputs.fps, trajectory.rate, params.rate_sigma)
        try:
            cast = votes.get(name) if votes is not None else None
            if isinstance(cast, SyncError):
                raise cast
            pose = None
            if not inputs.camera.posed:
                inputs, pose = posed(inputs, prepared, params, log_model, windows.get(name))
            timing = pose.timing if pose is not None else inputs.pose_timing
            used[name] = inputs
            radius[name] = vote_radius(inputs.camera, prepared, params.eps_px, gated)
            if inputs.track is None:
                result = identify_and_synchronize(name, inputs, prepared, params, radius[name])
            else:
                cast = cast if cast is not None else cast_votes(inputs.camera, inputs.track, prepared, radius[name])
                if inputs.pick_start_s is not None:
                    cast = picked_votes(name, inputs, cast, trajectory.rate, radius[name])
                result = synchronize_camera(name, inputs, cast, prepared, params, radius[name])
                if inputs.pick_start_s is not None:
                    result = replace(result, line=replace(result.line, flags=(*(result.line.flags or ()), "picked")))
            inputs, result = _segmented(name, inputs, result, prepared, params, radius[name], log_model)
            result = replace(result, line=with_pose_timing(result.line, timing, log_model))
            results[name], judged[name] = _judge(
                name, inputs, replace(result, pose=pose), path, params, prior, radius[name], log_model, trajectory.rate
            )
            search = results[name].line.line_search
            if (
                cameras[name].track is not None
                and search is not None
                and search.rival_probability is not None
                and search.rival_probability > 1.0 - RIVAL_PROBABILITY
            ):
                result = _the_rival(name, inputs, results[name], prepared, params, radius[name])
                result = replace(result, line=with_pose_timing(result.line, timing, log_model))
                results[name], judged[name] = _judge(
                    name,
                    inputs,
                    replace(result, pose=pose),
                    path,
                    params,
                    prior,
                    radius[name],
                    log_model,
                    trajectory.rate,
                )
        except SyncError as exc:
            failed[name] = str(exc)
            judged[name] = _unjudged(inputs, prior)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            failed[name] = f"camera {name}: the fit failed ({type(exc).__name__}: {exc})"
            judged[name] = _unjudged(inputs, prior)
    found = diagnose(judged, prepared, params.eps_px)  # first: the log's units, which explain everything else
    found = {**explain(judged, prepared, params.eps_px, params.logged_point_above_m, radius, log_model), **found}
    for name in failed.keys() & found.keys():
        failed[name] = diagnosed_failure(name, found[name], failed[name])
    lines, rejected = {}, {}
    for name, result in results.items():
        line = result.line
        if name in found:  # the cause found comes first: its remedy is the camera's
            line = replace(line, checks=(found[name], *(line.checks or ())))
        stopping = [r.text for r in line.checks or () if r.severity in (AMBIGUOUS, FAILED)]
        if stopping:
            rejected[name] = line
            failed[name] = f"camera {name}: " + "; ".join(stopping)
        else:
            lines[name] = line
    shared: dict[str, np.ndarray] = {}
    fitted_model, estimate, correction, drawn = log_model, None, None, None
    method = get_method(params.method)
    # A camera whose pose comes from the target absorbed the log's error during its visit in that pose: under a log
    # with a bias and other cameras to tell it apart its pose is fitted again under the bias's estimate
    # (sync/solve/posed_bias.py), kept where the lines stay where the poses alone allow; otherwise it stays out, and
    # the first pass gives the log corrected by the bias fitted with such poses free for a second (pose_joint.py).
    posed_here = {name for name in lines if _pose_from_target(used[name].camera)}
    joint = log_model.has_bias or log_model.white_m > 0  # a bias, or white noise cameras may see at the same time
    if params.log_bias and joint and isinstance(method, JointMethod):
        data = {
            name: camera_data(
                name, replace(used[name], track=results[name].track(used[name])), results[name].votes, radius[name]
            )
            for name in lines
        }
        rounds = ROUNDS if previous is None else LATER_ROUNDS
        fitted, bias, kept, drawn = _joint_lines(method, data, lines, posed_here, prepared, params, log_model, rounds)
        lines = {**lines, **fitted}
        pose_refused = log_model.has_bias and any(
            not cameras[n].camera.posed or _pose_from_target(cameras[n].camera) for n in failed
        )
        if lines and not last and corrects_again(previous, kept, pose_refused, len(lines)):
            correction = free_pose_correction(data, lines, posed_here, prepared, params, log_model)
        if bias is not None:
            fitted_model, estimate = bias.model, bias.estimate
            names = [n for n in lines if n in bias.sensitivity]
            shared = {f"{a}|{b}": bias.line_cov(a, b) for i, a in enumerate(names) for b in names[i + 1 :]}
    searched = "target" if previous is None else "second_pass"
    lines = {n: _with_pose_used(line, cameras[n].camera, used[n].camera, searched) for n, line in lines.items()}
    rejected = {n: _with_pose_used(line, cameras[n].camera, used[n].camera, searched) for n, line in rejected.items()}
    timeline = Timeline(
        {name: with_identification_line(line) for name, line in lines.items()},
        trajectory.rate,
        trajectory.t0,
        method=params.method,
        params=ParamsTable.from_table(params_table(params)),
        failed={name: failed[name] for name in cameras if name in failed},
        rejected=rejected,
        shared_cov=shared,
        log_model=_log_error(fitted_model, declared, estimate, gated),
        log_correction=drawn,
    )
    return timeline, results, correction


def _with_pose_used(line: CameraLine, given: Camera, used: Camera, searched: str) -> CameraLine:
    """The line with the pose it was fitted with (CameraLine.pose) where that is not its camera's as given
    (``given``): the pose ``used``, searched in this pass (``searched``: "target", "second_pass") for a camera that
    came without one, then refitted under the log's bias where _joint_lines kept the refit (the line's pose
    "bias_refit" already). Unchanged otherwise."""
    if given.posed:
        return line
    if line.pose is None:
        return replace(line, pose=LinePose.of(used, searched))
    return replace(line, pose=replace(line.pose, source=f"{searched}+{line.pose.source}"))


def _joint_lines(
    method: JointMethod,
    data: dict[str, CameraData],
    lines: dict[str, CameraLine],
    posed: set[str],
    prepared: Trajectory,
    params: SyncParams,
    log_model: LogModel,
    rounds: int,
) -> tuple[dict[str, CameraLine], LogBias | None, bool, LogCorrection | None]:
    """The lines fitted together with the log's error (``method.refine_with_log_bias``), its estimate (None: not
    fitted), whether a refit of the poses from the target was kept (True where none was made), and the correction of
    ``prepared`` the lines' poses were fitted on: the kept refit's (PoseRefit.correction), or where no pose came from
    the target the bias every line was fitted with (joint_correction); None otherwise. Under a
    log with a bias and with two cameras or more, the cameras ``posed`` from the target take part, their poses fitted
    again under the bias's estimate in ``rounds`` rounds (posed_bias.refit_poses: ROUNDS in the first pass,
    LATER_ROUNDS in a later one), their intervals with the refit's covariance (_with_pose_cov); where their lines
    leave the poses alone's farther than those allow (posed_bias.refit_kept, or already on the poses alone:
    refit_hopeless), or otherwise, they stay out and keep their lines. A kept refit's lines carry their refitted poses
    (CameraLine.pose, source "bias_refit")."""
    kept, refit = True, None
    if log_model.has_bias and len(lines) >= 2 and posed:
        refit, kept = refit_poses(method, data, lines, posed, prepared, params, log_model, rounds), False
    if refit is not None:
        fitted, bias = method.refine_with_log_bias(
            refit.data, {**lines, **refit.lines}, prepared, params, method_options(params), log_model
        )
        middles = track_middles(data, posed)
        if refit_kept(line_moves(middles, lines, {n: fitted[n] for n in posed if n in fitted})):
            merged = {**refit.lines, **fitted}
            widened = {n: _with_pose_cov(line, refit.covs.get(n), lines[n].cov) for n, line in merged.items()}
            refitted = {n: LinePose.of(refit.data[n].camera, "bias_refit") for n in refit.covs}
            on = refit.correction if refitted else None
            return {n: replace(line, pose=refitted.get(n)) for n, line in widened.items()}, bias, True, on
    surveyed = {n: data[n] for n in data if n not in posed}
    if not surveyed:
        return {}, None, kept, None
    fitted, bias = method.refine_with_log_bias(
        surveyed, {n: lines[n] for n in surveyed}, prepared, params, method_options(params), log_model
    )
    return fitted, bias, kept, (None if posed else joint_correction(bias, set(lines)))


def joint_correction(bias: LogBias | None, names: set[str]) -> LogCorrection | None:
    """The log's correction by the bias the lines of the cameras ``names`` were all fitted together with (source
    "log_bias"): where no pose came from the target, each of those lines is on the log so corrected. None where a
    camera left that fit, or without a bias (none fitted, at its prior, or the white error at each fix:
    fit_white_log)."""
    if bias is None or not bias.model.has_bias or not names <= set(bias.lines) or not np.any(bias.values):
        return None
    return bias_correction(bias, "log_bias")


PICK_BAND_S = 0.5  # a picked line keeps the votes within this many seconds of it (at least one pass's band)


def picked_votes(name: str, inputs: CameraInput, votes: Votes, rate: float | None, radius_px: float) -> Votes:
    """The camera's votes near the line the user picked (``CameraInput.pick_start_s``: the log's time, seconds after its
    first fix, at the video's first frame; slope fps / rate): ``votes_near`` that line. SyncError when none is left or
    the rates are unknown."""
    track, start = inputs.track, inputs.pick_start_s
    assert track is not None and start is not None
    fps = camera_clock(track, inputs.fps).fps or inputs.fps
    if not fps or not rate:
        raise SyncError(f"camera {name}: pick_start_s needs the camera's fps and the log's times")
    near = votes_near(inputs, votes, fps / rate, -fps * start, radius_px)
    if not near.any():
        raise SyncError(
            f"camera {name}: no vote near the picked start (pick_start_s = {start:g}): give one of the starts its "
            f"ambiguous status names, or remove the key"
        )
    return Votes(votes.frame[near], votes.sample[near], votes.dist[near])


def votes_near(
    inputs: CameraInput, votes: Votes, alpha: float, beta: float, radius_px: float, widest: float = math.inf
) -> np.ndarray:
    """Mask of the votes within PICK_BAND_S of the line clock = alpha x sample + beta, or within the band one pass's
    votes span (the vote radius over the target's median image speed), whichever is wider, and at most ``widest``
    clock units."""
    track = inputs.track
    assert track is not None
    clock = camera_clock(track, inputs.fps)
    fps = clock.fps or inputs.fps or 1.0
    times = FrameTimes.of_track(track)
    speed = image_speed(clock.clock_at(track.frame, times), track.xy, quantile=0.5)
    band = min(max(PICK_BAND_S * fps, radius_px / speed if speed else 0.0), widest)
    return np.abs(clock.clock_at(votes.frame, times) - alpha * votes.sample - beta) <= band


def _the_rival(
    name: str, inputs: CameraInput, result: CameraResult, prepared: Trajectory, params: SyncParams, radius_px: float
) -> CameraResult:
    """The camera's line refitted on the votes near the line search's rival, which the whole track prefers beyond
    1 - RIVAL_PROBABILITY (plausibility.rival_odds_of): the old line becomes its rival (line_search), to be weighed
    again. The votes kept are those of the band the odds profiled the rival's intercept over (at most
    RIVAL_BAND_FRAMES): a hovering target's band of one pass spans tens of seconds, and a refit over all of it may
    land as far from the rival as the old line was."""
    old = result.line.line_search
    assert old is not None and old.rival_alpha is not None and old.rival_beta is not None
    near = votes_near(inputs, result.votes, old.rival_alpha, old.rival_beta, radius_px, RIVAL_BAND_FRAMES)
    refit = synchronize_camera(
        name,
        inputs,
        Votes(result.votes.frame[near], result.votes.sample[near], result.votes.dist[near]),
        prepared,
        params,
        radius_px,
    )
    search = refit.line.line_search
    if search is None:
        return refit
    swapped = replace(
        search, runner_up_frames=old.support_frames, rival_alpha=old.alpha, rival_beta=old.beta, rival_probability=None
    )
    return replace(refit, votes=result.votes, line=replace(refit.line, line_search=swapped))


def _log_error(
    model: LogModel, declared: LogModel, estimate: tuple[float, float] | None, gate: LogModel
) -> dict | None:
    """timeline.json's log_error model: the model the sync used, which of its values were measured, the declared
    preset (their prior), the model whose error set the vote radius and gates (gate_model: a suggested receiver's
    fixes that read as an unbiased one's gate as that), and the bias's marginal-likelihood estimate (applied only when
    it rejects the preset's bias: fit_log_bias_measured)."""
    if model.white_m <= 0 and not model.has_bias:
        return None
    prior = {k: v for k, v in asdict(declared).items() if k != "measured"}
    gated = {k: getattr(gate, k) for k in ("name", "white_m", "bias_m", "bias_vertical_m")}
    record = {**asdict(model), "measured": list(model.measured), "prior": prior, "gate": gated}
    if estimate is not None:
        record["estimate"] = {"bias_m": estimate[0], "tau_s": estimate[1]}
    return record


def _segmented(
    name: str,
    inputs: CameraInput,
    result: CameraResult,
    prepared: Trajectory,
    params: SyncParams,
    radius_px: float,
    log_model: LogModel,
) -> tuple[CameraInput, CameraResult]:
    """A camera whose recording breaks (its own breaks, or a drop its votes show) fitted as segments
    (sync/identify/segments.py).

    The votes say which segments the target visits and their shifts to
    within a frame or so; each such segment's line is then fitted on its own
    frames (the method's fit, its slope held by the prior) and its shift is
    where that line meets the best-supported segment's, at the middle of its
    frames (a line fitted across segments of different offsets tilts, and
    shifts measured against it miss their whole frames). The camera's line
    is fitted again on every segment of known shift, its clock carrying
    them; the inputs then hold the track of those segments. Unchanged
    without a break, or when no segment's shift is known (the break's reason
    then refuses it, sync/identify/breaks.py). A drop's step is judged on the votes within eps_px of the track
    and must exceed what the log's bias explains (``_bias_step``).
    """
    track = result.track(inputs)
    assert track is not None, "a fitted camera has a track"
    clock = camera_clock(track, inputs.fps)
    times = FrameTimes.of_track(track)
    votes, line = result.votes, result.line
    vote_clock = clock.clock_at(votes.frame, times)
    least = _bias_step(inputs, track, clock.clock_at(track.frame, times), line, prepared, log_model)
    breaks = with_vote_break(
        inputs.breaks, votes.frame, vote_clock, votes.sample, votes.dist, line, params.delta, params.eps_px, least
    )
    coarse, breaks = segments_of(
        breaks,
        track.frame,
        votes.frame,
        vote_clock,
        votes.sample,
        votes.dist,
        line.alpha,
        line.beta,
        params.delta,
        clock.vfr,
    )
    inputs = replace(inputs, track=track, breaks=breaks)
    main = next((seg for seg in coarse if seg.source == "line"), None)
    if main is None:
        return inputs, replace(result, line=replace(line, breaks=breaks or None))
    reference = _segment_line(name, inputs, votes, main, prepared, params, radius_px) or line
    segments = tuple(
        _refined(
            seg, _segment_line(name, inputs, votes, seg, prepared, params, radius_px), reference, clock, times, track
        )
        for seg in coarse
    )
    segments, breaks = joined_at_void_breaks(segments, breaks)
    inputs = replace(inputs, breaks=breaks)
    segmented = replace(clock, segments=segments)
    keep_track = np.isfinite(segmented.clock_at(track.frame, times))
    keep_votes = np.isfinite(segmented.clock_at(votes.frame, times))
    kept = _track_rows(track, keep_track)
    kept_votes = Votes(votes.frame[keep_votes], votes.sample[keep_votes], votes.dist[keep_votes])
    data = camera_data(name, replace(inputs, track=kept), kept_votes, radius_px, segments)
    fitted = get_method(params.method).fit(data, prepared, params, method_options(params))
    return replace(inputs, track=kept), replace(
        result, votes=kept_votes, line=replace(fitted, identification=line.identification, breaks=breaks)
    )


def _bias_step(
    inputs: CameraInput, track: Track, track_clock: np.ndarray, line: CameraLine, prepared: Trajectory, log: LogModel
) -> Callable[[float], float]:
    """The least step of a camera's votes (clock units) its log's bias cannot explain, as a function of the frame the
    step is placed at: STEP_BIAS_SIGMAS stds of the difference between the visit's parts before and after it, each
    shifted by the bias along the target's motion there (sync/solve/slow_motion.py ``step_spread``). A turn, or a
    change of speed, turns a bias into such a step. 0 without a bias; inf without a frame rate."""
    if not log.has_bias:
        return lambda _: 0.0
    if inputs.fps is None:
        return lambda _: math.inf
    bias_sd = np.array([log.bias_m, log.bias_m, log.bias_vertical_m])
    spread = step_spread(
        inputs.camera,
        track.frame,
        track_clock,
        track.xy,
        PiecewiseTrajectory(prepared),
        line.alpha,
        line.beta,
        bias_sd,
        inputs.fps,
    )
    return lambda frame: STEP_BIAS_SIGMAS * spread(frame)


def _track_rows(track: Track, rows: np.ndarray) -> Track:
    """The track's rows ``rows`` (a boolean mask)."""

    def kept(column: np.ndarray | None) -> np.ndarray | None:
        return None if column is None else np.asarray(column)[rows]

    return Track(
        track.frame[rows],
        track.x[rows],
        track.y[rows],
        kept(track.time_s),
        kept(track.w),
        kept(track.h),
        kept(track.score),
    )


def _segment_line(
    name: str,
    inputs: CameraInput,
    votes: Votes,
    seg: Segment,
    prepared: Trajectory,
    params: SyncParams,
    radius_px: float,
) -> CameraLine | None:
    """The method's line through one segment's tracked frames and votes alone (steady clock); None when the segment
    has no measured shift, too few frames, or the fit fails."""
    track = inputs.track
    assert track is not None, "a fitted camera has a track"
    rows = (track.frame >= seg.start) & (track.frame < seg.stop)
    if seg.shift is None or rows.sum() < MIN_SEGMENT_FRAMES:
        return None
    in_votes = (votes.frame >= seg.start) & (votes.frame < seg.stop)
    own = Votes(votes.frame[in_votes], votes.sample[in_votes], votes.dist[in_votes])
    try:
        return get_method(params.method).fit(
            camera_data(name, replace(inputs, track=_track_rows(track, rows)), own, radius_px),
            prepared,
            params,
            method_options(params),
        )
    except (SyncError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        return None


def _refined(
    seg: Segment, own: CameraLine | None, reference: CameraLine, clock, times: FrameTimes | None, track: Track
) -> Segment:
    """The segment with its shift where its own line meets the reference line at the middle of its tracked frames;
    as it was without its own line. On a frame clock a shift of up to MAX_WHOLE frames is whole frames
    (sync/segments.whole_frames), and one that is not close to them is unresolved (unknown): a pose error biases
    segments seen in different parts of the image differently."""
    if own is None or seg.source == "line":
        return seg
    middle = float(np.median(clock.clock_at(track.frame[(track.frame >= seg.start) & (track.frame < seg.stop)], times)))
    sample = (middle - own.beta) / own.alpha
    shift = reference.alpha * sample + reference.beta - middle
    if clock.vfr or abs(shift) > MAX_WHOLE:
        return replace(seg, shift=round(shift, 4))
    whole = whole_frames(shift)
    return replace(seg, shift=whole) if whole == round(whole) else replace(seg, shift=None, source="unresolved")


STEP_BIAS_SIGMAS = 3.0  # a step of the votes within this many stds of what the log's bias explains is no drop
CROWDED = 1.5  # voting detections per identified frame above which other movers are within the vote radius


def _loose_identity(radius_px: float) -> Reason:
    """AMBIGUOUS: the target was picked among movers on few frames through a log whose error covers other movers too
    (on crowd scenes with a phone's log such picks were walkers 6-45 s off, with intervals of a second)."""
    return Reason(
        "ambiguous_identity",
        AMBIGUOUS,
        f"the target was picked among the movers on few frames, through a log whose error spans {radius_px:.0f} px: "
        f"another mover may fit as well",
        "give the tracker an init box on the target, a longer pass through the view, or a more accurate log",
    )


def follower_reason(
    line: CameraLine, summary: IdentificationSummary, fps: float | None, rate: float | None
) -> Reason | None:
    """When identification weighed another mover on the target's path against the identified track
    (sync/identify/followers.py) and counts (``counted_rival``): WEAK, its interval
    reaching the other mover's line (``with_identification_line``), or AMBIGUOUS when the other mover is at least
    as probable (FOLLOWER_AMBIGUOUS). The reason gives both lines' starts (the log's time at the video's first frame)
    with their probabilities, and what settles it."""
    rival = counted_rival(line, summary)
    if rival is None:
        return None
    starts = [(-line.beta / line.alpha, 1.0 - rival.probability), (-rival.beta / rival.alpha, rival.probability)]
    unit = (lambda s: f"{s / rate:.2f} s") if rate else (lambda s: f"sample {s:.1f}")
    shift = starts[1][0] - starts[0][0]
    apart = f"{abs(shift) / rate:.2g} s" if rate else f"{abs(shift):.1f} samples"
    side = "behind" if shift < 0 else "ahead of"
    key = "pick_start_s" if rate else "pick_start_sample"
    ambiguous = rival.probability >= FOLLOWER_AMBIGUOUS
    return Reason(
        "ambiguous" if ambiguous else "another_mover",
        AMBIGUOUS if ambiguous else WEAK,
        f"another mover walks the target's path {apart} {side} the identified one ({rival.frames} against "
        f"{summary.identified_frames} frames), and the log, paired sample by sample, leaves both possible: the "
        f"video's first frame at " + " or at ".join(f"{unit(s)} of the log ({p:.0%})" for s, p in starts),
        f"a tracker init box on the target, or a log more accurate than the two movers' distance apart, settles it; "
        f"or pick one: [[cameras]] {key} = one of these starts (docs/project.md)",
    )


def _unjudged(inputs: CameraInput, prior) -> Judged:
    """What ``diagnose`` knows of a camera without a line: its track, when its camera has a pose to project with."""
    return Judged(
        inputs.camera, inputs.track if inputs.camera.posed else None, None, None if prior is None else prior.alpha, True
    )


def _judge(
    name: str,
    inputs: CameraInput,
    result: CameraResult,
    path: PiecewiseTrajectory,
    params: SyncParams,
    prior,
    radius_px: float,
    log_model: LogModel,
    rate: float | None,
) -> tuple[CameraResult, Judged]:
    """The camera's result with its line checked (CameraLine.checks) at its vote radius (pixels), and what ``diagnose``
    needs of it.

    A rival line of the line search is weighed on the whole track under the
    log's error model first (plausibility.rival_odds_of: its probability goes
    into the line's line_search summary, which the rival check reads).

    A line with a non-finite slope or intercept is a SyncError; a covariance
    that is not finite or has a negative variance is dropped (no interval
    rather than a meaningless one).
    """
    line = result.line
    if not (math.isfinite(line.alpha) and math.isfinite(line.beta)) or line.alpha <= 0:
        raise SyncError(f"camera {name}: no usable line (alpha {line.alpha:g}, beta {line.beta:g})")
    if line.cov is not None and not (np.isfinite(line.cov).all() and (np.diag(line.cov) >= 0).all()):
        line = replace(line, cov=None)
    track = inputs.track if inputs.track is not None else result.identification.track  # type: ignore[union-attr]
    clock = replace(camera_clock(track, inputs.fps), segments=line.clock.segments)
    times = FrameTimes.of_track(track)
    track_clock = clock.clock_at(track.frame, times)
    fps = clock.fps if clock.fps is not None else inputs.fps
    votes = result.votes
    vote_clock = clock.clock_at(votes.frame, times)
    slope = motion_slope(inputs.camera, track, track_clock, path, vote_clock, votes.sample, fps)
    alpha_prior = None if prior is None else prior.alpha
    thin = (
        line.line_search.support_frames
        if line.line_search is not None
        else line_support(votes.sample, vote_clock, line.alpha, line.beta, params.delta)
    )
    support: tuple[int, int | None] = (thin, None)
    if thin < BACKWARD_BELOW:  # a thin line: would the log read backwards explain the votes better?
        support = (
            line_support(votes.sample, vote_clock, line.alpha, line.beta, params.delta),
            backward_support(votes.sample, vote_clock, votes.dist, params.delta, prior, params.seed),
        )
    odds = rival_odds_of(inputs.camera, track, track_clock, path, line, radius_px, fps, log_model, rate)
    if odds is not None and line.line_search is not None:
        found = line.line_search
        if odds.scanned is not None:  # the scan's line is the rival: the frames with a vote near it back it
            alpha, beta = odds.scanned
            frames = line_support(votes.sample, vote_clock, alpha, beta, params.delta)
            found = replace(found, rival_alpha=alpha, rival_beta=beta, runner_up_frames=frames)
        line = replace(line, line_search=replace(found, rival_probability=odds.rival_probability))
    motion = line_motion(
        inputs.camera, track, track_clock, path, line.alpha, line.beta, fps, log_drift(log_model, rate)
    )
    checks = judge_line(
        inputs.camera, track, track_clock, path, line, radius_px, fps, alpha_prior, slope, support, rate, motion
    )
    checks = (
        *checks,
        *segment_reasons(
            inputs.breaks,
            line.clock.segments,
            track.frame,
            votes.frame,
            vote_clock,
            votes.sample,
            line.alpha,
            line.beta,
            params.delta,
        ),
    )
    others = (
        line.identification is not None
        and line.identification.candidates_voting > CROWDED * line.identification.identified_frames
    )
    if inputs.detections is not None and radius_px > params.eps_px and "few_inliers" in (line.flags or ()) and others:
        checks = (*checks, _loose_identity(radius_px))
    summary = line.identification or inputs.identification
    if summary is not None and inputs.pick_start_s is None:
        follower = follower_reason(line, summary, fps, rate)
        checks = (*checks, follower) if follower is not None else checks
    line = replace(line, checks=checks)
    contradicted = any(r.severity == FAILED for r in checks)
    paced = motion.speed if motion.measured and motion.direction >= DIRECTION_MIN else None
    return replace(result, line=line), Judged(inputs.camera, track, slope, alpha_prior, contradicted, paced)
