"""Frames from a folder of images, a video file and a live stream drive a program."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli.main import cli, main
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
    frames = list(load_frames(None, f"video:{tmp_path / 'clip.mkv'}", None))
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
    assert len(list(load_frames(None, None, None, "color=c=white:size=8x8", "lavfi"))) == 10


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


def _clip(path: Path, codec: str, pix_fmt: str, frames: int = 1) -> Path:
    """A video of ``frames`` 64 x 48 frames in ``codec``."""
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream(codec, rate=10)
        stream.width, stream.height, stream.pix_fmt = 64, 48, pix_fmt
        for _ in range(frames):
            for packet in stream.encode(av.VideoFrame(64, 48, pix_fmt)):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


def test_a_stream_option_the_input_does_not_take_is_refused(tmp_path, monkeypatch, capsys):
    # FFmpeg leaves an option no part of it takes unused, without a word: the run went on
    # with the input's defaults (a camera at its own size for video_sise=640x480)
    av = pytest.importorskip("av")
    from ppaloc.datasets.loaders.ffoptions import input_options

    if input_options("lavfi") is None:  # nothing is refused where the tables cannot be read
        pytest.skip("the option tables of this PyAV build's FFmpeg libraries cannot be read")
    with pytest.raises(PpalocError) as err:
        load_frames(None, None, 1, "testsrc", "lavfi", ["video_sise=640x480"])
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(
        "stream testsrc (format lavfi): the lavfi input takes no option 'video_sise'; its "
        "own options: dumpgraph, graph, graph_file; FFmpeg's general input and decoding "
        "options are taken too (probesize, analyzeduration"
    )
    # a format FFmpeg finds itself (a file's) is asked once it is found
    path = _clip(tmp_path / "clip.mkv", "ffv1", "yuv420p")
    with pytest.raises(PpalocError, match=r"the matroska input and its ffv1 decoder take no "):
        load_frames(None, None, 1, str(path), None, ["nosuch=1"])
    # what the input and FFmpeg's general options take goes through
    assert len(list(load_frames(None, None, 1, str(path), None, ["probesize=100000"]))) == 1
    options = ["graph=testsrc=size=8x8", "analyzeduration=0", "threads=1"]
    assert len(list(load_frames(None, None, 2, "unused", "lavfi", options))) == 2
    # given a format, before the input is opened; the command's error is one line, exit 1
    monkeypatch.setattr(av, "open", lambda *a, **k: pytest.fail("the input was opened"))
    argv = ["cpp", "run", str(MEANS), "--stream", "testsrc", "--stream-format", "lavfi"]
    assert main([*argv, "--stream-option", "bogus=1", "--out", str(tmp_path / "run")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the lavfi input takes no option 'bogus'" in err


def test_a_decoding_option_reaches_the_decoder_the_frames_come_from(tmp_path):
    # FFmpeg's decoding options (lowres) were taken and changed nothing: PyAV hands them to
    # the decoder it opens while probing the input alone; a decoder's own (mjpeg's
    # extern_huff) was refused as no option of the input
    pytest.importorskip("av")
    from ppaloc.datasets.loaders.ffoptions import input_options
    from ppaloc.datasets.loaders.video import stream_frames

    if input_options("avi") is None:
        pytest.skip("the option tables of this PyAV build's FFmpeg libraries cannot be read")
    path = _clip(tmp_path / "clip.avi", "mjpeg", "yuvj420p")

    def first(options: dict[str, str]) -> np.ndarray:
        frames = stream_frames(str(path), None, options)
        try:
            return next(frames)
        finally:
            frames.close()

    assert first({}).shape == (48, 64)
    assert first({"lowres": "1", "probesize": "100000"}).shape == (24, 32)
    assert first({"extern_huff": "0"}).shape == (48, 64)
    # another decoder's own option is refused once the decoder is known, naming both
    with pytest.raises(PpalocError) as err:
        first({"enable_er": "1"})
    assert (
        "the avi input and its mjpeg decoder take no option 'enable_er'; the input's own "
        "options: use_odml; the decoder's: extern_huff; FFmpeg's general input and decoding "
        "options are taken too (probesize, "
    ) in str(err.value)
    # given a format, the check before the input is opened leaves it to that one
    with pytest.raises(PpalocError, match=r"the lavfi input and its \w+ decoder take no optio"):
        load_frames(None, None, 1, "testsrc", "lavfi", ["extern_huff=0"])
    # a name of bytes that are not UTF-8 (held as surrogates) is no option, in one line
    with pytest.raises(PpalocError, match=r"the lavfi input takes no option 'x\\udce9'"):
        load_frames(None, None, 1, "testsrc", "lavfi", ["x\udce9=0"])


def test_a_format_name_of_bytes_that_are_not_utf8_is_one_line(tmp_path):
    # --stream-format given bytes of another encoding (held as surrogates) beside a
    # --stream-option failed encoding its name to look it up: an internal error (exit 3)
    with pytest.raises(PpalocError) as err:
        load_frames(None, None, 1, str(tmp_path / "v.avi"), "av\udce9", ["threads=1"])
    message = str(err.value)
    assert message.startswith("cannot read stream ") and "(format av\udce9)" in message


def test_an_option_every_protocol_takes_is_not_refused(tmp_path):
    # rw_timeout (FFmpeg's URLContext: every protocol's) was refused as no option of the
    # input, for a file as for an http:// video
    pytest.importorskip("av")
    from ppaloc.datasets.loaders.ffoptions import input_options

    if input_options("matroska") is None:
        pytest.skip("the option tables of this PyAV build's FFmpeg libraries cannot be read")
    path = _clip(tmp_path / "clip.mkv", "ffv1", "yuv420p")
    for option in ("rw_timeout=5000000", "protocol_blacklist=udp"):
        assert len(list(load_frames(None, None, 1, str(path), None, [option]))) == 1


def test_the_option_tables_are_read_from_pyavs_own_ffmpeg(cxx, tmp_path):
    # another FFmpeg mapped into the process (one a package bundles) was taken for PyAV's:
    # the tables of another version were read, or (here, a library lacking them) none, and
    # nothing was refused
    import subprocess
    import sys

    pytest.importorskip("av")
    (tmp_path / "other.cpp").write_text(
        'extern "C" unsigned avformat_version(void) { return (58u << 16) | (76u << 8) | 100u; }\n'
    )
    other = tmp_path / "libavformat.so.58"
    subprocess.run([cxx, "-shared", "-fPIC", "-o", other, tmp_path / "other.cpp"], check=True)
    code = (
        "import ctypes, sys, av; ctypes.CDLL(sys.argv[1]); "
        "from ppaloc.datasets.loaders.ffoptions import input_options; "
        "print(input_options('lavfi') is not None)"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(other)], capture_output=True, text=True, check=True
    )
    assert done.stdout == "True\n", done.stderr


def test_the_program_is_checked_before_any_frame_is_read(tmp_path, monkeypatch):
    import ppaloc.datasets.loaders.video as video
    from ppaloc.cpp.command import run_cpp

    def never(*args, **kwargs):
        raise AssertionError("a frame was read")

    monkeypatch.setattr(video, "stream_frames", never)
    with pytest.raises(PpalocError, match="does not exist"):
        run_cpp(tmp_path / "gone.cpp", tmp_path / "run", stream="testsrc", stream_format="lavfi")
    with pytest.raises(PpalocError, match="must be NAME=VALUE"):
        run_cpp(MEANS, tmp_path / "run", stream="testsrc", settings=["x"])


class _Recorded:
    """Wraps ``video.stream_frames``: per frame decoded, the texts the program had posted
    (-1 before the run's session exists), and whether the input was closed."""

    def __init__(self, monkeypatch) -> None:
        import ppaloc.cpp.run as run
        import ppaloc.datasets.loaders.video as video

        self.posted_when_decoded: list[int] = []
        self.closed = False
        self.sessions: list = []
        opened, recorder = video.stream_frames, self

        class Stream:
            def __init__(self, *args, **kwargs) -> None:
                self.frames = opened(*args, **kwargs)

            def __iter__(self):
                return self

            def __next__(self):
                posted = len(recorder.sessions[0].texts) if recorder.sessions else -1
                frame = next(self.frames)
                recorder.posted_when_decoded.append(posted)
                return frame

            def close(self) -> None:
                recorder.closed = True
                self.frames.close()

        class Session(run.Session):
            def __post_init__(self) -> None:
                recorder.sessions.append(self)
                super().__post_init__()

        monkeypatch.setattr(video, "stream_frames", Stream)
        monkeypatch.setattr(run, "Session", Session)


def test_a_stream_feeds_the_program_as_it_is_decoded(cxx, lavfi, tmp_path, monkeypatch):
    from ppaloc.cpp.command import run_cpp

    rec = _Recorded(monkeypatch)
    result = run_cpp(MEANS, tmp_path / "run", stream="testsrc=size=32x24:rate=30",
                     stream_format="lavfi", frames=4, quiet=True)  # fmt: skip
    # Frame 0 is decoded before the session starts (it sizes the array); frame k >= 1 is
    # decoded only once the program has posted the means of frames 0 .. k-1.
    assert rec.posted_when_decoded == [-1, 1, 2, 3]
    # --frames bounds the endless test pattern: no frame beyond it is decoded, and the input
    # is closed once the last is taken.
    assert len(result.texts) == 4 and rec.closed
    assert result.summary()["frames"] == 4 and result.session.warnings == []


def test_frames_bound_an_endless_iterator_from_python(cxx):
    from ppaloc.cpp.frames import FrameSource

    taken: list[int] = []

    def endless():
        for k in itertools.count():
            taken.append(k)
            yield np.full((16, 16), 10 * k, np.uint8)

    result = run_program(MEANS, FrameSource(endless(), limit=3), timeout=20)
    np.testing.assert_allclose(_means(result.texts), [0, 10, 20], atol=1.0)
    assert taken == [0, 1, 2]


def test_a_frame_that_fails_mid_stream_keeps_the_frames_before(cxx, lavfi, tmp_path, monkeypatch):
    import ppaloc.datasets.loaders.video as video
    from ppaloc.cpp.command import run_cpp
    from ppaloc.cpp.run import FramesFailedError

    grey, calls = video._grey, []

    def broken(frame):  # the third frame's data is corrupt
        calls.append(1)
        if len(calls) == 3:
            raise ValueError("corrupt frame data")
        return grey(frame)

    monkeypatch.setattr(video, "_grey", broken)
    out = tmp_path / "run"
    with pytest.raises(FramesFailedError) as err:
        run_cpp(MEANS, out, stream="testsrc=size=32x24:rate=30", stream_format="lavfi",
                frames=5, quiet=True)  # fmt: skip
    assert str(err.value) == (
        "means.cpp stopped after 2 frame(s): cannot decode frame 2 of stream "
        f"testsrc=size=32x24:rate=30 (format lavfi): corrupt frame data; their outputs are in {out}"
    )
    assert (out / "text.txt").read_text().splitlines()[1].startswith("frame 1: mean ")
    assert len((out / "text.txt").read_text().splitlines()) == 2
    summary = json.loads((out / "summary.json").read_text())
    assert summary["frames"] == 2 and summary["warnings"] == [
        "the frames ended early: cannot decode frame 2 of stream testsrc=size=32x24:rate=30 "
        "(format lavfi): corrupt frame data"
    ]
    assert len(err.value.result.texts) == 2  # the run of the frames before, for Python
    assert len(calls) == 3  # nothing read after the failure


def test_a_source_is_closed_when_the_run_is_refused_before_it_starts(tmp_path):
    """A caller's open input (a camera) is released even when the output folder is refused."""
    from ppaloc.cpp.frames import FrameSource

    class Camera:
        closed = False

        def __iter__(self):
            return itertools.repeat(np.zeros((8, 8), np.uint8))

        def close(self):
            Camera.closed = True

    (tmp_path / "out").write_text("a user's file")
    with pytest.raises(PpalocError, match="out"):
        run_program(
            PROGRAMS / "means.cpp", frames=FrameSource(Camera(), limit=2), out=tmp_path / "out"
        )
    assert Camera.closed


def test_a_failed_runs_other_warnings_are_printed_before_its_error(tmp_path, monkeypatch, capsys):
    """The warnings of the frames that ran (a division by zero) are printed, the cause once."""
    from types import SimpleNamespace

    import ppaloc.cpp.command as command
    from ppaloc.cpp.run import FramesFailedError

    cause = "cannot decode frame 2 of stream s: bad data"
    session = SimpleNamespace(
        source=SimpleNamespace(error=cause),
        warnings=["means.cpp:9: an integer division by zero gave 0", f"frames ended: {cause}"],
    )

    def failing(*args, **kwargs):
        raise FramesFailedError(
            "means.cpp stopped after 2 frame(s)", SimpleNamespace(session=session)
        )

    monkeypatch.setattr(command, "run_program", failing)
    with pytest.raises(FramesFailedError):
        command.run_cpp(MEANS, tmp_path / "run", image=None, frames=2)
    assert capsys.readouterr().out == "  warning: means.cpp:9: an integer division by zero gave 0\n"
