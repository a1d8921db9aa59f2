"""The ingest stage: readers, geodesy agreement, cleaning, resampling, bad input, CLI."""

from __future__ import annotations

import datetime as dt
import json
import math
from unittest import mock

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from data_fixtures.gps_logs import (
    walk_trajectory,
    write_csv_log,
    write_gpx_log,
    write_nmea_log,
)
from tests.real_data import REAL_DATA
from tlsync_pipeline.cli.main import main
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu
from tlsync_pipeline.ingest import (
    IngestParams,
    RigidTransform,
    detect_format,
    ingest,
    process,
    read_log,
)
from tlsync_pipeline.ingest.process import reject_spikes, resample
from tlsync_pipeline.trajectory import Trajectory, read_trajectory

ORIGIN = Origin(47.3769, 8.5417, 450.0)
START = dt.datetime(2026, 3, 1, 23, 59, 0, tzinfo=dt.timezone.utc)  # crosses midnight: an NMEA day rollover
WRITERS = {"gpx": write_gpx_log, "nmea": write_nmea_log, "csv": write_csv_log}


@pytest.fixture(scope="module")
def walk() -> Trajectory:
    return walk_trajectory(seconds=120.0, rate=10.0, gap=(50.0, 30.0))


def _ingest(path, **kw):
    return ingest(read_log(path), IngestParams(**kw))


@pytest.mark.parametrize("fmt", ["gpx", "nmea", "csv"])
def test_logs_read_back_within_1cm(tmp_path, walk, fmt):
    corrupt = {} if fmt == "gpx" else {"corrupt": [3, 250, 700]}
    path = WRITERS[fmt](tmp_path / f"walk.{fmt}", walk, ORIGIN, START, **corrupt)
    assert detect_format(path) == fmt
    trajectory, report = _ingest(path, origin=ORIGIN)
    assert trajectory.rate == pytest.approx(10.0, abs=1e-9)
    assert trajectory.t0 == pytest.approx(START.timestamp(), abs=1e-6)
    np.testing.assert_array_equal(trajectory.sample, walk.sample)  # same grid, gap left out, no renumbering
    error = np.abs(trajectory.xyz - walk.xyz)
    assert error.max() < 0.01, f"{fmt}: worst axis error {error.max() * 1000:.1f} mm"
    if fmt == "nmea":  # 5 decimals of minutes (<= 9.3 mm north), altitude to 1 cm: the writer's rounding
        assert error[:, 0].max() < 0.0093 * math.cos(math.radians(ORIGIN.lat)) + 1e-3 and error[:, 2].max() < 0.006
    else:  # 1e-7 degree (<= 5.6 mm north), mm heights
        assert error[:, 1].max() < 0.0057 and error[:, 2].max() < 0.0006
    if corrupt:
        assert sum(d["count"] for d in report.dropped.values()) == 3
    assert report.origin == {"lat": ORIGIN.lat, "lon": ORIGIN.lon, "alt": ORIGIN.alt, "rule": "given"}


def test_gpx_1_0_and_segments(tmp_path, walk):
    path = write_gpx_log(tmp_path / "walk10.gpx", walk, ORIGIN, START, version="1.0")
    records = read_log(path)
    assert len(records) == len(walk) and records.unit == "track point"
    assert any("waypoint" in w for w in records.warnings)


def _ecef(lat, lon, h):
    a, f = 6378137.0, 1 / 298.257223563
    e2 = f * (2 - f)
    phi, lam = np.radians(lat), np.radians(lon)
    n = a / np.sqrt(1 - e2 * np.sin(phi) ** 2)
    return np.stack(
        [(n + h) * np.cos(phi) * np.cos(lam), (n + h) * np.cos(phi) * np.sin(lam), (n * (1 - e2) + h) * np.sin(phi)],
        axis=-1,
    )


def _enu_textbook(lat, lon, h, origin: Origin):
    d = _ecef(lat, lon, h) - _ecef(origin.lat, origin.lon, origin.alt)
    phi, lam = math.radians(origin.lat), math.radians(origin.lon)
    rotation = np.array(
        [
            [-math.sin(lam), math.cos(lam), 0.0],
            [-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi)],
            [math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi)],
        ]
    )
    return d @ rotation.T


