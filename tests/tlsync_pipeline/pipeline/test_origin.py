"""Geodetic ground control points far from where they belong: the file, the line and the likely slip."""

import numpy as np
import pytest

from calibration.extrinsics import read_gcps
from data_fixtures.gcp import write_gcp_csv
from tlsync_pipeline.errors import InputError
from tlsync_pipeline.geodesy import Origin, enu_to_geodetic
from tlsync_pipeline.pipeline.origin import check_gcp_places, check_log_near_gcps, resolve_origin

SITE = Origin(46.5197, 6.6323, 380.0)


def _gcps(path, origin=SITE, shift_m=(0.0, 0.0), edit=None):
    enu = np.random.default_rng(5).uniform([-60, -60, 0], [60, 60, 4], (6, 3)) + [*shift_m, 0.0]
    geo = enu_to_geodetic(enu, origin)
    if edit is not None:
        geo = edit(geo)
    return write_gcp_csv(path, np.tile([100.0, 100.0], (6, 1)), geo, geodetic=True)


def test_swapped_columns_far_from_the_given_origin_are_named(tmp_path):
    table = read_gcps(_gcps(tmp_path / "gcp.csv", edit=lambda g: g[:, [1, 0, 2]]))
    with pytest.raises(
        InputError,
        match=r"gcp.csv: the points are [\d,]+ km from the \[target\] origin; latitude and longitude look swapped",
    ) as info:
        check_gcp_places(table, SITE)
    assert len(str(info.value).replace(str(tmp_path), "")) < 140  # the folder's path aside (pytest's, of any length)


def test_one_point_with_a_sign_slip_is_named_with_its_line(tmp_path):
    def flip_third(g):
        g[2, 1] *= -1
        return g

    table = read_gcps(_gcps(tmp_path / "gcp.csv", edit=flip_third))
    with pytest.raises(
        InputError,
        match=r"gcp.csv:4: point \S+ is [\d,]+ km from the file's other points; the longitude's sign looks wrong",
    ):
        check_gcp_places(table, SITE)


def test_heights_in_feet_are_named(tmp_path):
    table = read_gcps(_gcps(tmp_path / "gcp.csv", edit=lambda g: g * [1, 1, 1 / 0.3048]))
    with pytest.raises(InputError, match="give alt in metres"):
        check_gcp_places(table, SITE)
    check_gcp_places(read_gcps(_gcps(tmp_path / "good.csv")), SITE)  # a good table passes


def test_one_camera_among_three_far_from_the_others_is_named(tmp_path):
    files = [
        _gcps(tmp_path / f"cam{i}.csv", shift_m=(300.0 * i, 0.0), edit=(lambda g: g[:, [1, 0, 2]]) if i == 1 else None)
        for i in range(3)
    ]
    with pytest.raises(
        InputError,
        match=r"cam1.csv: its points are [\d,]+ km from the other cameras' GCPs; latitude and longitude look swapped",
    ):
        resolve_origin("gcps", files, "[target]")
    two = [files[0], files[1]]
    with pytest.raises(
        InputError, match="the two cameras' GCPs are .* km apart; in one of them latitude and longitude look swapped"
    ):
        resolve_origin(None, two, "[target]")


def test_a_log_far_from_the_gcps_names_the_gcp_file(tmp_path):
    swapped = _gcps(tmp_path / "cam0.csv", edit=lambda g: g[:, [1, 0, 2]])
    origin = resolve_origin("gcps", [swapped], "[target]")  # one camera: consistent with itself
    with pytest.raises(
        InputError,
        match=r"cam0.csv: the GCPs are [\d,]+ km from the target's log \(log.gpx\); latitude and longitude look "
        r"swapped",
    ):
        check_log_near_gcps(SITE, tmp_path / "log.gpx", [swapped], origin)
    check_log_near_gcps(SITE, tmp_path / "log.gpx", [_gcps(tmp_path / "good.csv")], SITE)
