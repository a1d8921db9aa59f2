"""report.html and report.md of a quick run: the camera table, readable headings, stages with
render, local links only.
"""

import re

import pytest

from data_fixtures import make_scene, write_scene
from tlsync_pipeline.pipeline.engine import run_graph
from tlsync_pipeline.pipeline.graph import build_graph
from tlsync_pipeline.pipeline.project import load_project


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pages")
    scene = make_scene(seed=0, lines=((2.0, 4.0), (2.0, 45.0), (1.0, -30.5)), n_frames=(400, 400, 300))
    graph = build_graph(load_project(write_scene(scene, folder)), folder / "work")
    assert not run_graph(graph, targets=["render"]).failed
    return graph.work, (graph.work / "report.html").read_text(), (graph.work / "report.md").read_text()


def test_markdown_has_tables_and_readable_headings(pages):
    _, _, markdown = pages
    lines = markdown.splitlines()
    header = next(line for line in lines if line.startswith("| camera | status |"))
    rows = lines[lines.index(header) + 2 : lines.index(header) + 5]
    assert [row.split("|")[1].strip() for row in rows] == ["cam0", "cam1", "cam2"]
    assert all(re.search(r"[+-]\d+\.\d+ s ± [\d.]+", row) for row in rows[1:])  # start with its 95 % interval
    assert "```\n camera" not in markdown  # the timeline is a table, not a code block
    stages = lines[lines.index("## Stages") + 2 :]
    assert any(line.startswith("| render |") for line in stages)
    headings = [line for line in lines if line.startswith("### ")]
    assert "### cam1: voting space" in headings and "### cam1: tracked against projected" in headings
    assert not any(re.match(r"### \w+ cameras ", h) for h in headings)


def test_html_is_self_contained_and_links_exist(pages):
    work, page, _ = pages
    assert not re.search(r"""(src|href)=["']?(https?:)?//""", page)  # nothing fetched from the network
    assert page.count('src="data:image/png;base64,') >= 6 + 2  # votes and trajectory per camera, two charts
    for href in re.findall(r'href="([^"#][^"]*)"', page):
        assert (work / href).exists(), href
    for label in ("exports/frame_map.csv", "exports/offsets.csv", "exports/timeline.otio", "exports/sync.json"):
        assert f'href="{label}"' in page
    assert page.count('class="badge ok"') + page.count('class="badge weak"') == 3
    assert "CFR (frame indices), 15.000 fps" in page
    assert 'id="tlsync-player-data"' in page and "window.tlsyncPlayer" in page


def test_the_uncertainty_column_gives_the_budget_shares():
    from tlsync_pipeline.outputs.report_content import budget_text
    from tlsync_pipeline.sync.timeline import ErrorBudget

    assert budget_text(None) == "-"
    text = budget_text(ErrorBudget(tracking_frames=0.3, calibration_frames=0.4, log_frames=1.2))
    assert (
        text.startswith("± 1.3 frames") and "tracking 5 %" in text and "calibration 9 %" in text and "log 85 %" in text
    )
