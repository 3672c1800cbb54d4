"""Every loader on a small generated layout, and the bad inputs each must explain."""

from __future__ import annotations

import pickle
import re

import numpy as np
import pytest
from scipy.io import savemat

from ppaloc.datasets import load_dataset
from ppaloc.errors import DataError


def _levels(seq):
    return [int(f[0, 0]) for f in seq]


# --- folder ---------------------------------------------------------------------------------


def test_folder_natural_sort_index_truth_and_selection(write_frames, tmp_path):
    names = ["Image1.png", "Image2.png", "Image10.png", "Image11.png", "Image3.png"]
    write_frames(tmp_path / "ref", [1, 2, 10, 11, 3], names)
    write_frames(tmp_path / "qry", [101, 102, 110, 111, 103], names, colour=True)
    ds = load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}?tolerance=1")
    assert _levels(ds.reference) == [1, 2, 3, 10, 11]  # Image3 before Image10
    assert _levels(ds.query) == [101, 102, 103, 110, 111]
    assert ds.query[0].ndim == 2  # colour read as grey
    assert [g.tolist() for g in ds.ground_truth] == [
        [0, 1],
        [0, 1, 2],
        [1, 2, 3],
        [2, 3, 4],
        [3, 4],
    ]
    sub = load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}?start=1&step=2")
    assert _levels(sub.reference) == [2, 10] and _levels(sub.query) == [102, 110]
    assert [g.tolist() for g in sub.ground_truth] == [[0], [1]]


def test_folder_bad_inputs(write_frames, tmp_path):
    write_frames(tmp_path / "ref", [1, 2, 3])
    write_frames(tmp_path / "qry", [1, 2])
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataError, match=r"query folder .*missing does not exist"):
        load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'missing'}")
    with pytest.raises(
        DataError, match=r"holds no images .*: give the folder that holds the frames"
    ):
        load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'empty'}")
    with pytest.raises(DataError, match=r"has 3 images but query .* has 2; .* start=/stop="):
        load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}")
    with pytest.raises(DataError, match=r"start=5 stop=None keeps none of the 3 reference"):
        load_dataset(f"folder:{tmp_path / 'ref'},{tmp_path / 'ref'}?start=5")


def test_corrupt_image_named_when_read(write_frames, tmp_path):
    write_frames(tmp_path / "ref", [1, 2])
    paths = write_frames(tmp_path / "qry", [1, 2])
    paths[1].write_bytes(paths[1].read_bytes()[:30])  # truncated PNG
    spec = f"folder:{tmp_path / 'ref'},{tmp_path / 'qry'}"
    named = r"cannot read image .*Image001\.png.*replace the file"
    with pytest.raises(DataError, match=named):  # the same-place rule reads every frame
        load_dataset(spec)
    ds = load_dataset(spec + "?same_place=off")  # else frames are read when used
    assert int(ds.query[0][0, 0]) == 1
    with pytest.raises(DataError, match=named):
        ds.query[1]


# --- nordland -------------------------------------------------------------------------------


def _nordland(write_frames, root, summer, winter):
    names = [f"images-{10 * (k + 1):05d}.png" for k in range(len(summer))]
    write_frames(root / "summer", summer, names)
    write_frames(root / "winter", winter, names[: len(winter)])


def test_nordland_sync_and_dark_frames_dropped_together(write_frames, tmp_path):
    _nordland(write_frames, tmp_path, [0, 90, 100, 5, 120, 130], [80, 95, 10, 90, 125, 135])
    ds = load_dataset(f"nordland:{tmp_path}")
    assert ds.name == "nordland summer->winter" and ds.tolerance == 1
    assert len(ds.reference) == len(ds.query) == 6
    dropped = load_dataset(f"nordland:{tmp_path}?drop_dark=1&tolerance=0")
    assert _levels(dropped.reference) == [90, 120, 130]  # 0 and 5 in summer, 10 in winter
    assert _levels(dropped.query) == [95, 125, 135]
    assert dropped.meta["dropped_dark"] == 3
    assert dropped.meta["file_index"].tolist() == [1, 4, 5]
    assert [g.tolist() for g in dropped.ground_truth] == [[0], [1], [2]]
    swapped = load_dataset(f"nordland:{tmp_path}?ref=winter&query=summer&dark=1&drop_dark=1")
    assert _levels(swapped.reference) == [95, 10, 90, 125, 135]  # summer 0 is below 1


