"""Each camera's status, the one model every output speaks: ok, weak, ambiguous or failed, with reasons and a remedy.

- ``ok``: synchronized, nothing to say;
- ``weak``: synchronized, with a stated reason (few frames, motion along the
  viewing ray, an interval wider than a frame, ...); its interval says how
  far off it may be;
- ``ambiguous``: two lines far apart have comparable support: not
  synchronized;
- ``failed``: not synchronized: no line, or a line the camera's own evidence
  contradicts (the plausibility checks, sync/solve/plausibility.py), or a task of
  the camera that did not complete.

A status is the worst severity among its reasons; each ``Reason`` has a
stable ``code``, a sentence with the numbers and a remedy. Reasons come
from the line's flags (``FLAGS``: a flag another part of tlsync adds to a
line becomes a reason by adding it there), its warnings, its
``checks`` (the plausibility checks' reasons), its interval, and
``Timeline.failed`` (``Timeline.status``, sync/timeline.py). That status is
what timeline.json, ``tlsync status --json``, the terminal table,
report.html and the exit code all use: exit 0 only when every camera is ok
or weak.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

OK, WEAK, AMBIGUOUS, FAILED = "ok", "weak", "ambiguous", "failed"
SEVERITY = {OK: 0, WEAK: 1, AMBIGUOUS: 2, FAILED: 3}
SYNCHRONIZED = (OK, WEAK)
HALF_95 = 1.959964  # normal quantile of a two-sided 95 % interval
WIDE_FRAMES = 1.0  # a start known to more than this many of the camera's frames (95 %) is weak
LOW_SPEED_M_S = 2.0  # a target slower than this across a view (the hovers of consumer drones, walkers) ...
LOW_SPEED_REMEDY = (  # ... whose log's bias alone makes the start wide: what would settle it
    "a pass of the target at speed through this view, or a better log (RTK): a metre of bias is seconds at this speed"
)
WIDE_REMEDY = "a longer or better-calibrated pass of the target through the view narrows it"
# What to do about a wide interval, by what dominates it (timeline.ErrorBudget.dominant).
WIDE_REMEDIES = {
    "log": "the log's error dominates: use a better log (RTK, more fixes a second), or walk a curved path through "
    "this view",
    "calibration": "calibration or pose dominates: add or check ground control points, or check the camera's "
    "calibration",
    "tracking": "tracking dominates: a longer or closer pass through the view, or a sharper video",
}


@dataclass(frozen=True)
class Reason:
    """Why a camera is not plainly ok: a stable code, how serious (WEAK, AMBIGUOUS or FAILED), a
    sentence, what to do.
    """

    code: str
    severity: str
    text: str
    remedy: str

    def to_dict(self) -> dict:
        return {"code": self.code, "severity": self.severity, "text": self.text, "remedy": self.remedy}

    @classmethod
    def from_dict(cls, entry: dict) -> Reason:
        return cls(str(entry["code"]), str(entry["severity"]), str(entry["text"]), str(entry.get("remedy", "")))


# A line's flags (CameraLine.flags) as reasons: severity, sentence, remedy.
FLAGS: dict[str, tuple[str, str, str]] = {
    "few_inliers": (
        WEAK,
        "few frames support the line",
        "a longer pass of the target through the view, or check the track",
    ),
    "along_ray": (
        WEAK,
        "the target moves mostly along the viewing ray (little timing information)",
        "a pass of the target across the view",
    ),
    "truncated": (
        WEAK,
        "the video ends before its announced end; only the frames it holds are mapped",
        "check the video file (re-copy or re-encode it)",
    ),
    "clock_disagrees": (
        WEAK,
        "the offset disagrees with the camera's own clock by more than its tolerance (see clock_prior)",
        "check the camera's clock and the log's time base",
    ),
    "picked": (
        WEAK,
        "the line was picked by the project ([[cameras]] pick_start_s) among lines the evidence left possible",
        "remove pick_start_s to let the evidence decide",
    ),
}


@dataclass(frozen=True)
class CameraStatus:
    """A camera's status (OK, WEAK, AMBIGUOUS or FAILED) and its reasons, worst first."""

    camera: str
    status: str
    reasons: tuple[Reason, ...] = ()

    @property
    def synchronized(self) -> bool:
        return self.status in SYNCHRONIZED

    @property
    def reason(self) -> str:
        """Why the camera has its status, in one line: the reasons of its own severity ("" when ok)."""
        return "; ".join(r.text for r in self.reasons if r.severity == self.status)

    @property
    def remedy(self) -> str:
        """What to do about the worst reason ("" when ok)."""
        return self.reasons[0].remedy if self.reasons else ""

    def to_dict(self) -> dict:
        return {
            "status": self.status,
            "synchronized": self.synchronized,
            "reason": self.reason,
            "remedy": self.remedy,
            "reasons": [r.to_dict() for r in self.reasons],
        }


