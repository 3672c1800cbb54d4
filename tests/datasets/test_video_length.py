"""A video that decodes to fewer frames than its container declares is not shortened in
silence: FFmpeg ends a Matroska file cut short, or one whose damaged data its reader skipped,
without an error, and the frames were counted by decoding them (the container records no
count), so a map, a localisation and ``align=proportional`` ground truth used the frames
left as if they were the whole video."""

from __future__ import annotations

import re
import warnings
from fractions import Fraction

import numpy as np
import pytest

from ppaloc.cli import main
from ppaloc.datasets import load_dataset
from ppaloc.errors import DataError

av = pytest.importorskip("av")

from ppaloc.datasets.loaders.video import ShortVideoWarning, VideoFrames  # noqa: E402


def _mkv(path, pts, codec="ffv1", rate=10):
    """Grey 64 x 32 noise frames at the given times (in frames of ``rate``) as a video."""
    rng = np.random.default_rng(len(pts))
    with av.open(str(path), "w") as out:
        stream = out.add_stream(codec, rate=rate)
        stream.width, stream.height = 64, 32
        stream.pix_fmt = "gray" if codec == "ffv1" else "yuv420p"
        stream.codec_context.time_base = Fraction(1, rate)
        for t in pts:
            frame = av.VideoFrame.from_ndarray(rng.integers(0, 256, (32, 64), np.uint8), "gray")
            frame.pts, frame.time_base = t, Fraction(1, rate)
            out.mux(stream.encode(frame))
        out.mux(stream.encode())
    return path


def _cut(path, out, keep=2 / 3):
    data = path.read_bytes()
    out.write_bytes(data[: int(len(data) * keep)])
    return out


def _damage(path, out, size=3000):
    data = bytearray(path.read_bytes())
    mid = len(data) // 2
    data[mid : mid + size] = bytes(size)
    out.write_bytes(bytes(data))
    return out


def _decoded(path):
    with av.open(str(path)) as c:
        return [f.to_ndarray(format="gray") for f in c.decode(video=0)]


def test_a_good_video_reads_as_before_without_a_warning(tmp_path):
    # filterwarnings=error: a ShortVideoWarning here fails the test
    ok = _mkv(tmp_path / "ok.mkv", range(40))
    other = _mkv(tmp_path / "other.mkv", range(25))
    frames = VideoFrames(ok)
    assert len(frames) == 40
    assert all(np.array_equal(a, b) for a, b in zip(frames, _decoded(ok), strict=True))
    ds = load_dataset(f"video:{ok},{other}?align=proportional")
    assert len(ds.reference) == 40 and len(ds.query) == 25
    assert ds.ground_truth[24].tolist() == [39]


@pytest.mark.parametrize("missing", [1, 2])
def test_a_frame_or_two_short_of_the_container_is_no_warning(tmp_path, missing):
    path = _mkv(tmp_path / "gap.mkv", [t for t in range(40) if not 10 <= t < 10 + missing])
    assert len(VideoFrames(path)) == 40 - missing


def test_a_few_percent_short_of_the_container_is_no_warning(tmp_path):
    # 3 of 100 declared frames: more than two, but not more than 3 %
    path = _mkv(tmp_path / "gap.mkv", [t for t in range(100) if not 50 <= t < 53])
    assert len(VideoFrames(path)) == 97
    path = _mkv(tmp_path / "gap4.mkv", [t for t in range(100) if not 50 <= t < 54])
    with pytest.warns(ShortVideoWarning, match=r"decoded to 96 frames, but its container dec"):
        assert len(VideoFrames(path)) == 96


def test_a_video_cut_short_warns_naming_both_counts(tmp_path):
    cut = _cut(_mkv(tmp_path / "ok.mkv", range(40)), tmp_path / "cut.mkv")
    with pytest.warns(ShortVideoWarning) as caught:
        frames = VideoFrames(cut)
    (message,) = [str(w.message) for w in caught]
    n = len(frames)
    assert n < 37
    assert message == (
        f"video {cut} decoded to {n} frames, but its container declares 40 (4.0 s at 10 fps), "
        f"and they stop at {(n - 1) / 10:.1f} s: it is cut short or damaged; its {n} frames "
        "are used"
    )


def test_frames_missing_inside_a_video_warn(tmp_path):
    path = _mkv(tmp_path / "gap.mkv", [t for t in range(40) if not 10 <= t < 20])
    with pytest.warns(ShortVideoWarning) as caught:
        assert len(VideoFrames(path)) == 30
    assert [str(w.message) for w in caught] == [
        f"video {path} decoded to 30 frames, but its container declares 40 (4.0 s at 10 fps), "
        "and they reach 3.9 s: frames are missing inside it (damaged data skipped), or its "
        "frame rate varies; its 30 frames are used"
    ]