@pytest.mark.parametrize("origin", [ORIGIN, Origin(-33.86, 151.21, 20.0), Origin(69.6, -18.9, 1200.0)])
def test_enu_agrees_with_textbook_formulas_at_10km(origin):
    bearing = np.radians(np.arange(0, 360, 30))
    lat = origin.lat + np.degrees(10_000 * np.cos(bearing) / 6_371_000)
    lon = origin.lon + np.degrees(10_000 * np.sin(bearing) / (6_371_000 * math.cos(math.radians(origin.lat))))
    h = origin.alt + np.linspace(-50, 300, len(bearing))
    ours = geodetic_to_enu(lat, lon, h, origin)
    assert np.hypot(ours[:, 0], ours[:, 1]).min() > 9_900
    np.testing.assert_allclose(ours, _enu_textbook(lat, lon, h, origin), atol=1e-3, rtol=0)


def test_30s_gap_is_left_out_and_reported(tmp_path, walk):
    path = write_csv_log(tmp_path / "walk.csv", walk, ORIGIN, START)
    trajectory, report = _ingest(path)
    assert len(report.gaps) == 1
    gap = report.gaps[0]
    assert gap.duration_s == pytest.approx(30.1) and not gap.bridged and gap.after == "line 501"
    assert report.grid_left_out == 300 and report.samples == len(walk)
    assert not np.isin(np.arange(500, 800), trajectory.sample).any() and 800 in trajectory.sample
    assert "not bridged" in report.summary() and "300 grid sample(s) left out" in report.summary()
    bridged, report = _ingest(path, max_gap_s=40.0)
    assert report.gaps[0].bridged and len(bridged) == 1201 and report.grid_left_out == 0