def status_of(camera: str, reasons: list[Reason] | tuple[Reason, ...]) -> CameraStatus:
    """The status its reasons make: the worst severity (OK without any), reasons worst first."""
    ordered = tuple(sorted(reasons, key=lambda r: -SEVERITY[r.severity]))
    return CameraStatus(camera, ordered[0].severity if ordered else OK, ordered)


def line_reasons(
    flags: tuple[str, ...] | None, warnings: tuple[str, ...] | None, checks: tuple[Reason, ...] | None
) -> list[Reason]:
    """The reasons a camera line carries: its checks, its flags (FLAGS) and its warnings (a fallback of the method)."""
    reasons = list(checks or ())
    for flag in flags or ():
        severity, text, remedy = FLAGS.get(flag, (WEAK, flag, "see timeline.json"))
        reasons.append(Reason(flag, severity, text, remedy))
    for warning in warnings or ():
        reasons.append(
            Reason(
                "fallback",
                WEAK,
                f"the refinement was not used: {warning}",
                "check the track and the calibration near this camera's frames",
            )
        )
    return reasons


def failure(text: str, code: str = "not_synchronized", remedy: str = "") -> Reason:
    """A reason that leaves a camera not synchronized (a SyncError's message, a task that did not complete).

    A pose the target could not determine (sync/pose/pose.py's message) keeps its
    cause as the code and its remedy; two offsets alike make it ambiguous.
    """
    pose = _POSE_FAILURE.search(text)
    if pose is not None:
        return Reason(pose["cause"], AMBIGUOUS if pose["cause"] == "ambiguous_offset" else FAILED, text, pose["remedy"])
    diagnosed = _DIAGNOSED.search(text)
    if diagnosed is not None:
        return Reason(diagnosed["cause"], FAILED, text, diagnosed["remedy"])
    return Reason(code, FAILED, text, remedy or _failure_remedy(text))


def diagnosed_failure(camera: str, cause: Reason, text: str) -> str:
    """A camera's failure message (``text``, a SyncError's) led by the cause found for it (sync/solve/causes.py), its
    code and
    remedy kept in the words so that ``failure`` gives them back."""
    return (
        f"camera {camera}: {cause.text} (cause {cause.code}): {text.removeprefix(f'camera {camera}: ')}; {cause.remedy}"
    )


_POSE_FAILURE = re.compile(r"pose not determined from the target \((?P<cause>[a-z_]+)\): .*; (?P<remedy>[^;]+)$")
_DIAGNOSED = re.compile(r"^camera .*? \(cause (?P<cause>[a-z_]+)\): .*; (?P<remedy>[^;]+)$")


def _failure_remedy(text: str) -> str:
    """A remedy for the failures tlsync words itself (no vote, no target, a task that did not complete)."""
    if "never comes within" in text or "projects into its image" in text:
        return "check the camera's pose (GCPs), that the log is in the same world frame, and the track"
    if "reversed in time" in text:
        return "check the order of the log's times"
    if "never found" in text:
        return "check that the target crosses the view, or give the tracker an init box"
    if " failed: " in text or "did not run" in text:
        return "fix that task's error (see `tlsync status`) and run again"
    return "see the reason; `tlsync status` lists what ran and failed"