def test_nordland_bad_inputs(write_frames, tmp_path):
    _nordland(write_frames, tmp_path, [50, 60, 70], [50, 60])
    with pytest.raises(
        DataError, match=r"hold different frames .*images-00030\.png has no partner"
    ):
        load_dataset(f"nordland:{tmp_path}")
    with pytest.raises(DataError, match=r"season folder .*spring does not exist \(present: summer"):
        load_dataset(f"nordland:{tmp_path}?ref=spring")
    with pytest.raises(DataError, match="choose two different seasons"):
        load_dataset(f"nordland:{tmp_path}?query=summer")
    with pytest.raises(DataError, match=r"Nordland folder .*nowhere does not exist"):
        load_dataset(f"nordland:{tmp_path / 'nowhere'}")
    # a season's own folder given as the root was "summer/summer does not exist (present:
    # none); choose ref= and query= among them"
    with pytest.raises(DataError) as info:
        load_dataset(f"nordland:{tmp_path / 'summer'}")
    assert str(info.value) == (
        f"Nordland folder {tmp_path / 'summer'} is a season folder, not the folder that holds "
        f"the seasons: give its parent ({tmp_path}) and choose the seasons with ref= and query="
    )


# --- gardens point and vprbench -------------------------------------------------------------


def _save_rows(path, rows):
    arr = np.empty((len(rows), 2), dtype=object)
    for k, (q, refs) in enumerate(rows):
        arr[k, 0], arr[k, 1] = q, refs
    np.save(path, arr, allow_pickle=True)


def test_gardens_point_index_and_vprbench_truth(write_frames, tmp_path):
    for name, base in (("day_left", 0), ("day_right", 50), ("night_right", 100)):
        write_frames(tmp_path / name, [base + k for k in range(5)])
    _save_rows(tmp_path / "vprbench_ground_truth.npy", [(k, [max(k - 1, 0), k]) for k in range(5)])
    ds = load_dataset(f"gardens-point:{tmp_path}?ref=day_left&query=night_right")
    assert _levels(ds.reference)[:2] == [0, 1] and _levels(ds.query)[:2] == [100, 101]
    assert ds.tolerance == 2 and ds.ground_truth[0].tolist() == [0, 1, 2]
    vb = load_dataset(f"gardens-point:{tmp_path}?gt=vprbench")
    assert [g.tolist() for g in vb.ground_truth] == [[0], [0, 1], [1, 2], [2, 3], [3, 4]]
    with pytest.raises(DataError, match="choose two different traversals"):
        load_dataset(f"gardens-point:{tmp_path}?ref=day_left&query=day_left")


def test_vprbench_layout(write_frames, tmp_path):
    write_frames(tmp_path / "ref", [1, 2, 3, 4])
    write_frames(tmp_path / "query", [11, 12])
    _save_rows(tmp_path / "ground_truth_new.npy", [(0, [3]), (1, [])])
    ds = load_dataset(f"vprbench:{tmp_path}?tolerance=1")
    assert len(ds.reference) == 4 and len(ds.query) == 2
    assert [g.tolist() for g in ds.ground_truth] == [[2, 3], []]  # no true match for query 1
    _save_rows(tmp_path / "bad.npy", [(0, [3]), (1, [9])])
    with pytest.raises(DataError, match=r"bad\.npy: query 1 accepts reference index 9"):
        load_dataset(f"vprbench:{tmp_path}?gt=bad.npy")


# --- citycentre -----------------------------------------------------------------------------


