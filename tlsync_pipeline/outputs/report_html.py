"""``report.html``: one self-contained page a person opens after a run.

Pictures are embedded as data URIs; the player's script and style are
inlined; the videos are linked relatively (they stay the user's files, or
small proxy clips beside the report). Nothing is fetched from the network.

Sections: cameras (status, start and relation to the reference with 95 %
intervals, clock), the synchronized player, the charts, warnings of every
stage, the per-camera pictures, the calibration, the target's log, the
stages, the exports.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources

from tlsync_pipeline.outputs.report_content import Picture, ReportContent, camera_rows
from tlsync_pipeline.sync.model.status import SEVERITY as STATUSES


def _asset(name: str) -> str:
    return resources.files("tlsync_pipeline.outputs").joinpath("assets").joinpath(name).read_text(encoding="utf-8")


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _image(picture: Picture) -> str:
    if picture.data is None:
        src = picture.href
    else:
        src = f"data:{picture.media_type};base64," + base64.b64encode(picture.data).decode("ascii")
    caption = (
        f"<figcaption><b>{_e(picture.title)}</b>"
        + (f" — {_e(picture.caption)}" if picture.caption else "")
        + "</figcaption>"
    )
    return f'<figure><img class="picture" alt="{_e(picture.title)}" src="{src}">{caption}</figure>'


def _pictures(pictures: list[Picture]) -> str:
    return '<div class="pictures">' + "".join(_image(p) for p in pictures) + "</div>"


def _table(header: list[str], rows: list[list[str]], numeric: frozenset[int] = frozenset()) -> str:
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join(
        "<tr>"
        + "".join(f"<td{' class=num' if i in numeric else ''}>{cell}</td>" for i, cell in enumerate(row))
        + "</tr>"
        for row in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _cameras_section(content: ReportContent) -> str:
    rows = camera_rows(content.timeline, content.statuses)
    counts = {s: sum(r.status == s for r in rows) for s in STATUSES}
    lead = f"{len(rows)} camera(s): " + ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    reference = content.timeline.names[0] if content.timeline.cameras else None
    table = _table(
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
        [
            [
                _e(r.camera),
                f'<span class="badge {r.status}">{r.status}</span>',
                _e(r.reason),
                _e(r.remedy),
                _e(r.start),
                _e(r.relation),
                _e(r.clock),
                _e(r.support),
                _e(r.budget),
            ]
            for r in rows
        ],
        numeric=frozenset({4, 7}),
    )
    note = (
        "<p class=\"hint\">start: when the camera's frame 0 was taken, in seconds after the reference camera's frame 0 "
        "(positive: later). ±: half-width of the 95 % interval. ok and weak: synchronized (weak: usable, for the "
        "reason given; "
        "check the pictures); ambiguous (two lines far apart with comparable support) and failed: not synchronized.</p>"
    )
    return f'<h2 id="cameras">Cameras</h2><p class="lead">{_e(lead)}</p>{table}{note}'


def _player_section(player: dict | None) -> str:
    if not player or not player.get("cameras"):
        return ""
    data = json.dumps(player, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return (
        '<h2 id="player-title">Synchronized player</h2>'
        '<p class="hint">One position on the target\'s clock drives every video: each seeks to its frame through the '
        "camera's line "
        "(presentation times for VFR cameras; a shift per segment for a recording that breaks, its breaks marked red "
        "on the strip under its view). Away from the frames that show the target a camera's mapping holds only if its "
        "recording runs on unbroken there: a break neither the container's times nor the pictures show (a restart "
        "between identical pictures, its times re-stamped) is not seen. Red circle: where the logged trajectory "
        "projects at that instant; red line: "
        "the projected "
        "path while the camera records. Keys: ← → one frame of the chosen camera (click a view to choose it), space: "
        "play / pause.</p>"
        '<div id="player"><div class="controls">'
        '<button id="player-back" title="previous frame (←)">◀</button><button id="player-play">play</button>'
        '<button id="player-forward" title="next frame (→)">▶</button>'
        '<input id="player-slider" type="range" aria-label="target time"><span id="player-time"></span>'
        '<label>step frames of <select id="player-step-camera"></select></label></div>'
        '<div id="player-views"></div></div>'
        f'<script type="application/json" id="tlsync-player-data">{data}</script>'
        f"<script>{_asset('player.js')}</script>"
    )


def _warnings_section(content: ReportContent) -> str:
    if not content.warnings:
        return '<h2 id="warnings">Warnings</h2><p>No stage recorded a warning.</p>'
    items = "".join(
        f'<li><span class="stage-name">{_e(w.stage)}</span> '
        f"{'<b>' + _e(w.camera) + '</b>: ' if w.camera else ''}{_e(w.text)}</li>"
        for w in content.warnings
    )
    return f'<h2 id="warnings">Warnings ({len(content.warnings)})</h2><ul class="warnings">{items}</ul>'


def _camera_pictures_section(content: ReportContent) -> str:
    parts = []
    for name, pictures in content.camera_pictures.items():
        if pictures:
            parts.append(f"<h3>{_e(name)}</h3>{_pictures(pictures)}")
    if content.pair_pictures:
        parts.append("<h3>Matching frames of two cameras</h3>" + _pictures(content.pair_pictures))
    parts += [f'<p class="hint">{_e(note)}</p>' for note in content.notes.get("pictures", [])]
    if not parts:
        return ""
    hint = (
        '<p class="hint">Band swap: red = the real frame, green = the target rendered where the logged trajectory '
        "projects. "
        "Yellow where they overlap: aligned. A separate red and green blob: misaligned (before: frame index taken as "
        "time on the log; "
        "after: the synchronized time). Voting space: votes, inliers and the fitted line. Trajectory: tracked against "
        "projected positions.</p>"
    )
    return '<h2 id="pictures">Pictures per camera</h2>' + hint + "".join(parts)


def _calibration_section(content: ReportContent) -> str:
    if not content.calibration and not content.calibration_pictures:
        return ""
    items = "".join(f"<li>{_e(text)}</li>" for text in content.calibration.values())
    return f'<h2 id="calibration">Calibration</h2><ul>{items}</ul>' + (
        _pictures(content.calibration_pictures) if content.calibration_pictures else ""
    )


def _stages_section(content: ReportContent) -> str:
    if not content.stages:
        return ""
    rows = [
        [_e(s.stage), _e(s.camera or "-"), _e(s.created), "-" if s.seconds is None else f"{s.seconds:.1f}"]
        for s in content.stages
    ]
    return '<h2 id="stages">Stages</h2>' + _table(
        ["stage", "camera", "made (UTC)", "seconds"], rows, numeric=frozenset({3})
    )


def _exports_section(content: ReportContent) -> str:
    notes = content.notes.get("exports", [])
    if not content.exports and not notes:
        return ""
    items = "".join(
        f'<li><a href="{_e(href)}">{_e(label)}</a> <span class="hint">{_e(href)}</span></li>'
        for label, href in content.exports
    )
    return f'<h2 id="exports">Exports</h2><ul>{items}</ul>' + "".join(
        f'<p class="hint">{_e(note)}</p>' for note in notes
    )


def report_html(content: ReportContent) -> str:
    """The whole page as text."""
    nav = [
        ("cameras", "cameras"),
        ("player-title", "player"),
        ("charts", "charts"),
        ("warnings", "warnings"),
        ("pictures", "pictures"),
        ("calibration", "calibration"),
        ("target", "target log"),
        ("stages", "stages"),
        ("exports", "exports"),
    ]
    body = [
        f"<h1>{_e(content.title)}</h1>",
        "<nav>" + "".join(f'<a href="#{anchor}">{label}</a>' for anchor, label in nav) + "</nav>",
        _cameras_section(content),
        _player_section(content.player),
        ('<h2 id="charts">Charts</h2>' + _pictures(content.charts)) if content.charts else "",
        _warnings_section(content),
        _camera_pictures_section(content),
        _calibration_section(content),
        (f'<h2 id="target">Target log</h2><pre>{_e(content.ingest)}</pre>') if content.ingest else "",
        _stages_section(content),
        _exports_section(content),
    ]
    return (
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(content.title)}</title><style>{_asset('report.css')}</style></head><body>"
        + "\n".join(part for part in body if part)
        + "</body></html>\n"
    )
