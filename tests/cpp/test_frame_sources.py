"""Frames from a folder of images, a video file and a live stream drive a program."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli.main import cli
from ppaloc.cpp import run_program
from ppaloc.cpp.command import load_frames
from ppaloc.errors import PpalocError
from ppaloc.frontend import to_sensor

from .conftest import PROGRAMS

MEANS = PROGRAMS / "means.cpp"


def _means(texts: list[str]) -> list[float]:
    return [float(re.fullmatch(r"mean (\S+)", t).group(1)) for t in texts]


def _run_cli(capsys, *args: str) -> list[float]:
    cli.main(["cpp", "run", str(MEANS), *args], standalone_mode=False)
    return [float(m) for m in re.findall(r"^  mean (\S+)$", capsys.readouterr().out, re.M)]


def _pictures(n: int, seed: int = 0) -> list[np.ndarray]:
    """Grey pictures of different sizes and levels (not 256 x 256: to_sensor resizes)."""
    rng = np.random.default_rng(seed)
    return [
        rng.integers(10 + 18 * i, 40 + 18 * i, (48 + 4 * i, 64), dtype=np.uint8) for i in range(n)
    ]


def test_a_folder_of_images_gives_every_frame_in_order(cxx, tmp_path, capsys):
    folder = tmp_path / "frames"
    folder.mkdir()
    pictures = _pictures(12)
    for i, p in enumerate(pictures):  # natural order: frame2 before frame10
        Image.fromarray(p).save(folder / f"frame{i}.png")
    means = _run_cli(capsys, "--dataset", f"folder:{folder}", "--out", str(tmp_path / "run"))
    want = [to_sensor(p).mean() for p in pictures]
    assert len(means) == 12  # all of a folder given alone, not the dataset default of 10
    np.testing.assert_allclose(means, want, atol=1.0)
    assert _run_cli(capsys, "--dataset", f"folder:{folder}", "--frames", "2", "--out",
                    str(tmp_path / "run")) == means[:2]  # fmt: skip


def _write_video(path: Path, levels: list[int]) -> None:
    """A short lossless video (FFV1) of flat grey frames, written with PyAV."""
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream("ffv1", rate=10)
        stream.width, stream.height, stream.pix_fmt = 64, 48, "yuv420p"
        for level in levels:
            rgb = np.full((48, 64, 3), level, np.uint8)
            for packet in stream.encode(av.VideoFrame.from_ndarray(rgb, format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def test_a_video_file_gives_its_frames(cxx, tmp_path, capsys):
    levels = [30, 90, 160, 230]
    _write_video(tmp_path / "clip.mkv", levels)
    frames = load_frames(None, f"video:{tmp_path / 'clip.mkv'}", None)
    assert len(frames) == 4 and frames[0].shape == (256, 256)
    result = run_program(MEANS, frames)
    np.testing.assert_allclose(_means(result.texts), levels, atol=2.0)
    two = _run_cli(capsys, "--dataset", f"video:{tmp_path / 'clip.mkv'}?step=2", "--out",
                   str(tmp_path / "run"))  # fmt: skip
    np.testing.assert_allclose(two, levels[::2], atol=2.0)


@pytest.fixture(scope="module")
def lavfi() -> None:
    """Skip where the installed FFmpeg cannot open lavfi filter graphs."""
    import av

    try:
        av.open("testsrc=size=32x24", format="lavfi").close()
    except Exception as exc:  # PyAV's FFmpeg built without libavdevice's lavfi
        pytest.skip(f"FFmpeg here has no lavfi input: {exc}")


def test_a_live_stream_is_bounded_by_frames(cxx, lavfi, tmp_path, capsys):
    import av

    graph = "testsrc=size=320x240:rate=30"
    means = _run_cli(
        capsys, "--stream", graph, "--stream-format", "lavfi", "--frames", "3", "--out",
        str(tmp_path / "run"),
    )  # fmt: skip
    with av.open(graph, format="lavfi") as container:
        decoded = container.decode(video=0)
        want = [to_sensor(next(decoded).to_ndarray(format="rgb24")).mean() for _ in range(3)]
    np.testing.assert_allclose(means, want, atol=1.0)
    assert len(load_frames(None, None, None, "color=c=white:size=8x8", "lavfi")) == 10  # default


def test_bad_frame_sources_are_one_line(tmp_path):
    cases = [
        ((None, "synthetic:", None, "x", None), "give one of --image, --dataset and --stream"),
        ((None, None, None, None, "v4l2"), "--stream-format v4l2 needs --stream INPUT"),
        ((None, f"video:{tmp_path / 'none.mp4'}", None), "does not exist"),
        ((None, f"folder:{tmp_path / 'none'}", None), "none"),
        ((None, None, 2, str(tmp_path / "none.mp4")), "cannot read stream"),
        ((None, None, 2, "testsrc", "no-such-format"), "cannot read stream testsrc (format"),
    ]
    for args, message in cases:
        with pytest.raises(PpalocError, match=re.escape(message)) as err:
            load_frames(*args)
        assert "\n" not in str(err.value)


def test_stream_options_reach_ffmpeg(cxx, tmp_path, capsys):
    raw = tmp_path / "frames.gray"  # raw 8 x 4 grey frames: FFmpeg needs their size and format
    raw.write_bytes(np.repeat(np.array([10, 200, 90], np.uint8), 32).tobytes())
    args = ["--stream", str(raw), "--stream-format", "rawvideo", "--frames", "5"]
    options = ["--stream-option", "video_size=8x4", "--stream-option", "pixel_format=gray"]
    means = _run_cli(capsys, *args, *options, "--out", str(tmp_path / "run"))
    assert means == [10.0, 200.0, 90.0]  # the stream ended after 3 of the 5 frames asked
    with pytest.raises(PpalocError, match=r"^--stream-option 'video_size' must be NAME=VALUE"):
        load_frames(None, None, 1, str(raw), "rawvideo", ["video_size"])
    with pytest.raises(PpalocError, match=r"^--stream-option needs --stream INPUT"):
        load_frames(None, None, 1, None, None, ["video_size=8x4"])


def test_the_program_is_checked_before_any_frame_is_read(tmp_path, monkeypatch):
    import ppaloc.datasets.loaders.video as video
    from ppaloc.cpp.command import run_cpp

    def never(*args, **kwargs):
        raise AssertionError("a frame was read")

    monkeypatch.setattr(video, "read_stream", never)
    with pytest.raises(PpalocError, match="does not exist"):
        run_cpp(tmp_path / "gone.cpp", tmp_path / "run", stream="testsrc", stream_format="lavfi")
    with pytest.raises(PpalocError, match="must be NAME=VALUE"):
        run_cpp(MEANS, tmp_path / "run", stream="testsrc", settings=["x"])