def _citycentre(write_frames, root, pairs, revisit_from, by_image=False):
    # Capture k: left image value k, right image value 100 + k (numbered from 1).
    values = [v for k in range(pairs) for v in (k, 100 + k)]
    write_frames(root / "Images", values, [f"{i + 1:04d}.jpg" for i in range(2 * pairs)])
    n = 2 * pairs if by_image else pairs
    truth = np.zeros((n, n), np.uint8)
    for q in range(revisit_from, pairs):
        r = q - revisit_from  # the second lap passes the first lap's places in order
        if by_image:
            truth[2 * q, 2 * r] = truth[2 * q + 1, 2 * r + 1] = 1
        else:
            truth[q, r] = 1
    savemat(root / "CityCentreGroundTruth.mat", {"truth": truth})


@pytest.mark.parametrize("by_image", [False, True])
def test_citycentre_split_at_first_revisit(write_frames, tmp_path, by_image):
    _citycentre(write_frames, tmp_path, pairs=30, revisit_from=24, by_image=by_image)
    ds = load_dataset(f"citycentre:{tmp_path}")
    assert ds.meta["split"] == 24
    assert len(ds.reference) == 24 and len(ds.query) == 6
    assert abs(int(ds.reference[3][0, 0]) - 3) <= 2  # left camera, JPEG tolerance
    assert [g.tolist() for g in ds.ground_truth] == [[k] for k in range(6)]
    right = load_dataset(f"citycentre:{tmp_path}?camera=right&split=26")
    assert abs(int(right.reference[0][0, 0]) - 100) <= 2
    assert len(right.query) == 4 and right.ground_truth[0].tolist() == [2]


def test_citycentre_bad_inputs(write_frames, tmp_path):
    _citycentre(write_frames, tmp_path, pairs=30, revisit_from=24)
    with pytest.raises(DataError, match=r"split=30 must be between 1 and 29"):
        load_dataset(f"citycentre:{tmp_path}?split=30")
    savemat(tmp_path / "old_truth.mat", {"truth": np.zeros((7, 7))})
    with pytest.raises(DataError, match=r"cannot tell the ground-truth .mat file .*truth=FILE"):
        load_dataset(f"citycentre:{tmp_path}")
    with pytest.raises(DataError, match=r"truth matrix is 7x7 but the folder has 60 images"):
        load_dataset(f"citycentre:{tmp_path}?truth=old_truth.mat")


# --- video ----------------------------------------------------------------------------------


def _write_video(path, frames, fps=10, shape=None, codec="libx264", pix_fmt="yuv420p"):
    """``frames`` (grey, uint8) as a video; ``shape`` sizes one of no frames."""
    av = pytest.importorskip("av")
    with av.open(str(path), "w") as out:
        stream = out.add_stream(codec, rate=fps)
        stream.height, stream.width = shape or frames[0].shape
        stream.pix_fmt = pix_fmt
        if not frames:  # the container's header and no packet
            out.start_encoding()
            return
        for f in frames:
            out.mux(stream.encode(av.VideoFrame.from_ndarray(f, format="gray")))
        out.mux(stream.encode())


def test_video_step_and_alignment(tmp_path):
    frames = [np.full((32, 48), 20 * k, np.uint8) for k in range(10)]
    _write_video(tmp_path / "ref.mp4", frames)
    _write_video(tmp_path / "qry.mp4", frames[:7])
    ds = load_dataset(f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'qry.mp4'}?align=proportional")
    assert len(ds.reference) == 10 and len(ds.query) == 7
    assert ds.reference[4].shape == (32, 48) and abs(int(ds.reference[4].mean()) - 80) <= 3
    assert ds.ground_truth[6].tolist() == [9] and ds.ground_truth[3].tolist() == [4, 5]
    stepped = load_dataset(f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'ref.mp4'}?step=3")
    assert len(stepped.reference) == 4
    assert [abs(int(f.mean()) - 60 * k) <= 3 for k, f in enumerate(stepped.query)] == [True] * 4
    assert int(stepped.query[1].mean()) > int(stepped.query[0].mean())  # backwards: restart
    copied = pickle.loads(pickle.dumps(stepped))
    assert copied.query[2].tobytes() == stepped.query[2].tobytes()
    with pytest.raises(DataError, match=r"align=index needs equal counts: add align=proportional"):
        load_dataset(f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'qry.mp4'}")
    with pytest.raises(DataError, match=r"video .*none\.mp4 does not exist"):
        load_dataset(f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'none.mp4'}")
    (tmp_path / "junk.mp4").write_bytes(b"\x00" * 100)
    with pytest.raises(DataError, match=r"junk\.mp4"):
        load_dataset(f"video:{tmp_path / 'ref.mp4'},{tmp_path / 'junk.mp4'}")


