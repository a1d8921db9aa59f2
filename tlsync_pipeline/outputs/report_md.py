"""``report.md``: the run's report as Markdown (tables, warnings, pictures linked beside it)."""

from __future__ import annotations

from tlsync_pipeline.outputs.report_content import ReportContent, camera_rows


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(header: list[str], rows: list[list[str]], align: str) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if a == "r" else "---" for a in align) + "|"]
    out += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return out + [""]


def report_markdown(content: ReportContent) -> str:
    """The whole report as Markdown text."""
    timeline = content.timeline
    reference = timeline.names[0] if timeline.cameras else None
    lines = [f"# {content.title}", "", "## Cameras", ""]
    rows = camera_rows(timeline, content.statuses)
    lines += _table(
        [
            "camera",
            "status",
            "why",
            "what to do",
            f"start after {reference}'s frame 0 (95 %)",
            f"relation to {reference} (95 %)",
            "clock",
            "inliers / votes",
            "uncertainty (1 σ, at the visit)",
        ],
        [[r.camera, r.status, r.reason, r.remedy, r.start, r.relation, r.clock, r.support, r.budget] for r in rows],
        "llllrllr",
    )
    lines += [
        "start: when the camera's frame 0 was taken, after the reference camera's frame 0 (positive: later); ±: 95 % "
        "interval.",
        "",
    ]
    lines += ["## Warnings", ""]
    if content.warnings:
        lines += [
            f"- **{w.stage}**" + (f" {w.camera}" if w.camera else "") + f": {w.text}" for w in content.warnings
        ] + [""]
    else:
        lines += ["No stage recorded a warning.", ""]
    if content.calibration:
        lines += ["## Calibration", ""] + [f"- {text}" for text in content.calibration.values()] + [""]
    if content.ingest:
        lines += ["## Target log", "", "```", content.ingest, "```", ""]
    if content.stages:
        lines += ["## Stages", ""]
        lines += _table(
            ["stage", "camera", "made (UTC)", "seconds"],
            [
                [s.stage, s.camera or "-", s.created, "-" if s.seconds is None else f"{s.seconds:.1f}"]
                for s in content.stages
            ],
            "lllr",
        )
    if content.exports or content.notes.get("exports"):
        lines += ["## Exports", ""] + [f"- [{label}]({href})" for label, href in content.exports] + [""]
        lines += [note for text in content.notes.get("exports", []) for note in (text, "")]
    lines += ["## Pictures", ""]
    for picture in content.charts:
        lines += [f"### {picture.title}", "", f"![{picture.title}]({picture.href})", ""]
    for name, pictures in content.camera_pictures.items():
        for picture in pictures:
            lines += [f"### {name}: {picture.title}", "", f"![{name}: {picture.title}]({picture.href})", ""]
    for picture in content.pair_pictures + content.calibration_pictures:
        lines += [f"### {picture.title}", "", f"![{picture.title}]({picture.href})", ""]
    lines += [note for text in content.notes.get("pictures", []) for note in (text, "")]
    lines += ["The interactive report with the synchronized player: [report.html](report.html).", ""]
    return "\n".join(lines)
