"""The timeline: every camera's line, the line in R^(N+1) and all pairwise relations.

Camera lines map target samples to frames, frame = alpha * sample + beta
(0-based frames, samples on the trajectory grid). A pairwise relation "A->B"
maps frames of A to frames of B: frame_B = alpha * frame_A + beta.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from tlsync_pipeline.errors import InputError

FORMAT_VERSION = 1


@dataclass(frozen=True)
class Relation:
    """frame_B = alpha * frame_A + beta (0-based frames)."""

    alpha: float
    beta: float

    def __call__(self, frame_a):
        return self.alpha * np.asarray(frame_a, dtype=np.float64) + self.beta

    def inverse(self) -> "Relation":
        return Relation(1.0 / self.alpha, -self.beta / self.alpha)


@dataclass(frozen=True)
class CameraLine:
    """One camera's fitted line frame = alpha * sample + beta, with its support.

    votes: votes cast; inliers: votes on the line; residual_rms: frames;
    fps: nominal frame rate or None.
    """

    name: str
    alpha: float
    beta: float
    votes: int
    inliers: int
    residual_rms: float
    fps: float | None = None
    details: dict = field(default_factory=dict)

    @property
    def relation(self) -> Relation:
        """sample -> frame."""
        return Relation(self.alpha, self.beta)

    @property
    def cov(self) -> np.ndarray | None:
        """2x2 covariance of (alpha, beta), or None when the method gives none."""
        cov = self.details.get("cov")
        return None if cov is None else np.asarray(cov, dtype=np.float64)


@dataclass(frozen=True)
class Timeline:
    """All cameras' lines on one target grid (rate in samples/s, t0 in s)."""

    cameras: dict[str, CameraLine]
    target_rate: float | None = None
    target_t0: float | None = None
    method: str = "paper"
    params: dict = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        return list(self.cameras)

    def relation(self, a: str, b: str) -> Relation:
        """frame_B = alpha * frame_A + beta, through the target's grid."""
        la, lb = self.cameras[a], self.cameras[b]
        alpha = lb.alpha / la.alpha
        return Relation(alpha, lb.beta - alpha * la.beta)

    def relation_cov(self, a: str, b: str) -> np.ndarray | None:
        """2x2 covariance of relation(a, b)'s (alpha, beta), cameras independent; None without covariances."""
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
        return grad @ joint @ grad.T

    def seconds_relation(self, a: str, b: str) -> Relation | None:
        """time_B = alpha * time_A + beta in seconds of each camera's clock (frame 0 or time_s = 0 at 0 s); None without both fps."""
        fa, fb = self.cameras[a].fps, self.cameras[b].fps
        if not fa or not fb:
            return None
        rel = self.relation(a, b)
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
        """The ``timeline.json`` content (contract in docs/formats.md)."""
        first = self.names[0] if self.cameras else None
        cameras = {}
        for name, c in self.cameras.items():
            entry = {k: v for k, v in asdict(c).items() if k not in ("name", "details")}
            entry.update(c.details)
            if first is not None:
                entry["start_offset_frames"], entry["start_offset_s"] = self.start_offset(first, name)
                if name != first:
                    entry.update(self._offset_errors(first, name))
            cameras[name] = entry
        pairs = {}
        for key, rel in self.pairs().items():
            a, b = key.split("->")
            frames, seconds = self.start_offset(a, b)
            pairs[key] = {"alpha": rel.alpha, "beta": rel.beta, "start_offset_frames": frames, "start_offset_s": seconds}
            cov = self.relation_cov(a, b)
            if cov is not None:
                pairs[key]["se_alpha"], pairs[key]["se_beta"] = float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))
                pairs[key].update(self._offset_errors(a, b))
            timed = self.seconds_relation(a, b)
            if timed is not None:
                pairs[key]["seconds"] = {"alpha": timed.alpha, "beta": timed.beta}
        return {
            "format": "tlsync-timeline",
            "version": FORMAT_VERSION,
            "method": self.method,
            "params": self.params,
            "target": {"rate": self.target_rate, "t0": self.target_t0},
            "reference": first,
            "cameras": cameras,
            "failed": self.failed,
            "line": self.line(),
            "pairs": pairs,
        }


def eps_t(estimated: Relation, truth: Relation, n_frames_a: int) -> float:
    """Temporal error (eq. 5): mean |estimated - true| frame of B over A's frames 0..n_frames_a-1."""
    frames = np.arange(n_frames_a, dtype=np.float64)
    return float(np.mean(np.abs(estimated(frames) - truth(frames))))


def write_timeline(timeline: Timeline, path: str | Path) -> None:
    """Write ``timeline.json`` (callers that cache use an atomic writer)."""
    Path(path).write_text(json.dumps(timeline.to_dict(), indent=1, allow_nan=False) + "\n", encoding="utf-8")


def read_timeline(path: str | Path) -> Timeline:
    """Read ``timeline.json`` back into a Timeline (pairs are recomputed)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        cameras = {}
        for name, c in data["cameras"].items():
            base = {k: c[k] for k in ("alpha", "beta", "votes", "inliers", "residual_rms")}
            skip = set(base) | {"fps", "start_offset_frames", "start_offset_s", "se_start_offset_frames", "se_start_offset_s"}
            details = {k: v for k, v in c.items() if k not in skip}
            cameras[name] = CameraLine(name, fps=c.get("fps"), details=details, **base)
        target = data.get("target", {})
        return Timeline(
            cameras, target.get("rate"), target.get("t0"), data.get("method", "paper"), data.get("params", {}), data.get("failed", {})
        )
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    except (KeyError, TypeError, AttributeError) as exc:
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
