"""Hostile files: every reader names the file and the cause, never quotes the file's bytes,
tells a damaged file from one that needs ``trust=1``, and bounds sizes before allocating."""

from __future__ import annotations

import os
import pickle
import re
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse
from PIL import Image
from scipy.io import savemat

from ppaloc.datasets import load_dataset
from ppaloc.datasets.groundtruth import read_truth_mat, read_vprbench
from ppaloc.datasets.images import list_images, read_grey
from ppaloc.errors import DataError

SECRET = b"root:x:0:0:SECRET-CONTENT"


def _png_claiming(path: Path, width: int, height: int) -> Path:
    """A valid PNG header that claims ``width`` x ``height`` pixels, with almost no data."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(kind + data) & 0xFFFFFFFF
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    body = chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + body + chunk(b"IEND", b""))
    return path


# -- images --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("size", "fragment"),
    [
        ((100_000, 100_000), "claims too many pixels (10000000000; at most 50000000)"),
        ((8000, 8000), "claims 8000 x 8000 pixels, outside 1 to 50000000"),
    ],
)
def test_image_bomb_names_the_file(tmp_path, size, fragment):
    path = _png_claiming(tmp_path / "bomb.png", *size)
    with pytest.raises(DataError, match=re.escape(fragment)) as info:
        read_grey(path)
    assert str(path) in str(info.value)


def test_image_bomb_in_a_folder_run_names_the_file(write_frames, tmp_path):
    write_frames(tmp_path / "ref", [10, 20, 30])
    write_frames(tmp_path / "qry", [10, 20])
    _png_claiming(tmp_path / "qry" / "Image002.png", 100_000, 100_000)
    with pytest.raises(DataError, match=r"qry/Image002\.png claims too many pixels"):
        list(load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}").query)


def test_nan_pixels_in_a_float_tiff_are_refused(tmp_path):
    path = tmp_path / "depth.tif"
    Image.fromarray(np.array([[np.nan, 1.0], [0.5, np.inf]], np.float32)).save(path)
    with pytest.raises(DataError, match=r"depth\.tif holds 2 NaN or infinite pixels"):
        read_grey(path)


@pytest.mark.parametrize(
    ("content", "fragment"),
    [
        (SECRET, "cannot read image"),
        (b"", "cannot read image"),
        (b"\x89PNG\r\n\x1a\n" + b"\0" * 10, "cannot read image"),
    ],
)
def test_non_images_are_named_not_quoted(tmp_path, content, fragment):
    path = tmp_path / "x.png"
    path.write_bytes(content)
    with pytest.raises(DataError, match=fragment) as info:
        read_grey(path)
    assert "SECRET" not in str(info.value)


def test_a_folder_named_like_an_image_is_refused(tmp_path):
    (tmp_path / "frame.png").mkdir()
    with pytest.raises(DataError, match="is a folder, not an image file"):
        read_grey(tmp_path / "frame.png")


def test_dangling_symlink_in_a_folder_is_named(write_frames, tmp_path):
    write_frames(tmp_path / "ref", [1, 2, 3])
    write_frames(tmp_path / "qry", [1, 2])
    (tmp_path / "qry" / "Image002.png").symlink_to(tmp_path / "gone.png")
    with pytest.raises(DataError, match=r"Image002\.png is a symbolic link to .*gone\.png"):
        load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}")
    with pytest.raises(DataError, match="does not exist; restore the target"):
        list_images(tmp_path / "qry")


# -- VPR-Bench ground truth ------------------------------------------------------------------


def _rows(n: int) -> np.ndarray:
    rows = np.empty((n, 2), dtype=object)
    for q in range(n):
        rows[q, 0], rows[q, 1] = q, [q]
    return rows


def _npy_with_pickle(path: Path, n: int = 3) -> bytes:
    np.save(path, _rows(n), allow_pickle=True)
    return path.read_bytes()


class _Evil:
    def __reduce__(self):
        return (print, ("must never run",))


def _corrupt_cases(tmp_path: Path) -> list[tuple[str, bytes, str]]:
    good = _npy_with_pickle(tmp_path / "good.npy")
    header_end = good.index(b"\n") + 1
    plain = tmp_path / "plain.npy"
    np.save(plain, np.zeros((1000, 2), np.int64))
    plain_bytes = plain.read_bytes()
    huge = good[:header_end].replace(b"(3, 2)", b"(10000000000, 2)")
    return [
        ("plain text", SECRET + b"\n", "it is not a .npy file"),
        ("empty", b"", "it is not a .npy file"),
        ("a pickle, not a .npy", pickle.dumps([[0, [0]]]), "it is not a .npy file"),
        ("magic only", b"\x93NUMPY", "its .npy header is corrupt or truncated"),
        ("header cut", good[: header_end - 20], "its .npy header is corrupt or truncated"),
        ("pickle cut", good[: header_end + 30], "its pickled rows are corrupt or truncated"),
        ("pickle garbage", good[:header_end] + SECRET, "its pickled rows are corrupt"),
        ("array cut", plain_bytes[: len(plain_bytes) // 2], "it is truncated"),
        ("huge header", huge + b"\0" * 16, "its header claims 20000000000 elements"),
    ]


@pytest.mark.parametrize("trust", [False, True])
@pytest.mark.parametrize("case", range(9))
def test_vprbench_corrupt_file_is_not_a_question_of_trust(tmp_path, case, trust):
    label, content, fragment = _corrupt_cases(tmp_path)[case]
    path = tmp_path / "gt.npy"
    path.write_bytes(content)
    with pytest.raises(DataError) as info:
        read_vprbench(path, 3, 3, trust=trust)
    message = str(info.value)
    assert "trust=1" not in message, label
    assert "SECRET" not in message and "root:" not in message, label
    assert fragment in message, label


def test_vprbench_foreign_pickle_asks_for_trust_without_quoting(tmp_path, capsys):
    rows = _rows(2)
    rows[1, 1] = _Evil()
    path = tmp_path / "gt.npy"
    np.save(path, rows, allow_pickle=True)
    with pytest.raises(DataError, match="is a pickle that holds more than numbers") as info:
        read_vprbench(path, 2, 2)
    assert "trust=1" in str(info.value)
    assert "print" not in str(info.value) and "builtins" not in str(info.value)
    assert "must never run" not in capsys.readouterr().out


def test_vprbench_bad_row_values_are_not_quoted(tmp_path):
    rows = _rows(2)
    rows[1, 1] = ["SECRET"]
    path = tmp_path / "gt.npy"
    np.save(path, rows, allow_pickle=True)
    with pytest.raises(DataError, match="row 1: the query index and the reference") as info:
        read_vprbench(path, 2, 2)
    assert "SECRET" not in str(info.value)


def _vprbench_layout(write_frames, root: Path) -> Path:
    write_frames(root / "ref", [1, 2, 3])
    write_frames(root / "query", [1, 2, 3])
    _npy_with_pickle(root / "ground_truth_new.npy")
    return root


@pytest.mark.parametrize(
    ("gt", "fragment"),
    [
        ("../outside.npy", "points outside the dataset folder"),
        ("sub/../../outside.npy", "points outside the dataset folder"),
        ("link.npy", "points outside the dataset folder"),
        ("passwd", "must name a .npy file"),
        ("missing.npy", "does not exist"),
        ("folder.npy", "is a folder"),
    ],
)
def test_vprbench_gt_path_stays_in_the_dataset(write_frames, tmp_path, gt, fragment):
    root = _vprbench_layout(write_frames, tmp_path / "data")
    outside = tmp_path / "outside.npy"
    outside.write_bytes(SECRET)
    (root / "link.npy").symlink_to(outside)
    (root / "folder.npy").mkdir()
    with pytest.raises(DataError, match=fragment) as info:
        load_dataset(f"vprbench:{root}?gt={gt}")
    assert "SECRET" not in str(info.value)


def test_vprbench_gt_by_absolute_path_is_read_and_never_quoted(write_frames, tmp_path):
    root = _vprbench_layout(write_frames, tmp_path / "data")
    elsewhere = tmp_path / "elsewhere.npy"
    _npy_with_pickle(elsewhere)
    ds = load_dataset(f"vprbench:{root}?gt={elsewhere}")
    assert [a.tolist() for a in ds.ground_truth] == [[0], [1], [2]]
    elsewhere.write_bytes(SECRET)
    with pytest.raises(DataError, match=r"it is not a \.npy file") as info:
        load_dataset(f"vprbench:{root}?gt={elsewhere}")
    assert "SECRET" not in str(info.value)


# -- City Centre truth matrix ----------------------------------------------------------------


def test_sparse_truth_matrix_is_read(tmp_path):
    path = tmp_path / "truth.mat"
    savemat(path, {"truth": scipy.sparse.csr_matrix(np.eye(4))})
    assert read_truth_mat(path).tolist() == np.eye(4, dtype=bool).tolist()


@pytest.mark.parametrize(
    ("value", "fragment"),
    [
        ({"truth": np.eye(3)}, "'truth' is a MATLAB struct, not a matrix"),
        (np.array([np.eye(2), "x"], dtype=object), "'truth' is a MATLAB cell"),
        ("hello", "'truth' is a MATLAB char"),
        (np.zeros((3, 4)), "has shape (3, 4); expected a square matrix"),
        (np.zeros((2, 2, 2)), "expected a square matrix"),
        (np.array([[np.nan, 1], [0, 1]]), "holds NaN or infinite entries"),
        (
            scipy.sparse.csr_matrix((30_000, 30_000), dtype=np.float64),
            "is 30000x30000, larger than 20000x20000",
        ),
    ],
)
def test_bad_truth_matrices_get_a_clear_message(tmp_path, value, fragment):
    path = tmp_path / "truth.mat"
    savemat(path, {"truth": value})
    with pytest.raises(DataError) as info:
        read_truth_mat(path)
    assert fragment in str(info.value)


def test_a_text_file_named_mat_is_not_quoted(tmp_path):
    path = tmp_path / "truth.mat"
    path.write_bytes(SECRET * 10)
    with pytest.raises(DataError, match=r"not a MATLAB \.mat file, or corrupt") as info:
        read_truth_mat(path)
    assert "SECRET" not in str(info.value)


def test_citycentre_truth_outside_the_folder_is_refused(write_frames, tmp_path):
    write_frames(tmp_path / "cc", range(8))
    with pytest.raises(DataError, match=r"truth='\.\./x\.mat' points outside the dataset folder"):
        load_dataset(f"citycentre:{tmp_path / 'cc'}?truth=../x.mat")


def test_an_image_that_is_a_pipe_is_refused_before_it_is_opened(tmp_path):
    # Image.open on a FIFO waits for a writer for ever (ppaloc cpp run --image pipe.png)
    import os

    os.mkfifo(tmp_path / "f.png")
    with pytest.raises(DataError, match=r"f.png is not a regular file \(a pipe, device or "):
        read_grey(tmp_path / "f.png")


@pytest.mark.parametrize(
    ("spec", "named"),
    [
        ("video:{d}/pipe.mp4,{d}/pipe.mp4", "video {d}/pipe.mp4"),
        ("folder:{d}/ref,{d}/qry?gt={d}/pipe.npy", "gt={d}/pipe.npy"),
        (
            "folder:{d}/ref,{d}/qry?ref_positions={d}/pipe.csv&query_positions={d}/pipe.csv"
            "&tolerance_m=5",
            "ref_positions={d}/pipe.csv",
        ),
    ],
)
def test_a_pipe_a_spec_names_is_called_one_not_missing(tmp_path, spec, named):
    import os

    for sub in ("ref", "qry"):
        (tmp_path / sub).mkdir()
        Image.fromarray(np.zeros((8, 8), np.uint8)).save(tmp_path / sub / "a.png")
    for name in ("pipe.mp4", "pipe.npy", "pipe.csv"):
        os.mkfifo(tmp_path / name)
    with pytest.raises(DataError) as err:
        load_dataset(spec.format(d=tmp_path)).query_ground_truth  # noqa: B018
    assert str(err.value).startswith(
        named.format(d=tmp_path) + " is not a regular file (a pipe, device or socket)"
    )


@pytest.mark.parametrize(
    ("graph", "says"),
    [
        ("testsrc=size=8x8,scale=64:64", "claims 64 x 64 pixels a frame, more than 4000"),
        ("testsrc=size=64x64,scale=8:8", "makes frames of 64 x 64 pixels, more than 4000"),
    ],
)
def test_a_lavfi_graph_of_huge_frames_is_refused_before_it_makes_one(
    graph, says, tmp_path, monkeypatch
):
    # FFmpeg's probe ran the graph for a frame before its size was checked: a graph of
    # 20000 x 20000 frames took gigabytes and was killed
    av = pytest.importorskip("av")
    import ppaloc.datasets.loaders.video as video

    try:
        av.open("testsrc=size=32x24", format="lavfi").close()
    except Exception as exc:  # PyAV's FFmpeg built without lavfi
        pytest.skip(f"FFmpeg here has no lavfi input: {exc}")
    monkeypatch.setattr(video, "MAX_IMAGE_PIXELS", 4000)  # 64 x 64 is too large
    log = tmp_path / "frames.txt"  # a line per frame the graph makes, written at its close
    tail = f",metadata=mode=add:key=k:value=v,metadata=mode=print:file={log}"
    with pytest.raises(
        DataError, match=f"^stream {re.escape(graph + tail)} \\(format lavfi\\) {says};"
    ):
        video.stream_frames(graph + tail, "lavfi")
    assert not log.exists() or log.read_text() == ""


@pytest.mark.parametrize(
    ("make", "says"),
    [
        (lambda p: p.mkdir(), "f1.png is named like an image but is a folder; move it out"),
        (os.mkfifo, "f1.png is named like an image but is a pipe, device or socket; move it"),
        (lambda p: p.symlink_to(os.devnull), "f1.png is named like an image but is a pipe"),
        (lambda p: p.symlink_to(p.name), "f1.png is a symbolic link that leads into a loop"),
    ],
)
def test_an_entry_named_like_an_image_that_is_none_is_named_when_listed(tmp_path, make, says):
    # skipped without a word: a frame dropped, every later index moved against the other
    # traversal; a link loop was called a link to a target that does not exist
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "f0.png")
    make(tmp_path / "f1.png")
    with pytest.raises(DataError, match=f"^image folder {re.escape(str(tmp_path))}: {says}"):
        list_images(tmp_path)
