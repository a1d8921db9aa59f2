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
