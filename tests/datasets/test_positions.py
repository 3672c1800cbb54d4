"""Positions files: reading, units, metres, and every refusal's message."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.datasets import positions as pos
from ppaloc.datasets.positions import from_metres, read_positions, to_metres
from ppaloc.errors import DataError


def _csv(tmp_path, text, name="p.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_reads_each_recognised_pair(tmp_path):
    xy = read_positions(_csv(tmp_path, "t,X ,y\n0,1.5,2\n1,3,-4e1\n"), 2, "ref_positions")
    assert (xy.kind, xy.columns) == ("xy", ("X", "y"))
    np.testing.assert_array_equal(xy.values, [[1.5, 2], [3, -40]])
    utm = read_positions(
        _csv(tmp_path, "Easting,Northing,zone\n500000,5000000,32V\n500010,5000000,32v\n"),
        2,
        "ref_positions",
    )
    assert (utm.kind, utm.zone) == ("utm", "32V")
    ll = read_positions(_csv(tmp_path, "\ufefflongitude,latitude\n10,60\n10.001,60\n"), 2, "r")
    assert ll.kind == "latlon" and ll.values[0].tolist() == [60, 10]  # stored lat, lon


def test_blank_lines_are_skipped_and_names_checked(tmp_path):
    path = _csv(tmp_path, "image,x,y\na.png,0,0\n\nsub/b.png,1,0\n")
    got = read_positions(path, 2, "ref_positions", names=["a.png", "b.png"])
    assert got.values.tolist() == [[0, 0], [1, 0]]
    with pytest.raises(DataError, match=r"line 2: image is 'a\.png' but frame 0 is 'b\.png'"):
        read_positions(path, 2, "ref_positions", names=["b.png", "a.png"])


def test_latlon_become_straight_line_metres():
    def at(*rows):
        return pos.PositionsFile(
            pos.Path("p.csv"), "latlon", np.array(rows, float), ("lat", "lon"), None, ""
        )

    ref, qry = to_metres(at((51.5, -0.1), (51.5, -0.1001)), at((51.5001, -0.1)))
    assert ref.shape == (2, 3) and np.allclose(ref[0], 0)
    # 0.0001 deg of latitude near 51.5 N: 11.13 m; of longitude: 6.95 m (WGS84)
    assert np.linalg.norm(qry[0] - ref[0]) == pytest.approx(11.13, abs=0.01)
    assert np.linalg.norm(ref[1] - ref[0]) == pytest.approx(6.95, abs=0.01)
    assert qry[0][1] > 11 and abs(qry[0][0]) < 1e-6  # north, not east


def test_xy_and_utm_stay_as_written():
    a = pos.PositionsFile(pos.Path("a.csv"), "utm", np.array([[1.0, 2.0]]), ("e", "n"), "32V", "")
    b = pos.PositionsFile(pos.Path("b.csv"), "utm", np.array([[3.0, 4.0]]), ("e", "n"), None, "")
    ref, qry = to_metres(a, b)
    assert ref.tolist() == [[1, 2]] and qry.tolist() == [[3, 4]]


def test_from_metres_golden_with_queries_that_have_no_match():
    ref = np.array([[0.0, 0], [10, 0], [20, 0], [30, 0]])
    qry = np.array([[0.0, 0], [15, 0], [25, 3], [100, 0], [10, 5]])
    got = [r.tolist() for r in from_metres(ref, qry, 5.0)]
    assert got == [[0], [1, 2], [], [], [1]]  # (25, 3) is 5.83 m from 20 and 30


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_from_metres_matches_every_pair_distance(data):
    n = data.draw(st.integers(1, 12))
    m = data.draw(st.integers(0, 12))
    coords = st.floats(-50, 50, allow_nan=False)
    ref = np.array(data.draw(st.lists(st.tuples(coords, coords), min_size=n, max_size=n)))
    qry = np.array(data.draw(st.lists(st.tuples(coords, coords), min_size=m, max_size=m)))
    tol = data.draw(st.floats(0, 40))
    got = from_metres(ref, qry.reshape(m, 2), tol)
    for j in range(m):
        d = np.hypot(*(ref - qry[j]).T)
        # pairs a nanometre from the boundary may fall either way (squared distances round)
        clear = np.abs(d - tol) > 1e-9
        kept = np.isin(np.arange(n), got[j])
        assert kept[clear].tolist() == (d <= tol)[clear].tolist()
        assert got[j].tolist() == sorted(set(got[j].tolist()))


def test_from_metres_bounds_the_pairs(monkeypatch):
    monkeypatch.setattr(pos, "MAX_GROUND_TRUTH_ITEMS", 5)
    ref = np.zeros((3, 2))
    with pytest.raises(DataError, match=r"tolerance_m=1 accepts 6 \(query, reference\) pairs, "
                       r"more than 5; lower the tolerance"):  # fmt: skip
        from_metres(ref, np.zeros((2, 2)), 1.0)


@pytest.mark.parametrize(
    ("text", "n", "message"),
    [
        ("", 1, r"is empty or has no header; its first line names the columns"),
        ("a,b\n1,2\n", 1, r"has no coordinate columns \(header: 'a', 'b'\); name them x,y"),
        ("x,z\n1,2\n", 1, r"has a 'x' column but no y column to pair it with"),
        ("lat,z\n1,2\n", 1, r"has a 'lat' column but no lon/lng/long/longitude column"),
        ("x,y,lat,lon\n1,2,3,4\n", 1, r"holds both x/y metres and lat/lon degrees: mixed units"),
        ("x,y,X\n1,2,3\n", 1, r"columns x, X name one coordinate twice"),
        ("x,y\n1,2\n3\n", 2, r"line 3: 1 fields where the header has 2"),
        ("x,y\n1,abc\n", 1, r"line 2, column 'y': 'abc' is not a number; write plain decimals"),
        ("x,y\n1,nan\n", 1, r"line 2, column 'y' is nan; every frame needs a finite position"),
        ("x,y\n1,\n", 1, r"line 2, column 'y' is empty; every frame needs a position"),
        ("x,y\n1,2\n3,4\n", 1, r"has more than 1 rows for the 1 frames of its traversal"),
        ("x,y\n1,2\n", 2, r"has 1 rows for the 2 frames of its traversal; give one row per"),
        ("lat,lon\n151.2,-33.8\n", 1, r"lat 151.2 is not a latitude in -90..90 degrees \(are"),
        ("lat,lon\n10,190\n", 1, r"lon 190 is not a longitude in -180..180 degrees"),
        ("easting,northing,zone\n1,2,32V\n3,4,33V\n", 2, r"spans UTM zones 32V, 33V; .* lat/lon"),
        ("x,y\n1e999,2\n", 1, r"column 'x' is 1e999: too large to be a position"),
        ("x,y\n1,2e9\n", 1, r"line 2: y 2e\+09 is not a position in -1e\+09..1e\+09 metres"),
        ("easting,northing\n-1e300,2\n", 1, r"line 2: easting -1e\+300 is not a position in"),
    ],
)
def test_every_bad_file_is_one_line_naming_the_fix(tmp_path, text, n, message):
    path = _csv(tmp_path, text)
    with pytest.raises(DataError, match=message) as info:
        read_positions(path, n, "ref_positions")
    assert "\n" not in str(info.value) and f"ref_positions={path}" in str(info.value)


def test_files_that_are_not_csv_text(tmp_path):
    with pytest.raises(DataError, match=r"ref_positions=.*nope\.csv does not exist"):
        read_positions(tmp_path / "nope.csv", 1, "ref_positions")
    (tmp_path / "d.csv").mkdir()
    with pytest.raises(DataError, match=r"d\.csv is a folder; give the positions \.csv file"):
        read_positions(tmp_path / "d.csv", 1, "ref_positions")
    with pytest.raises(DataError, match=r"p\.txt must be a \.csv file"):
        read_positions(_csv(tmp_path, "x,y\n", "p.txt"), 1, "ref_positions")
    bad = tmp_path / "b.csv"
    bad.write_bytes(b"x,y\n\xff\xfe,1\n")
    with pytest.raises(DataError, match=r"is not UTF-8 text \(byte 4\)"):
        read_positions(bad, 1, "ref_positions")
    bad.write_bytes(b"x,y\n1,\x002\n")
    with pytest.raises(DataError, match=r"holds NUL bytes"):
        read_positions(bad, 1, "ref_positions")


def test_size_is_bounded_before_reading(tmp_path, monkeypatch):
    monkeypatch.setattr(pos, "MAX_POSITIONS_BYTES", 10)
    with pytest.raises(DataError, match=r"is 12 bytes, more than 10"):
        read_positions(_csv(tmp_path, "x,y\n1,2\n3,4\n"), 2, "ref_positions")


def test_two_files_in_different_units_or_zones(tmp_path):
    a = read_positions(_csv(tmp_path, "x,y\n0,0\n", "a.csv"), 1, "ref_positions")
    b = read_positions(_csv(tmp_path, "lat,lon\n0,0\n", "b.csv"), 1, "query_positions")
    with pytest.raises(DataError, match=r"mixed units: .*a\.csv holds x/y metres but .*b\.csv "
                       r"holds lat/lon degrees; give both"):  # fmt: skip
        to_metres(a, b)
    c = read_positions(_csv(tmp_path, "easting,northing,zone\n0,0,31U\n", "c.csv"), 1, "r")
    d = read_positions(_csv(tmp_path, "easting,northing,zone\n0,0,32U\n", "d.csv"), 1, "q")
    with pytest.raises(DataError, match=r"is in UTM zone 31U but .* in zone 32U"):
        to_metres(c, d)


def test_haversine_agrees_at_short_range():
    r = 6371008.8  # mean earth radius: a sphere's distance agrees to 0.5% with WGS84's
    a = pos.PositionsFile(pos.Path("a"), "latlon", np.array([[48.0, 11.0]]), ("", ""), None, "")
    b = pos.PositionsFile(
        pos.Path("b"), "latlon", np.array([[48.0002, 11.0003]]), ("", ""), None, ""
    )
    ref, qry = to_metres(a, b)
    lat1, lon1, lat2, lon2 = map(math.radians, (48.0, 11.0, 48.0002, 11.0003))
    h = (
        math.sin((lat2 - lat1) / 2) ** 2
        + math.cos(lat1) * math.cos(lat2) * math.sin((lon2 - lon1) / 2) ** 2
    )
    assert np.linalg.norm(qry[0] - ref[0]) == pytest.approx(
        2 * r * math.asin(math.sqrt(h)), rel=5e-3
    )
