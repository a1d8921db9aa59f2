"""ingest_report.json (ingest stage -> identify, vote, sync, render; ``tlsync ingest-log``'s ``<stem>.ingest.json``):
what ingestion did to the target's log, read and written here."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

from tlsync_pipeline.artefacts.jsonfile import malformed, read_document, write_document
from tlsync_pipeline.ingest.records import ALTITUDE_NAMES

GAP_FACTOR = 3.0  # an interval over GAP_FACTOR x the median interval is a gap


@dataclass(frozen=True)
class Gap:
    """An interval between two kept fixes longer than GAP_FACTOR x the median interval."""

    after: str  # where the fix before the gap came from
    start_s: float
    end_s: float
    duration_s: float
    bridged: bool  # interpolated over (duration <= max_gap_s)


@dataclass(frozen=True)
class IngestReport:
    """What ingestion did, for the summary and ingest_report.json."""

    source: str
    format: str
    frame: str  # "ENU" (from geodetic) or "local"
    fixes_read: int
    fixes_used: int
    samples: int
    rate: float
    t0: float
    t0_utc: str | None
    duration_s: float
    extent_m: list[float]  # size along x/E, y/N, z/U
    max_gap_s: float
    gaps: list[Gap]
    grid_left_out: int  # grid positions inside unbridged gaps
    dropped: dict[str, dict]  # reason -> {"count", "first": [...]}
    unit: str  # what the provenance numbers count
    ignored: int
    origin: dict | None  # {"lat", "lon", "alt", "rule"} for geodetic logs
    params: dict
    warnings: list[str] = field(default_factory=list)
    clock: str = "UTC"  # what t0 counts: UTC, or a relative clock (offsets work, UTC does not)
    altitude: dict = field(default_factory=dict)  # {"reference", "source" (log/declared), "offset_m"}
    quality: dict = field(default_factory=dict)  # column -> {"min", "median", "max"} over the fixes used
    sigma_m: dict | None = None  # {"median", "p95", "max"} of the per-fix sigmas used as weights
    log_model: dict = field(
        default_factory=dict
    )  # {"name", "why"}: the error model the log's kind suggests (suggested_log_model)
    notes: list[str] = field(
        default_factory=list
    )  # how the reader read the file where it chose (time base, sub-seconds, lat/lon order)
    video_time_zero: float | None = (
        None  # logs in or beside a video: the log's time (t0's clock, s) at the video's time 0
    )
    t0_local: str | None = None  # t0 as an ISO date without zone, for a log on a local wall clock with no zone

    def to_dict(self) -> dict:
        out = asdict(self)
        out["format_version"] = 1
        return out

    @classmethod
    def from_dict(cls, data: dict) -> IngestReport:
        """The report as ``to_dict`` wrote it (ingest_report.json)."""
        fields = {k: v for k, v in data.items() if k != "format_version"}
        return cls(**{**fields, "gaps": [Gap(**g) for g in fields.get("gaps", [])]})

    def summary(self, with_warnings: bool = True) -> str:
        """The lines printed after ingestion (with_warnings: and a ``warning:`` line per warning)."""
        lines = [
            f"log: {self.source} ({self.format})",
            f"fixes: {self.fixes_read} read, {self.fixes_used} used",
            f"trajectory: {self.samples} samples at {self.rate:g} Hz over {self.duration_s:.1f} s"
            + (
                f" from {self.t0_utc}"
                if self.t0_utc
                else f" from {self.t0_local} local time ({self.clock}: offsets work, UTC does not)"
                if self.t0_local
                else f" from t0 = {self.t0:.3f} s ({self.clock}: offsets work, UTC does not)"
            ),
            "extent: "
            + " x ".join(f"{v:.1f} m" for v in self.extent_m)
            + (" (E x N x U)" if self.frame == "ENU" else " (x y z)"),
        ]
        if self.origin is not None:
            o = self.origin
            lines.append(f"origin: lat {o['lat']:.8f}, lon {o['lon']:.8f}, alt {o['alt']:.3f} m ({o['rule']})")
        if self.altitude:
            a = self.altitude
            offset = f", offset {a['offset_m']:+.3f} m" if a["offset_m"] else ""
            lines.append(f"heights: above {ALTITUDE_NAMES[a['reference']]} (as the {a['source']} says{offset})")
        lines += [f"read: {note}" for note in self.notes]
        if self.log_model:
            lines.append(
                f"log model: {self.log_model['name']} ({self.log_model['why']}; [target] log_model overrides it)"
            )
        if self.sigma_m:
            sigma = f"median {self.sigma_m['median']:.3f} m, 95% {self.sigma_m['p95']:.3f} m"
            lines.append(f"sigma: {sigma} (weights for the refinement)")
        if self.gaps:
            left = f", {self.grid_left_out} grid sample(s) left out" if self.grid_left_out else ""
            lines.append(f"gaps: {len(self.gaps)} over {GAP_FACTOR:g}x the median interval{left}")
            for gap in self.gaps[:10]:
                verdict = "bridged" if gap.bridged else "not bridged"
                lines.append(f"  {gap.duration_s:.2f} s after {gap.after}: {verdict}")
            if len(self.gaps) > 10:
                lines.append(f"  ... {len(self.gaps) - 10} more in the report")
        else:
            lines.append("gaps: none")
        total = sum(d["count"] for d in self.dropped.values())
        lines.append(f"dropped: {total}" + ("" if total else " (none)"))
        for reason, d in self.dropped.items():
            more = ", ..." if d["count"] > len(d["first"]) else ""
            lines.append(f"  {d['count']} {reason} ({self.unit} {', '.join(map(str, d['first']))}{more})")
        if with_warnings:
            lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


def write_ingest_report(report: IngestReport, path: str | Path) -> None:
    """Write ingest_report.json."""
    write_document(report.to_dict(), path)


def read_ingest_report(path: str | Path) -> IngestReport:
    """Read ingest_report.json."""
    data = read_document(path, "a tlsync ingest report")
    try:
        return IngestReport.from_dict(data)
    except (KeyError, TypeError, ValueError) as exc:
        raise malformed(path, "a tlsync ingest report", exc) from None