def test_a_video_cut_short_is_named(tmp_path):
    # its stream had no decoder set up: "cannot read video ...: 'NoneType' object has no
    # attribute 'width'", a Python error in place of the cause (an MPEG-4 part 2 stream
    # cut short leaves it so; H.264 cut short loses the stream itself, named before)
    path = tmp_path / "clip.mp4"
    _write_video(path, [np.zeros((32, 32), np.uint8)], codec="mpeg4")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(DataError, match=r"clip\.mp4 holds no decodable video stream \(cut short"):
        load_dataset(f"video:{path},{path}")


def test_a_damaged_video_without_a_frame_count_is_named(tmp_path):
    # Matroska records no frame count, so the frames are counted by decoding them; a damaged
    # frame met there ended in an internal error (av's InvalidDataError, exit 3)
    path = tmp_path / "clip.mkv"
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (48, 64), dtype=np.uint8) for _ in range(30)]
    _write_video(path, frames, codec="mjpeg", pix_fmt="yuvj420p")
    data = bytearray(path.read_bytes())
    at = [m.start() for m in re.finditer(b"\xff\xd8", bytes(data))][6] + 300  # frame 6's tables
    data[at : at + 250] = bytes((b * 7 + 13) % 256 for b in data[at : at + 250])
    path.write_bytes(bytes(data))
    with pytest.raises(DataError) as err:
        load_dataset(f"video:{path},{path}")
    message = str(err.value)
    assert re.fullmatch(
        rf"cannot decode frame \d+ of video {re.escape(str(path))} \(decoded to count its "
        r"frames, which its container does not record\): Invalid data found when processing "
        r"input; the video is damaged or cut short: give a complete video",
        message,
    ), message


def test_ffmpeg_causes_read_without_error_numbers(tmp_path):
    # "cannot read video ...: [Errno 1094995529] Invalid data found when processing input:
    # '...'": FFmpeg's error number and the file again; an empty file is called empty
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"\x00" * 100)
    with pytest.raises(DataError) as err:
        load_dataset(f"video:{junk},{junk}")
    assert str(err.value) == f"cannot read video {junk}: Invalid data found when processing input"
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    with pytest.raises(DataError) as err:
        load_dataset(f"video:{empty},{empty}")
    assert str(err.value) == f"video {empty} is empty (0 bytes); give a complete video"


def test_a_video_of_no_frames_is_named(tmp_path):
    # FFmpeg's end of file on opening it: "cannot read video ...: [Errno 541478725] End of
    # file", an error number in place of the cause
    path = tmp_path / "empty.mkv"
    _write_video(path, [], shape=(32, 32))
    with pytest.raises(DataError, match=r"empty\.mkv holds no frames \(an empty video"):
        load_dataset(f"video:{path},{path}")


def test_a_missing_relative_folder_says_where_it_was_looked_for(tmp_path, monkeypatch):
    # a spec in a --config file of another folder is read from the current one, unsaid
    monkeypatch.chdir(tmp_path)
    with pytest.raises(DataError) as info:
        load_dataset("nordland:../data/nordland-64x32")
    assert str(info.value) == (
        "Nordland folder ../data/nordland-64x32 does not exist: check the path in the dataset "
        f"spec (a relative path is read from the current folder, {tmp_path})"
    )
    with pytest.raises(DataError) as info:
        load_dataset(f"nordland:{tmp_path / 'nowhere'}")
    assert str(info.value).endswith("check the path in the dataset spec")