def test_written_trajectory_keeps_rate_t0_and_indices(tmp_path, walk):
    path = write_nmea_log(tmp_path / "walk.nmea", walk, ORIGIN, START)
    out = tmp_path / "traj.csv"
    result = CliRunner().invoke(main, ["ingest-log", str(path), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "samples at 10 Hz" in result.output and "gaps: 1" in result.output
    back = read_trajectory(out)
    assert back.rate == pytest.approx(10.0, rel=1e-9) and back.t0 == pytest.approx(START.timestamp(), abs=1e-6)
    np.testing.assert_allclose(back.sample, walk.sample, atol=1e-4)
    sidecar = json.loads((tmp_path / "traj.ingest.json").read_text())
    assert sidecar["origin"]["rule"] == "first fix" and sidecar["rate"] == 10.0


def test_resample_pure():
    t = np.array([0.0, 0.1, 0.2, 0.5, 0.6, 2.6, 2.7])
    xyz = np.column_stack([t * 10, np.zeros(7), np.zeros(7)])
    index, grid, left = resample(t, xyz, 10.0, max_gap_s=0.35)
    assert index.tolist() == [0, 1, 2, 3, 4, 5, 6, 26, 27]  # 0.3, 0.4 bridged (0.3 s); 0.7..2.5 not
    np.testing.assert_allclose(grid[:, 0], index, atol=1e-9)
    assert left == 19


def test_rate_option_resamples(tmp_path, walk):
    path = write_csv_log(tmp_path / "walk.csv", walk, ORIGIN, START)
    trajectory, report = _ingest(path, origin=ORIGIN, rate=2.0)
    assert report.rate == 2.0 and trajectory.sample[:3].tolist() == [0, 1, 2]
    np.testing.assert_allclose(trajectory.xyz[1], walk.xyz[5], atol=0.01)


def test_spikes_rejected_and_origin_is_first_kept_fix(tmp_path):
    rows = ["time,lat,lon,alt", "0,47.5,8.5,400"]  # the first fix is 1 km off
    rows += [f"{i},{47.49 + i * 1e-6:.7f},8.5,400" for i in range(1, 40)]
    rows[20] = "19,47.4950000,8.5,400"  # a 550 m jump
    (tmp_path / "spiky.csv").write_text("\n".join(rows) + "\n")
    trajectory, report = _ingest(tmp_path / "spiky.csv", max_speed_mps=20.0)
    assert report.dropped["spike (implied speed over 20 m/s)"] == {"count": 2, "first": [2, 21]}
    assert report.origin["lat"] == pytest.approx(47.490001) and np.abs(trajectory.xyz).max() < 5
    assert trajectory.sample.tolist() == list(range(39))  # spikes interpolated over: 1 s intervals, max gap 3 s


def test_a_log_without_heights_says_so(tmp_path):
    rows = ["time,lat,lon,alt"] + [f"{i},{47.49 + i * 1e-5:.7f},8.5,0" for i in range(20)]
    (tmp_path / "flat.csv").write_text("\n".join(rows) + "\n")
    _, report = _ingest(tmp_path / "flat.csv")
    assert any(
        w.startswith("every fix's height is 0: a log without heights") and "altitude_offset_m" in w
        for w in report.warnings
    )
    (tmp_path / "flat.csv").write_text(
        "\n".join(r.replace(",0", ",0.5") if i else r for i, r in enumerate(rows)) + "\n"
    )
    assert not any("height is 0" in w for w in _ingest(tmp_path / "flat.csv")[1].warnings)


def test_reject_spikes_recovers_after_a_jump():
    t = np.arange(10.0)
    xyz = np.zeros((10, 3))
    xyz[5:, 0] = 100.0  # a real relocation, after which positions agree again
    keep = reject_spikes(t, xyz, 30.0)
    assert keep[:5].all() and not keep[5:8].all() and keep[-1]


def test_duplicates_and_talkers(tmp_path, walk):
    path = write_nmea_log(tmp_path / "a.nmea", walk, ORIGIN, START)
    lines = path.read_text().splitlines()
    gn = [line.replace("$GPGGA", "$GNGGA") for line in lines if "GGA" in line]
    # GN with a fresh checksum: same fix, other talker -> exact duplicate of the GP line
    from data_fixtures.gps_logs import _nmea

    gn = [_nmea(line[1 : line.index("*")]) for line in gn]
    merged = []
    for line in lines:
        merged.append(line)
        if "GGA" in line:
            merged.append(gn.pop(0))
    path.write_text("\n".join(merged) + "\n")
    trajectory, report = _ingest(path, origin=ORIGIN)
    assert report.dropped["exact duplicate"]["count"] == len(walk)
    assert len(trajectory) == len(walk)


def test_odometry_transform(tmp_path):
    rows = ["time,x,y,z"] + [f"{100 + i * 0.5},{i * 0.5},0,0" for i in range(21)]
    (tmp_path / "odom.csv").write_text("\n".join(rows) + "\n")
    transform = RigidTransform.from_yaw(90.0, (10.0, 20.0, 1.0))
    trajectory, report = ingest(read_log(tmp_path / "odom.csv", "odometry"), IngestParams(transform=transform))
    np.testing.assert_allclose(trajectory.xyz[-1], [10.0, 30.0, 1.0], atol=1e-9)
    assert report.frame == "local" and report.origin is None and report.rate == 2.0


def test_smoothing_reduces_noise(tmp_path):
    truth = walk_trajectory(seconds=60.0, rate=10.0, gap=None)
    noisy = Trajectory(truth.sample, truth.xyz + np.random.default_rng(1).normal(0, 0.5, truth.xyz.shape), 10.0, 0.0)
    path = write_csv_log(tmp_path / "noisy.csv", noisy, ORIGIN, START)
    raw, _ = _ingest(path, origin=ORIGIN)
    smooth, report = _ingest(path, origin=ORIGIN, smoothing_s=2.0)
    rms = lambda a: float(np.sqrt(np.mean((a.xyz - truth.xyz) ** 2)))  # noqa: E731
    assert rms(smooth) < 0.5 * rms(raw) and report.params["smoothing_s"] == 2.0


def _nmea_line(body):
    from data_fixtures.gps_logs import _nmea

    return _nmea(body)


BAD_LOGS = {
    "empty": ("empty.nmea", "", "empty log"),
    "no fix": ("nofix.nmea", _nmea_line("GPGSV,3,1,12,01,40,083,46") + "\n", "no position fix"),
    "all invalid": (
        "invalid.nmea",
        "".join(_nmea_line(f"GPGGA,12000{i}.00,4722.61400,N,00832.50200,E,0,00,,,M,,M,,") + "\n" for i in range(5)),
        "no valid fix; 5 line(s) dropped: 5 GGA fix quality 0 (no fix) (line 1, ...)",
    ),
    "backwards": (
        "back.csv",
        "time,lat,lon,alt\n0,47,8,400\n1,47,8,400\n0.5,47,8,400\n",
        "back.csv:4: time goes backwards",
    ),
    "nmea backwards": (
        "back.nmea",
        "".join(
            _nmea_line(f"GPGGA,1200{s:02d}.00,4722.61400,N,00832.50200,E,1,08,0.9,400.0,M,47.0,M,,") + "\n"
            for s in (1, 2, 5, 3)
        ),
        "back.nmea:4: time goes backwards",
    ),
    "latitude": ("lat.csv", "time,lat,lon,alt\n0,47,8,400\n1,95.5,8,400\n", "lat.csv:3: latitude 95.5 out of range"),
    "gpx cut": (
        "cut.gpx",
        '<?xml version="1.0"?>\n<gpx version="1.1">\n<trk><trkseg>\n<trkpt lat="47" '
        'lon="8"><ele>1</ele><time>2026-01-01T00:00:00Z</time></trkpt>\n<trkpt la',
        "cut short",
    ),
    "undetectable": ("what.log", "hello world\n1 2 3\n", "cannot detect the log format"),
    # a file of the system given as the log: described (length, separators), never quoted
    "passwd": (
        "passwd",
        "root:x:0:0:root:/root:/bin/bash\n",
        "cannot detect the log format (a text file whose first line is 31 characters, 7 fields separated by ':')",
    ),
}


@pytest.mark.parametrize("case", BAD_LOGS)
def test_bad_input_has_a_clear_message_and_exit_code_2(tmp_path, case):
    name, text, expected = BAD_LOGS[case]
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputError) as info:
        _ingest(path)
    assert str(path) in str(info.value) and expected in str(info.value)
    result = CliRunner().invoke(main, ["ingest-log", str(path), "--out", str(tmp_path / "t.csv")])
    assert result.exit_code == 2 and expected in result.output
    assert not (tmp_path / "t.csv").exists()


def test_nmea_cut_mid_line_is_dropped_and_said(tmp_path, walk):
    path = write_nmea_log(tmp_path / "cut.nmea", walk, ORIGIN, START)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 30])
    n_lines = data[: len(data) - 30].count(b"\n") + 1
    trajectory, report = _ingest(path)
    cut = report.dropped["cut mid-line (the file ends without a newline)"]
    assert cut == {"count": 1, "first": [n_lines]}
    assert f"1 cut mid-line (the file ends without a newline) (line {n_lines})" in report.summary()


