"""Ground truth: positions -> accepted sets, dilation, and the two file readers."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.io import savemat

from ppaloc.datasets.groundtruth import (
    dilate,
    from_positions,
    read_truth_mat,
    read_vprbench,
    validate_sets,
)
from ppaloc.errors import DataError


def test_from_positions_golden():
    got = from_positions(np.array([0.0, 1.4, 1.5, 3.0, 7.0, np.inf]), 5, 1)
    assert [a.tolist() for a in got] == [[0, 1], [0, 1, 2], [0, 1, 2, 3], [2, 3, 4], [], []]
    assert [a.tolist() for a in from_positions(np.array([2.0, 2.6]), 5, 0)] == [[2], [3]]


def test_dilate_golden():
    got = dilate([np.array([0, 4]), np.array([], np.int64), np.array([9])], 10, 2)
    assert [a.tolist() for a in got] == [[0, 1, 2, 3, 4, 5, 6], [], [7, 8, 9]]


def test_validate_refuses_out_of_range_and_drops_overhang():
    with pytest.raises(DataError, match=r"gt\.npy: query 1 accepts reference index 12"):
        validate_sets([[0], [12]], 10, "gt.npy")
    assert [a.tolist() for a in validate_sets([[8, 9, 10, 11]], 10, "gt", overhang=2)] == [[8, 9]]


def _save_rows(path, rows):
    arr = np.empty((len(rows), 2), dtype=object)
    for k, (q, refs) in enumerate(rows):
        arr[k, 0], arr[k, 1] = q, refs
    np.save(path, arr, allow_pickle=True)


def test_vprbench_object_array_read_without_trust(tmp_path):
    path = tmp_path / "gt.npy"
    _save_rows(path, [(1, [2, 3]), (0, np.array([0, 1])), (2, [])])
    got = read_vprbench(path, n_query=3, n_ref=4)
    assert [a.tolist() for a in got] == [[0, 1], [2, 3], []]


def test_vprbench_plain_integer_pairs(tmp_path):
    path = tmp_path / "gt.npy"
    np.save(path, np.array([[0, 2], [1, 0]]))
    assert [a.tolist() for a in read_vprbench(path, 2, 3)] == [[2], [0]]


class _Evil:
    def __reduce__(self):
        return (print, ("this must never run",))


def test_vprbench_refuses_foreign_pickles_and_names_trust(tmp_path, capsys):
    path = tmp_path / "gt.npy"
    arr = np.empty((1, 2), dtype=object)
    arr[0, 0], arr[0, 1] = 0, _Evil()
    np.save(path, arr, allow_pickle=True)
    with pytest.raises(
        DataError, match=r"is a pickle that holds more than numbers and lists.*add trust=1"
    ):
        read_vprbench(path, 1, 1)
    assert "never run" not in capsys.readouterr().out
    # With trust the file is fully unpickled (and print runs): only for trusted files.
    with pytest.raises(DataError):
        read_vprbench(path, 1, 1, trust=True)
    assert "never run" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ([(0, [0]), (5, [1])], "row 1: query index 5 is outside the 2 query images"),
        ([(0, [0]), (0, [1])], "query 0 appears twice"),
        ([(0, [0])], "has no row for 1 of 2 query images"),
        ([(0, [0]), (1, [7])], "query 1 accepts reference index 7"),
        ([(0, [0]), (1, ["x"])], "row 1"),
    ],
)
def test_vprbench_inconsistent_rows(tmp_path, rows, message):
    path = tmp_path / "gt.npy"
    _save_rows(path, rows)
    with pytest.raises(DataError, match=message):
        read_vprbench(path, n_query=2, n_ref=3)


def test_vprbench_missing_and_corrupt(tmp_path):
    with pytest.raises(DataError, match="does not exist"):
        read_vprbench(tmp_path / "nope.npy", 1, 1)
    (tmp_path / "bad.npy").write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(DataError, match="cannot read VPR-Bench ground truth"):
        read_vprbench(tmp_path / "bad.npy", 1, 1)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.lists(st.integers(-3, 12), max_size=5), min_size=1, max_size=6),
    st.randoms(use_true_random=False),
)
def test_fuzz_vprbench_reader_roundtrip_or_data_error(tmp_path_factory, sets, rnd):
    n_ref = 10
    rows = [(q, s) for q, s in enumerate(sets)]
    rnd.shuffle(rows)
    path = tmp_path_factory.mktemp("gt") / "gt.npy"
    _save_rows(path, rows)
    overhang = max((len(set(s)) - 1) // 2 for s in sets)
    in_range = all(-overhang <= i < n_ref + overhang for s in sets for i in s)
    try:
        got = read_vprbench(path, len(sets), n_ref)
    except DataError:
        assert not in_range
        return
    assert in_range
    assert [a.tolist() for a in got] == [sorted({i for i in s if 0 <= i < n_ref}) for s in sets]


@settings(max_examples=40, deadline=None)
@given(st.binary(max_size=200))
def test_fuzz_vprbench_random_bytes_only_data_error(tmp_path_factory, payload):
    path = tmp_path_factory.mktemp("gt") / "gt.npy"
    header = b"\x93NUMPY\x01\x00v\x00{'descr': '|O', 'fortran_order': False, 'shape': (1, 2), }"
    path.write_bytes(header.ljust(10 + 0x76 - 1) + b"\n" + pickle.PROTO + b"\x02" + payload)
    with pytest.raises(DataError):
        read_vprbench(path, 1, 1)


def test_truth_mat(tmp_path):
    t = np.zeros((4, 4), np.uint8)
    t[3, 0] = 1
    savemat(tmp_path / "gt.mat", {"truth": t, "other": 1})
    got = read_truth_mat(tmp_path / "gt.mat")
    assert got.dtype == bool and got[3, 0] and got.sum() == 1
    with pytest.raises(DataError, match="has no variable 'GT' \\(it has: truth, other\\)"):
        read_truth_mat(tmp_path / "gt.mat", "GT")
    savemat(tmp_path / "rect.mat", {"truth": np.zeros((2, 3))})
    with pytest.raises(DataError, match="shape \\(2, 3\\); expected a square matrix"):
        read_truth_mat(tmp_path / "rect.mat")
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all")
    with pytest.raises(DataError, match="cannot read ground-truth matrix"):
        read_truth_mat(tmp_path / "junk.mat")


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-8, 40, allow_nan=False),
    st.integers(1, 30),
    st.integers(0, 5),
)
def test_from_positions_properties(p, n_ref, tol):
    (got,) = from_positions(np.array([p]), n_ref, tol)
    assert np.all((got >= 0) & (got < n_ref))
    assert np.all(np.abs(got - p) <= tol + 0.5 + 1e-9)
    if got.size:
        assert np.array_equal(got, np.arange(got[0], got[-1] + 1))  # contiguous
    nearest = int(np.floor(p + 0.5))
    if 0 <= nearest < n_ref:
        assert nearest in got
    assert got.size <= 2 * tol + 2


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 12), st.randoms(use_true_random=False))
def test_fuzz_truth_mat_roundtrip(tmp_path_factory, n, rnd):
    t = np.array([[rnd.random() < 0.2 for _ in range(n)] for _ in range(n)], np.uint8)
    path = tmp_path_factory.mktemp("mat") / "gt.mat"
    savemat(path, {"truth": t})
    assert np.array_equal(read_truth_mat(path), t != 0)


@settings(max_examples=40, deadline=None)
@given(st.binary(max_size=300))
def test_fuzz_truth_mat_random_bytes_only_data_error(tmp_path_factory, payload):
    path = tmp_path_factory.mktemp("mat") / "gt.mat"
    path.write_bytes(payload)
    with pytest.raises(DataError):
        read_truth_mat(path)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.lists(st.integers(0, 50), max_size=6), max_size=20), st.data())
def test_packed_sets_behave_as_a_sequence_of_arrays(sets, data):
    from ppaloc.datasets.groundtruth import PackedSets

    packed = PackedSets.from_sets(sets)
    assert len(packed) == len(sets)
    assert [g.tolist() for g in packed] == sets
    assert packed.lengths.tolist() == [len(s) for s in sets]
    start = data.draw(st.integers(-25, 25))
    stop = data.draw(st.integers(-25, 25))
    step = data.draw(st.sampled_from([1, 2, -1]))
    cut = packed[start:stop:step]
    assert isinstance(cut, PackedSets)
    assert [g.tolist() for g in cut] == sets[start:stop:step]
    if sets:
        k = data.draw(st.integers(-len(sets), len(sets) - 1))
        assert packed[k].dtype == np.int64 and packed[k].tolist() == sets[k]
        with pytest.raises(ValueError):
            packed[k][...] = 0  # rows are read-only views
    with pytest.raises(IndexError):
        packed[len(sets)]
    assert PackedSets.from_sets(packed) is packed


def test_packed_sets_refuse_a_broken_index():
    from ppaloc.datasets.groundtruth import PackedSets

    with pytest.raises(ValueError, match="indptr must run from 0"):
        PackedSets(np.arange(3), np.array([0, 2]))
    with pytest.raises(ValueError, match="must not decrease"):
        PackedSets(np.arange(3), np.array([0, 2, 1, 3]))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.floats(-1e308, 1e308, allow_nan=False),
            st.floats(-8, 40),
            st.sampled_from([np.nan, np.inf, -np.inf]),
        ),
        max_size=12,
    ),
    st.integers(1, 30),
    st.integers(0, 5),
)
def test_from_positions_matches_one_query_at_a_time(positions, n_ref, tol):
    """The packed, vectorised form accepts exactly the frames a per-query loop does."""
    reach = tol + 0.5
    want = []
    for q in np.asarray(positions, dtype=np.float64):
        if not np.isfinite(q):
            want.append([])
            continue
        lo = max(int(np.ceil(q - reach - 1e-9)), 0)
        hi = min(int(np.floor(q + reach + 1e-9)), n_ref - 1)
        want.append(list(range(lo, hi + 1)))
    got = from_positions(np.asarray(positions, dtype=np.float64), n_ref, tol)
    assert [g.tolist() for g in got] == want