@pytest.mark.parametrize("codec", ["ffv1", "mpeg4"])
def test_a_damaged_video_is_not_shortened_in_silence(tmp_path, codec):
    damaged = _damage(_mkv(tmp_path / "ok.mkv", range(40), codec), tmp_path / "bad.mkv")
    with pytest.warns(ShortVideoWarning, match=r"decoded to \d+ frames, but its container "):
        assert len(VideoFrames(damaged)) < 37


def test_proportional_alignment_refuses_a_video_cut_short(tmp_path):
    ok = _mkv(tmp_path / "ok.mkv", range(40))
    cut = _cut(ok, tmp_path / "cut.mkv")
    for spec in (f"video:{ok},{cut}?align=proportional", f"video:{cut},{ok}?align=proportional"):
        with pytest.raises(DataError) as err:
            load_dataset(spec)
        assert re.fullmatch(
            rf"video {re.escape(str(cut))} decoded to \d+ frames, but its container declares "
            r"40 \(4\.0 s at 10 fps\), and they stop at [0-9.]+ s: it is cut short or damaged; "
            r"align=proportional places query frames by the two videos' lengths, so every "
            r"query frame's ground truth would be wrong: give a complete video, or your own "
            r"ground truth",
            str(err.value),
        ), err.value
    with pytest.warns(ShortVideoWarning):  # the one video twice: the lengths agree
        ds = load_dataset(f"video:{cut},{cut}?align=proportional")
    assert ds.ground_truth[3].tolist() == [3]
    with pytest.warns(ShortVideoWarning), pytest.raises(DataError, match="align=index needs"):
        load_dataset(f"video:{ok},{cut}")


def test_proportional_alignment_warns_of_frames_missing_inside(tmp_path):
    ok = _mkv(tmp_path / "ok.mkv", range(40))
    gap = _mkv(tmp_path / "gap.mkv", [t for t in range(40) if not 10 <= t < 20])
    with pytest.warns(ShortVideoWarning, match=r"30 frames are used, but align=proportional"):
        ds = load_dataset(f"video:{ok},{gap}?align=proportional")
    assert len(ds.query) == 30


def test_a_video_whose_container_counts_its_frames_names_the_count_where_it_ends(tmp_path):
    path = tmp_path / "clip.mp4"
    with av.open(str(path), "w", options={"movflags": "+faststart"}) as out:
        stream = out.add_stream("mpeg4", rate=10)
        stream.width, stream.height, stream.pix_fmt = 64, 32, "yuv420p"
        rng = np.random.default_rng(0)
        for _ in range(40):
            grey = rng.integers(0, 256, (32, 64), np.uint8)
            out.mux(stream.encode(av.VideoFrame.from_ndarray(grey, format="gray")))
        out.mux(stream.encode())
    cut = _cut(path, tmp_path / "cut.mp4")
    frames = VideoFrames(cut)  # the index counts 40: nothing is decoded yet
    assert len(frames) == 40
    with pytest.raises(DataError) as err:
        frames[39]
    assert re.fullmatch(
        rf"video {re.escape(str(cut))} ends before frame \d+ of the 40 its container "
        r"declares: it is cut short or damaged; give a complete video",
        str(err.value),
    ), err.value


def test_the_commands_say_so_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    ok = _mkv(tmp_path / "ok.mkv", range(40))
    _cut(ok, tmp_path / "cut.mkv")
    _mkv(tmp_path / "gap.mkv", [t for t in range(40) if not 10 <= t < 20])
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        code = main(["map", "video:cut.mkv", "--out", "cut.npz", "-q"])
        out, err = capsys.readouterr()
        assert code == 0 and out == ""
        assert re.fullmatch(
            r"ppaloc: warning: ShortVideoWarning: video cut\.mkv decoded to \d+ frames, but "
            r"its container declares 40 \(4\.0 s at 10 fps\), and they stop at [0-9.]+ s: it "
            r"is cut short or damaged; its \d+ frames are used\n",
            err,
        ), err  # once, though a map reads its video as reference and query
        assert main(["map", "video:ok.mkv", "--out", "m.npz", "-q"]) == 0
        capsys.readouterr()
        assert main(["localise", "m.npz", "gap.mkv"]) == 0
        out, err = capsys.readouterr()
        assert len(out.splitlines()) == 31  # a header and 30 rows
        assert err == (
            "ppaloc: warning: ShortVideoWarning: video gap.mkv decoded to 30 frames, but its "
            "container declares 40 (4.0 s at 10 fps), and they reach 3.9 s: frames are "
            "missing inside it (damaged data skipped), or its frame rate varies; its 30 "
            "frames are used\n"
        )
        spec = "video:ok.mkv,cut.mkv?align=proportional"
        code = main(["evaluate", "-d", spec, "-m", "single-frame", "--out", "e", "-q"])
        out, err = capsys.readouterr()
        assert code == 1 and len(err.splitlines()) == 1
        assert err.startswith("ppaloc: error: video cut.mkv decoded to ")
        assert "so every query frame's ground truth would be wrong" in err