def test_nmea_without_rmc_and_without_geoid_separation(tmp_path):
    lines = [_nmea_line(f"GPGGA,0000{i:02d}.00,4722.61400,N,00832.50200,E,1,08,0.9,400.0,M,,M,,") for i in range(10)]
    (tmp_path / "gga.nmea").write_text("\n".join(lines) + "\n")
    records = read_log(tmp_path / "gga.nmea")
    assert (
        records.t[0] == 0.0
        and not records.utc
        and any("no RMC" in w for w in records.warnings)
        and any("geoid" in w for w in records.warnings)
    )


def test_project_ingest(tmp_path, walk):
    write_gpx_log(tmp_path / "walk.gpx", walk, ORIGIN, START)
    (tmp_path / "p.toml").write_text(
        '[target]\nlog = "walk.gpx"\norigin = [47.3769, 8.5417, 450.0]\nmax_speed_mps = 30\n\n[[cameras]]\nname = '
        '"c0"\n'
    )
    result = CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml")])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "work" / "target" / "ingest_report.json").read_text())
    assert report["origin"]["rule"] == "given" and report["samples"] == len(walk)
    back = read_trajectory(tmp_path / "work" / "target" / "trajectory.csv")
    np.testing.assert_allclose(back.xyz, walk.xyz, atol=0.01)
    assert "ran: ingest" in result.output and "samples" in result.output  # the stage's summary
    assert (tmp_path / "work" / "target" / "ingest.manifest.json").exists()  # through the pipeline's cache
    quiet = CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml"), "--quiet", "--work", str(tmp_path / "w2")])
    assert (
        quiet.exit_code == 0
        and "running" not in quiet.output
        and (tmp_path / "w2" / "target" / "trajectory.csv").exists()
    )


