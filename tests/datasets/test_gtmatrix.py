"""Ground-truth matrices: .npy, .npz and .csv, hard and soft, and every refusal."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ppaloc.datasets import gtmatrix
from ppaloc.datasets.gtmatrix import read_matrix
from ppaloc.errors import DataError

GT = np.array([[1, 1, 0, 0], [0, 0, 0, 0], [0, 0, 1, 1]], bool)  # 3 queries x 4 references
WANT = [[0, 1], [], [2, 3]]


def _rows(sets):
    return [r.tolist() for r in sets]


@pytest.mark.parametrize("dtype", [bool, np.uint8, np.int64, np.float32, np.float64])
def test_npy_of_any_numeric_dtype(tmp_path, dtype):
    path = tmp_path / "gt.npy"
    np.save(path, GT.astype(dtype))
    got = read_matrix(path, 3, 4, "gt")
    assert _rows(got.sets) == WANT and got.shape == (3, 4) and got.soft is None
    assert len(got.sha256) == 64


def test_fortran_order_and_transposed_files(tmp_path):
    np.save(tmp_path / "f.npy", np.asfortranarray(GT))
    assert _rows(read_matrix(tmp_path / "f.npy", 3, 4, "gt").sets) == WANT
    np.save(tmp_path / "t.npy", GT.T)  # VPR_Tutorial's references x queries
    assert _rows(read_matrix(tmp_path / "t.npy", 3, 4, "gt", transpose=True).sets) == WANT


def test_npz_with_hard_and_soft(tmp_path):
    soft = GT.copy()
    soft[1, 3] = soft[0, 2] = True
    np.savez(tmp_path / "GT.npz", GThard=GT.T, GTsoft=soft.T)
    got = read_matrix(tmp_path / "GT.npz", 3, 4, "gt", transpose=True)
    assert _rows(got.sets) == WANT and _rows(got.soft) == [[0, 1, 2], [3], [2, 3]]
    np.savez(tmp_path / "one.npz", anything=GT)
    assert _rows(read_matrix(tmp_path / "one.npz", 3, 4, "gt").sets) == WANT
    np.savez(tmp_path / "two.npz", a=GT, b=GT)
    with pytest.raises(DataError, match=r"holds a, b, not GThard; save the hard matrix as GThard"):
        read_matrix(tmp_path / "two.npz", 3, 4, "gt")


def test_csv_plain_and_as_numpy_writes_it(tmp_path):
    path = tmp_path / "gt.csv"
    path.write_text("1,1,0,0\n0, 0,0,0\n\n0,0,1.0,1\n")
    assert _rows(read_matrix(path, 3, 4, "gt").sets) == WANT
    np.savetxt(path, GT.astype(float), delimiter=",")  # 1.000000000000000000e+00
    assert _rows(read_matrix(path, 3, 4, "gt").sets) == WANT


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.data())
def test_every_format_gives_the_same_sets(tmp_path, data):
    m, n = data.draw(st.integers(0, 6)), data.draw(st.integers(1, 6))
    cells = data.draw(st.lists(st.booleans(), min_size=m * n, max_size=m * n))
    gt = np.array(cells, bool).reshape(m, n)
    want = [np.flatnonzero(row).tolist() for row in gt]
    np.save(tmp_path / "h.npy", gt)
    np.savez(tmp_path / "h.npz", GThard=gt)
    np.savetxt(tmp_path / "h.csv", gt.astype(int), fmt="%d", delimiter=",")
    for name in ("h.npy", "h.npz", "h.csv"):
        assert _rows(read_matrix(tmp_path / name, m, n, "gt").sets) == want, name
    np.save(tmp_path / "t.npy", gt.T)
    assert _rows(read_matrix(tmp_path / "t.npy", m, n, "gt", transpose=True).sets) == want


@pytest.mark.parametrize(
    ("array", "message"),
    [
        (
            GT[:2],
            r"has shape \(2, 4\); expected 3 x 4 \(queries x references, one row per query\)$",
        ),
        (
            GT.T,
            r"has shape \(4, 3\); .*it looks transposed: add gt_transpose=1 for a references "
            r"x queries file",
        ),
        (GT[0], r"has shape \(4,\); expected 3 x 4"),
        (
            GT.astype(float) * 2,
            r"row 0, column 0 is 2\.0; a ground-truth matrix holds only 0 and 1",
        ),
        (np.where(GT, np.nan, 0.0), r"row 0, column 0 is nan; .* only 0 and 1"),
        (GT.astype(complex), r"holds complex128 values; a ground-truth matrix is bool or numbers"),
        (GT.astype(str), r"holds <U5 values"),
    ],
)
def test_bad_arrays_are_named(tmp_path, array, message):
    path = tmp_path / "gt.npy"
    np.save(path, array)
    with pytest.raises(DataError, match=message) as info:
        read_matrix(path, 3, 4, "gt")
    assert str(info.value).startswith(f"gt={path}")


def test_pickles_are_never_loaded(tmp_path):
    path = tmp_path / "gt.npy"
    np.save(path, np.array([[object()]], dtype=object), allow_pickle=True)
    with pytest.raises(
        DataError, match=r"holds Python objects \(a pickle\), which are never loaded"
    ):
        read_matrix(path, 1, 1, "gt")
    path.write_bytes(pickle.dumps(GT))
    with pytest.raises(DataError, match=r"is not a \.npy file .*save the matrix with numpy\.save"):
        read_matrix(path, 3, 4, "gt")


def test_truncated_and_oversized_npy(tmp_path, monkeypatch):
    path = tmp_path / "gt.npy"
    np.save(path, GT.astype(np.float64))
    path.write_bytes(path.read_bytes()[:-8])
    with pytest.raises(DataError, match=r"is truncated \(216 of 224 bytes\)"):
        read_matrix(path, 3, 4, "gt")
    np.save(path, GT)
    monkeypatch.setattr(gtmatrix, "MAX_MATRIX_CELLS", 11)
    with pytest.raises(DataError, match=r"claims 12 cells, more than 11"):
        read_matrix(path, 3, 4, "gt")
    monkeypatch.setattr(gtmatrix, "MAX_GROUND_TRUTH_ITEMS", 3)
    monkeypatch.setattr(gtmatrix, "MAX_MATRIX_CELLS", 100)
    with pytest.raises(DataError, match=r"holds more than 3 ones; the accepted sets would not fit"):
        read_matrix(path, 3, 4, "gt")
    monkeypatch.setattr(gtmatrix, "MAX_GROUND_TRUTH_BYTES", 10)
    with pytest.raises(DataError, match=r"is \d+ bytes, more than 10; save it as a bool \.npy"):
        read_matrix(path, 3, 4, "gt")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("1,1,0,0\n0,0,0,0\n", r"has shape \(2, 4\); expected 3 x 4"),
        ("1,1,0,0\n0,0,0,0\n0,0,1,1\n1,1,1,1\n", r"has shape \(4, 4\); expected 3 x 4"),
        ("1,1,0\n0,0,0\n0,0,1\n", r"has shape \(3, 3\); expected 3 x 4"),
        ("ref0,ref1,ref2,ref3\n", r"line 1, column 0: 'ref0' is not 0 or 1; .*\(no header\)"),
        ("1,1,0,0\n0,0,x,0\n0,0,1,1\n", r"line 2, column 2: 'x' is not 0 or 1"),
        ("1,1,0,0\n0,0,,0\n0,0,1,1\n", r"line 2, column 2: '' is not 0 or 1"),
        ("1,1,0,0\n0,0,0.5,0\n0,0,1,1\n", r"line 2, column 2: '0.5' is not 0 or 1"),
        ("1;1;0;0\n", r"has shape \(1, 1\); expected 3 x 4"),
        # its whole shape, so a transposed file is named as one (it was '(3, 3)', the
        # first line's count as if every line were like it, with no hint)
        ("1,0,0\n0,1,0\n0,0,1\n1,1,1\n", r"has shape \(4, 3\); .*add gt_transpose=1"),
        ("1,1,0,0\n0,0,0\n0,0,1,1\n", r"line 2 has 3 values where line 1 has 4; every line"),
        # no line, or blank lines only: it was 'has shape (0, 4)', a width it does not have
        ("", r"has no values \(an empty file\); expected 3 x 4 \(queries x references"),
        ("\n \n\n", r"has no values \(an empty file\); expected 3 x 4"),
    ],
)
def test_bad_csv_is_named(tmp_path, text, message):
    path = tmp_path / "gt.csv"
    path.write_text(text)
    with pytest.raises(DataError, match=message):
        read_matrix(path, 3, 4, "gt")


def test_missing_folder_and_suffix(tmp_path):
    with pytest.raises(DataError, match=r"gt=.*nope\.npy does not exist: check the path"):
        read_matrix(tmp_path / "nope.npy", 3, 4, "gt")
    (tmp_path / "d.npy").mkdir()
    with pytest.raises(DataError, match=r"d\.npy is a folder; give the ground-truth matrix"):
        read_matrix(tmp_path / "d.npy", 3, 4, "gt")
    (tmp_path / "gt.mat").write_bytes(b"")
    with pytest.raises(
        DataError, match=r"gt\.mat must be a \.npy, \.npz or \.csv file of 0s and 1s"
    ):
        read_matrix(tmp_path / "gt.mat", 3, 4, "gt_soft")
