import numpy as np
import pytest

from tlsync_pipeline.geodesy import Origin, enu_to_geodetic, geodetic_to_enu


def test_origin_is_zero_and_round_trip():
    origin = Origin(47.3769, 8.5417, 408.0)
    np.testing.assert_allclose(geodetic_to_enu(origin.lat, origin.lon, origin.alt, origin), [[0, 0, 0]], atol=1e-6)
    enu = np.array([[100.0, -250.0, 12.0], [-5000.0, 3000.0, -40.0]])
    back = geodetic_to_enu(*enu_to_geodetic(enu, origin).T, origin)
    np.testing.assert_allclose(back, enu, atol=1e-6)


def test_axes_point_east_north_up():
    origin = Origin(10.0, 20.0, 0.0)
    east = geodetic_to_enu(10.0, 20.001, 0.0, origin)[0]
    north = geodetic_to_enu(10.001, 20.0, 0.0, origin)[0]
    assert east[0] > 100 and abs(east[1]) < 0.01
    assert north[1] > 100 and abs(north[0]) < 0.01
    assert geodetic_to_enu(10.0, 20.0, 7.0, origin)[0][2] == pytest.approx(7.0)


def test_origin_validation():
    with pytest.raises(ValueError, match="out of range"):
        Origin(95.0, 0.0, 0.0)


SITE = Origin(46.5197, 6.6323, 380.0)


def _points(origin: Origin = SITE, n: int = 6) -> np.ndarray:
    """lat, lon, alt (n, 3) of points spread over 200 m around ``origin``."""
    enu = np.random.default_rng(3).uniform([-100, -100, -5], [100, 100, 5], (n, 3))
    return enu_to_geodetic(enu, origin)


@pytest.mark.parametrize(
    "slip, words",
    [
        (lambda p: p[:, [1, 0, 2]], "latitude and longitude look swapped"),
        (lambda p: p * [1, -1, 1], "the longitude's sign"),
        (lambda p: p * [-1, 1, 1], "the latitude's sign"),
        (lambda p: p * [-1, -1, 1], "the signs of latitude and longitude"),
    ],
)
def test_a_slip_is_named_by_the_edit_that_undoes_it(slip, words):
    from tlsync_pipeline.geodesy import likely_slip

    points = slip(_points())
    assert likely_slip(points[:, 0], points[:, 1], SITE).startswith(words)
    good = _points()
    assert likely_slip(good[:, 0] + 1.0, good[:, 1], SITE) is None  # 111 km north: no slip explains it


def test_heights_in_feet_are_recognised():
    from tlsync_pipeline.geodesy import heights_in_feet

    points = _points()
    assert heights_in_feet(points[:, 2] / 0.3048, SITE)
    assert not heights_in_feet(points[:, 2], SITE)
    assert not heights_in_feet(
        points[:, 2] / 0.3048, Origin(0.0, 0.0, 10.0)
    )  # 33 ft or 10 m: cannot tell, and harmless