@pytest.mark.parametrize(
    "extra, expected",
    [
        ('origin = "gcps"', "no camera has geodetic"),
        ("origin = [95, 8, 0]", "out of range"),
        ('format = "kmz"', "unknown log format"),
        ("odometry_transform = { R = [[1, 0, 0], [0, 2, 0], [0, 0, 1]] }", "not a rotation"),
        ("max_gap = 3", "did you mean 'max_gap_s'"),
    ],
)
def test_project_keys_are_checked(tmp_path, walk, extra, expected):
    write_gpx_log(tmp_path / "walk.gpx", walk, ORIGIN, START)
    (tmp_path / "p.toml").write_text(f'[target]\nlog = "walk.gpx"\n{extra}\n\n[[cameras]]\nname = "c0"\n')
    result = CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml")])
    assert result.exit_code == 2 and expected in result.output


def test_nmea_variants(tmp_path):
    from data_fixtures.gps_logs import nmea_sentences

    g1, r1 = nmea_sentences(1.7e9, 47.1, 8.2, 500.0)
    g2, r2 = nmea_sentences(1.7e9 + 1, 47.1, 8.2, 500.0, talker="GN")
    g3, _ = nmea_sentences(1.7e9 + 2, -47.1, -8.2, 500.0, talker="GA")
    g4, _ = nmea_sentences(1.7e9 + 3, -47.1, -8.2, 500.0, talker="GL")
    lowered = g3[:-3].lower() + g3[-3:]  # the checksum no longer matches the body
    # trailing blanks (pynmea2's path), a logger's prefix before '$', S/W hemispheres, four talkers
    (tmp_path / "v.nmea").write_text(f"{g1}   \n{r1}\n[12.5] {g2}\n{r2}\n{lowered}\n{g3}\n{g4}\n")
    records = read_log(tmp_path / "v.nmea")
    np.testing.assert_allclose(records.t - 1.7e9, [0, 1, 2, 3], atol=1e-6)
    np.testing.assert_allclose(records.values[2], [-47.1, -8.2, 500.0], atol=1e-7)
    assert records.line.tolist() == [1, 3, 6, 7] and records.dropped == {"bad checksum": [5]}


def test_scene_trajectory_through_gpx(tmp_path, paper_scene):
    """What the pipeline demo does: a synthetic scene's trajectory as a GPX log, ingested back."""
    truth = paper_scene.trajectory
    path = write_gpx_log(tmp_path / "scene.gpx", truth, ORIGIN, START)
    # The scene jumps between camera zones at up to ~250 m/s: no real target does, so say so.
    trajectory, report = _ingest(path, origin=ORIGIN, max_speed_mps=400.0)
    assert report.rate == truth.rate and not report.dropped
    np.testing.assert_array_equal(trajectory.sample, truth.sample)
    # GPX times have ms resolution: at 1/15 s steps a fix is up to 0.5 ms off its grid time
    speed = np.linalg.norm(np.gradient(truth.xyz, axis=0), axis=1) * truth.rate
    assert (np.linalg.norm(trajectory.xyz - truth.xyz, axis=1) <= 0.01 + 0.0005 * speed).all()


