"""ROS bags through rosbags (optional extra): a tiny ROS 2 bag written with rosbags' own writer."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

pytest.importorskip("rosbags")
from rosbags.rosbag2 import Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from tlsync_pipeline.cli.main import main  # noqa: E402
from tlsync_pipeline.errors import InputError  # noqa: E402
from tlsync_pipeline.geodesy import Origin, geodetic_to_enu  # noqa: E402
from tlsync_pipeline.ingest import IngestParams, detect_format, ingest, read_log  # noqa: E402
from tlsync_pipeline.ingest.rosbag import navsatfix_row, odometry_row  # noqa: E402

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
T0 = 1_772_400_000


def _header(i, rate=5.0):
    ns = int(round(i * 1e9 / rate))
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=T0 + ns // 10**9, nanosec=ns % 10**9), frame_id="map"
    )


def _fix(i, status=0):
    return T["sensor_msgs/msg/NavSatFix"](
        header=_header(i),
        status=T["sensor_msgs/msg/NavSatStatus"](status=status, service=1),
        latitude=47.3769 + i * 1e-6,
        longitude=8.5417,
        altitude=450.0 + 0.1 * i,
        position_covariance=np.zeros(9),
        position_covariance_type=0,
    )


def _odom(i):
    point = T["geometry_msgs/msg/Point"](x=0.5 * i, y=0.0, z=1.0)
    pose = T["geometry_msgs/msg/Pose"](
        position=point, orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    )
    twist = T["geometry_msgs/msg/Twist"](
        linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
        angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
    )
    return T["nav_msgs/msg/Odometry"](
        header=_header(i),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
    )


@pytest.fixture
def bag(tmp_path):
    """20 fixes on /fix (the 4th without a fix, written out of stamp order) and 20 poses on /odom."""
    path = tmp_path / "run"
    with Writer(path, version=9) as writer:
        fix = writer.add_connection("/fix", "sensor_msgs/msg/NavSatFix", typestore=STORE)
        odom = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=STORE)
        for k, i in enumerate([0, 1, 2, 4, 3, *range(5, 20)]):
            receive = T0 * 10**9 + k * 200_000_000 + 5_000_000  # arrival order: stamps 4 then 3
            writer.write(
                fix, receive, STORE.serialize_cdr(_fix(i, status=-1 if i == 3 else 0), "sensor_msgs/msg/NavSatFix")
            )
            writer.write(odom, receive, STORE.serialize_cdr(_odom(i), "nav_msgs/msg/Odometry"))
    return path


def test_navsatfix_topic(bag):
    assert detect_format(bag) == "rosbag"
    with pytest.raises(
        InputError,
        match="several NavSatFix/Odometry/PoseStamped topics: /fix .NavSatFix, 20 messages., /odom .Odometry",
    ):
        read_log(bag)
    records = read_log(bag, "rosbag", topic="/fix")
    assert records.dropped == {"NavSatFix status -1 (no fix)": [5]} and records.unit == "/fix message"
    assert (np.diff(records.t) > 0).all()  # sorted by stamp
    origin = Origin(47.3769, 8.5417, 450.0)
    trajectory, report = ingest(records, IngestParams(origin=origin))
    assert report.rate == 5.0 and report.t0 == T0 and len(trajectory) == 20
    expected = geodetic_to_enu(47.3769 + np.arange(20) * 1e-6, np.full(20, 8.5417), 450.0 + 0.1 * np.arange(20), origin)
    np.testing.assert_allclose(trajectory.xyz, expected, atol=1e-6)


def test_odometry_topic_via_cli(bag, tmp_path):
    out = tmp_path / "odom.csv"
    result = CliRunner().invoke(
        main, ["ingest-log", str(bag), "--format", "rosbag", "--topic", "/odom", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "20 samples at 5 Hz" in result.output
    missing = CliRunner().invoke(main, ["ingest-log", str(bag), "--topic", "/nope", "--out", str(out)])
    assert missing.exit_code == 2 and "no NavSatFix/Odometry/PoseStamped topic '/nope'" in missing.output


def test_message_conversion_functions():
    assert odometry_row(_odom(4)) == (T0 + 0.8, 2.0, 0.0, 1.0)
    assert navsatfix_row(_fix(2, status=-1)) is None
    t, lat, lon, alt = navsatfix_row(_fix(2))
    assert t == pytest.approx(T0 + 0.4) and lat == pytest.approx(47.376902) and alt == pytest.approx(450.2)
    zero = _fix(1)
    zero.header.stamp.sec, zero.header.stamp.nanosec = 0, 0
    assert navsatfix_row(zero, receive_ns=7 * 10**9)[0] == 7.0  # unstamped: the bag's receive time


from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    magic=st.sampled_from([b"#ROSBAG V2.0\n", b"\x89MCAP0\r\n", b"SQLite format 3\x00"]), data=st.binary(max_size=300)
)
def test_damaged_bags_give_input_errors(tmp_path, magic, data):
    path = tmp_path / "damaged.bag"
    path.write_bytes(magic + data)
    try:
        ingest(read_log(path))
    except InputError as exc:
        assert str(exc).startswith(str(path))


def test_bare_mcap_with_pose_topic_sim_clock_and_covariance_sigma(tmp_path):
    """An MCAP bag's .mcap file alone (no metadata.yaml), PoseStamped and NavSatFix with covariance, sim time."""
    from rosbags.rosbag2 import StoragePlugin

    path = tmp_path / "sim"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        pose = writer.add_connection("/pose", "geometry_msgs/msg/PoseStamped", typestore=STORE)
        fix = writer.add_connection("/gps/fix", "sensor_msgs/msg/NavSatFix", typestore=STORE)
        for i in range(10):
            stamp = T["builtin_interfaces/msg/Time"](sec=100 + i, nanosec=0)
            header = T["std_msgs/msg/Header"](stamp=stamp, frame_id="map")
            point = T["geometry_msgs/msg/Point"](x=float(i), y=2.0, z=0.5)
            msg = T["geometry_msgs/msg/PoseStamped"](
                header=header,
                pose=T["geometry_msgs/msg/Pose"](
                    position=point, orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
                ),
            )
            writer.write(pose, (100 + i) * 10**9, STORE.serialize_cdr(msg, "geometry_msgs/msg/PoseStamped"))
            gps = _fix(i)
            gps.header.stamp = stamp
            gps.position_covariance = np.diag([0.04, 0.09, 0.25]).ravel()
            gps.position_covariance_type = 2
            writer.write(fix, (100 + i) * 10**9, STORE.serialize_cdr(gps, "sensor_msgs/msg/NavSatFix"))
    (path / "metadata.yaml").unlink()
    mcap = next(path.glob("*.mcap"))
    assert detect_format(mcap) == "rosbag"
    with pytest.raises(InputError, match=r"/gps/fix \(NavSatFix, 10 messages\), /pose \(PoseStamped, 10 messages\)"):
        read_log(mcap)
    poses = read_log(mcap, topic="/pose")
    assert poses.frame == "local" and not poses.utc and "simulation" in poses.clock
    np.testing.assert_allclose(poses.values[:, 0], np.arange(10.0))
    trajectory, report = ingest(poses)
    assert report.t0_utc is None and "offsets work, UTC does not" in report.summary()
    fixes = read_log(mcap, topic="/gps/fix")
    np.testing.assert_allclose(fixes.sigma, np.sqrt((0.04 + 0.09) / 2))
