"""``ppaloc localise --live``: the on-sensor localiser's frames, weights and estimates."""

from __future__ import annotations

import io
import json
import socket
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.cli.localise import weights_grid
from ppaloc.cli.main import main
from ppaloc.datasets import to_sensor


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def onsensor_map(tmp_path_factory) -> tuple[Path, Path]:
    """A map of ``onsensor-lowres`` over four 16 x 24 random images, and their folder."""
    root = tmp_path_factory.mktemp("live")
    ref = root / "ref"
    ref.mkdir()
    rng = np.random.default_rng(4)
    for i in range(4):
        Image.fromarray(rng.integers(0, 256, (16, 24), np.uint8)).save(ref / f"r{i}.png")
    out = root / "m.npz"
    assert main(["map", f"folder:{ref}", "-m", "onsensor-lowres", "--out", str(out), "-q"]) == 0
    return out, ref


class Localise:
    """``ppaloc localise MAP REF... --live`` in a thread, on a free port."""

    def __init__(
        self, map_path: Path, ref: Path, repeat: int, tmp_path: Path, fps: str = "10"
    ) -> None:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = s.getsockname()[1]
        self.url = f"http://127.0.0.1:{self.port}/"
        self.csv = tmp_path / "est.csv"
        argv = ["localise", str(map_path), *[str(ref)] * repeat, "--out", str(self.csv)]
        argv += ["--live", "--port", str(self.port), "--fps", fps]
        self.code: int | None = None
        self.thread = threading.Thread(target=lambda: setattr(self, "code", main(argv)))
        self.thread.daemon = True
        self.thread.start()

    def state(self, ready, what: str) -> dict:
        for _ in range(1200):  # the first frame builds the sensor's kernels
            try:
                with urllib.request.urlopen(self.url + "state.json", timeout=5) as r:
                    s = json.loads(r.read())
                if ready(s):
                    return s
            except OSError:
                pass  # not listening yet
            time.sleep(0.05)
        raise AssertionError(f"the live view never showed {what}")

    def get(self, path: str) -> bytes:
        with urllib.request.urlopen(self.url + path, timeout=5) as r:
            return r.read()

    def end(self) -> list[list[str]]:
        self.thread.join(60)
        assert not self.thread.is_alive() and self.code == 0
        return [line.split(",") for line in self.csv.read_text().splitlines()[1:]]


def test_live_shows_the_sensor_frame_the_weights_and_the_estimate(onsensor_map, tmp_path):
    map_path, ref = onsensor_map
    run = Localise(map_path, ref, 3, tmp_path, fps="4")  # 3 s of frames to read from
    s = run.state(lambda s: s["frame"] >= 1, "a frame")
    assert s["program"] == "ppaloc localise m.npz (onsensor-lowres)" and s["frames"] == 12
    assert [d["name"] for d in s["displays"]] == [
        "sensor frame",
        "weights of the 4 nodes, in node order by rows",
    ]
    assert s["items"] == []
    frame0 = s["texts"][0]
    assert frame0["frame"] == 0
    assert frame0["text"].startswith(f"{ref / 'r0.png'}: node 0 (reference frame 0), score ")
    for _ in range(50):  # the images of one frame: no frame ended between the reads
        sensor, weights = (
            np.asarray(Image.open(io.BytesIO(run.get(d["src"])))) for d in s["displays"]
        )
        again = run.state(lambda s: True, "the state")
        if again["displays"] == s["displays"]:
            break
        s = again
    else:
        raise AssertionError("the frames ran faster than the images could be read")
    assert sensor.shape == (256, 256) and weights.shape == (2, 2)
    shown = np.asarray(Image.open(ref / f"r{s['displays'][0]['frame'] % 4}.png"))
    assert (sensor == to_sensor(shown)).all()
    rows = run.end()
    texts = [t["text"] for t in s["texts"]]
    for row, text in zip(rows, texts, strict=False):
        moved = {"1": "yes", "0": "no", "": "unknown"}[row[5]]
        assert text.endswith(
            f"node {row[2]} (reference frame {row[3]}), score {row[4]}, moved {moved}"
        )


def test_live_refuses_a_host_method_and_stray_flags(onsensor_map, capsys):
    map_path, ref = onsensor_map
    code, out, err = run(capsys, "localise", map_path, ref, "--live", "-m", "weighted-node-lowres")
    assert (code, out) == (1, "")
    assert err == (
        "ppaloc: error: --live shows the on-sensor localiser, and method 'weighted-node-lowres' "
        "runs on the host: give --method onsensor-lowres, onsensor-lowres16, onsensor-lbp or "
        "onsensor-haar (with a map of their kind) or onsensor-auto (a map of any place a "
        "sensor holds; a patch map is the host's alone), or leave out --live\n"
    )
    for flag, value in (("--port", "8000"), ("--host", "0.0.0.0"), ("--fps", "5")):
        code, _, err = run(capsys, "localise", map_path, ref, flag, value)
        assert (code, err) == (
            1,
            f"ppaloc: error: {flag} is for the live view: give --live with it\n",
        )
    for fps in ("0", "1e-300"):  # 1e-300 waited beyond a timer: an internal error
        code, _, err = run(capsys, "localise", map_path, ref, "--live", "--fps", fps)
        assert err == (
            f"ppaloc: error: --fps {float(fps):g} must be a number of frames per second in "
            "[0.001, 10000]\n"
        )


def test_weights_grid_lays_the_nodes_out_by_rows():
    assert weights_grid(np.arange(5.0)).tolist() == [[0, 1, 2], [3, 4, 0]]
    assert weights_grid(np.array([7.0])).tolist() == [[7.0]]


@pytest.mark.slow
def test_chromium_shows_the_live_localiser(onsensor_map, tmp_path, dump_dom):
    map_path, ref = onsensor_map
    # 16 frames at 4 a second: the page must load its images before the view closes (at
    # 10 a second it closed 2 s after Chromium started, which a loaded machine can pass)
    run = Localise(map_path, ref, 4, tmp_path, fps="4")
    run.state(lambda s: s["frame"] >= 1, "a frame")
    out = dump_dom(run.url, 1500)
    run.end()
    dom = out.stdout
    assert dom.count('data-loaded="1"') == 2, out.stderr[-2000:]
    assert '<h1 id="title">ppaloc localise m.npz (onsensor-lowres)</h1>' in dom
    assert "sensor frame (frame " in dom and "weights of the 4 nodes" in dom
    assert ": node 0 (reference frame 0), score " in dom