def test_project_odometry_with_transform_and_default_origin(tmp_path, walk):
    rows = ["time,x,y,z"] + [f"{100 + i * 0.5},{i * 0.5},0,0" for i in range(21)]
    (tmp_path / "odom.csv").write_text("\n".join(rows) + "\n")
    (tmp_path / "p.toml").write_text(
        '[target]\nlog = "odom.csv"\nformat = "odometry"\nodometry_transform = { yaw_deg = 90.0, t = [10, 20, 1] '
        '}\n\n[[cameras]]\nname = "c0"\n'
    )
    assert CliRunner().invoke(main, ["ingest", str(tmp_path / "p.toml"), "--quiet"]).exit_code == 0
    back = read_trajectory(tmp_path / "work" / "target" / "trajectory.csv")
    np.testing.assert_allclose(back.xyz[-1], [10.0, 30.0, 1.0], atol=1e-4)
    write_csv_log(tmp_path / "walk.csv", walk, ORIGIN, START)
    (tmp_path / "q.toml").write_text('[target]\nlog = "walk.csv"\n\n[[cameras]]\nname = "c0"\n')
    assert CliRunner().invoke(main, ["ingest", str(tmp_path / "q.toml"), "--quiet"]).exit_code == 0
    report = json.loads((tmp_path / "work" / "target" / "ingest_report.json").read_text())
    assert report["origin"]["rule"] == "first fix" and report["origin"]["lat"] == pytest.approx(ORIGIN.lat, abs=1e-7)


REAL = REAL_DATA / "drone2" / "target.csv"


@pytest.mark.skipif(not REAL.exists(), reason="real drone data (../shared/real/drone2) not present")
def test_real_rtk_log_passes_through_unchanged():
    """A clean 5 Hz RTK log in local metres: same samples, same positions, no drops, no gaps."""
    trajectory, report = _ingest(REAL)
    original = read_trajectory(REAL)
    assert report.rate == 5.0 and not report.dropped and not report.gaps
    np.testing.assert_array_equal(trajectory.sample, original.sample.round())
    np.testing.assert_allclose(trajectory.xyz, original.xyz, atol=1e-9)


def test_gps_log_of_a_scene_synchronizes_like_its_trajectory(tmp_path, paper_scene):
    """End to end: scene -> NMEA log -> tlsync ingest -> tlsync run recovers the true lines."""
    from data_fixtures import write_scene
    from tlsync_pipeline.sync.timeline import read_timeline

    write_scene(paper_scene, tmp_path)
    write_nmea_log(tmp_path / "target.nmea", paper_scene.trajectory, ORIGIN, START, corrupt=[7, 100])
    text = (tmp_path / "project.toml").read_text()
    text = text.replace(
        'trajectory = "trajectory.csv"',
        'log = "target.nmea"\nmax_speed_mps = 400\n'
        # the cameras' world frame is ENU at this origin: the trajectory must share it
        f"origin = [{ORIGIN.lat}, {ORIGIN.lon}, {ORIGIN.alt}]",
    )
    (tmp_path / "project.toml").write_text(text)
    result = CliRunner().invoke(main, ["ingest", str(tmp_path / "project.toml")])
    assert result.exit_code == 0, result.output
    assert "2 bad checksum" in result.output
    result = CliRunner().invoke(main, ["run", str(tmp_path / "project.toml"), "-j", "1"])
    assert result.exit_code == 0, result.output
    assert "ingest" not in result.output.split("ran: ")[1].splitlines()[0]  # fresh from `tlsync ingest`
    timeline = read_timeline(tmp_path / "work" / "timeline.json")
    for name, truth in paper_scene.lines.items():
        line = timeline.cameras[name]
        assert line.alpha == pytest.approx(truth.alpha, rel=2e-3) and line.beta == pytest.approx(truth.beta, abs=0.5)


def test_gpx_segments_out_of_time_order(tmp_path, walk):
    """Segments are put in time order; points inside a segment are not reordered."""
    text = write_gpx_log(tmp_path / "w.gpx", walk, ORIGIN, START).read_text()
    head, first, second = text.split("<trkseg>")
    first, second = (
        first.replace("</trkseg>", ""),
        second.replace("</trkseg>", "").replace("</trk>", "").replace("</gpx>", ""),
    )
    (tmp_path / "swapped.gpx").write_text(f"{head}<trkseg>{second}</trkseg><trkseg>{first}</trkseg></trk></gpx>\n")
    trajectory, report = _ingest(tmp_path / "swapped.gpx", origin=ORIGIN)
    np.testing.assert_array_equal(trajectory.sample, walk.sample)
    assert report.gaps[0].after == "track point 901"  # provenance counts in document order: that segment came second
    lines = first.strip().split("\n")
    lines[3], lines[4] = lines[4], lines[3]  # two points swapped inside a segment
    (tmp_path / "inside.gpx").write_text(f"{head}<trkseg>{chr(10).join(lines)}</trkseg></trk></gpx>\n")
    with pytest.raises(InputError, match="inside.gpx: track point 5: time goes backwards"):
        _ingest(tmp_path / "inside.gpx")


def _walk_fix_by_fix(t, xyz, max_speed, rounding):
    """reject_spikes as its docstring defines it, one fix at a time: the reference for the vectorised walk."""
    n = len(t)
    slack = [0.0] * n if rounding is None else np.nan_to_num(rounding).tolist()
    held = []
    for i in range(n):
        a = i
        while a > 0 and (xyz[a - 1] == xyz[i]).all():
            a -= 1
        b = i
        while b < n - 1 and (xyz[b + 1] == xyz[i]).all():
            b += 1
        held.append(min(t[b] - t[a], 1.0))

    def reachable(i, last):
        allowed = max_speed * max(abs(t[i] - t[last]) + held[min(i, last)], 0.1) + slack[i] + slack[last]
        return math.dist(xyz[i], xyz[last]) <= allowed

    ok = [reachable(i + 1, i) for i in range(n - 1)]
    start = next((i for i in range(n - 2) if ok[i] and ok[i + 1]), next((i for i in range(n - 1) if ok[i]), 0))
    keep = np.zeros(n, dtype=bool)
    keep[start] = True
    for order in (range(start + 1, n), range(start - 1, -1, -1)):
        last = start
        for i in order:
            if reachable(i, last):
                keep[i], last = True, i
    return keep


@settings(max_examples=150, deadline=None, derandomize=True)
@given(seed=st.integers(0, 10_000), n=st.integers(2, 40), block=st.sampled_from([1, 3, 8, 1 << 20]))
def test_spikes_rejected_in_blocks_as_by_the_walk_fix_by_fix(seed, n, block):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.3, n))
    xyz = np.cumsum(rng.normal(0, 1, (n, 3)), axis=0)
    for i in np.flatnonzero(rng.random(n) < rng.uniform(0, 0.7)):
        xyz[i] = xyz[i - 1]  # positions held over several fixes (a log written per video frame)
    spikes = rng.random(n) < rng.uniform(0, 0.4)
    xyz[spikes] += rng.normal(0, 50, (int(spikes.sum()), 3))
    rounding = np.where(rng.random(n) < 0.3, np.nan, rng.uniform(0, 2, n)) if seed % 3 == 0 else None
    with mock.patch.object(process, "SPIKE_BLOCK", block):
        kept = reject_spikes(t, xyz, 10.0, rounding)
    np.testing.assert_array_equal(kept, _walk_fix_by_fix(t, xyz, 10.0, rounding))


@pytest.mark.parametrize("block", [2, 1 << 20])
def test_a_log_on_its_own_grid_resamples_as_in_the_general_case(block):
    rng = np.random.default_rng(0)
    t = 1000.0 + np.arange(50) / 100.0
    xyz = rng.normal(size=(50, 3))
    with mock.patch.object(process, "SPIKE_BLOCK", block):
        fast = resample(t, xyz, 100.0, 0.03)
        with mock.patch.object(process, "_on_own_grid", lambda *args: False):
            general = resample(t, xyz, 100.0, 0.03)
    np.testing.assert_array_equal(fast[0], np.arange(50))
    np.testing.assert_array_equal(fast[0], general[0])
    np.testing.assert_array_equal(fast[1], general[1])
    assert fast[2] == general[2] == 0
    # a max gap shorter than a step
    assert not process._on_own_grid(t * 100.0 - 1e5, np.arange(50), t - t[0], 1e-4, 0.005)
