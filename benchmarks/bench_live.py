"""Display updates per second through the live view: four 256 x 256 displays.

A program outputs four displays every frame (two analogue registers, two digital ones) on
256 x 256 frames, with a live view; a client polls ``state.json`` and fetches every display
image that changed, as the page does. A display update is one new PNG fetched by the
client. Two settings: the defaults (frames paced to 30 per second, the client polling every
100 ms, as the page: at most 4 x 10 updates per second) and a fast sensor (frames paced to
200 per second) with the client polling back to back (the most the server delivers while
the program runs; at most 4 x 200). The program's frame rate without a live view is given
for scale. Run: ``.venv/bin/python -m pytest benchmarks/bench_live.py -p no:xdist -s`` (or
``.venv/bin/python benchmarks/bench_live.py``).
"""

from __future__ import annotations

import json
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from ppaloc.cpp import compiler, run_program
from ppaloc.cpp.live import LiveView

#: (frames per second the run is paced to, the client's poll interval in seconds, frames)
SETTINGS = ((30.0, 0.1, 60), (200.0, 0.0, 400))
SIZE = 256

PROGRAM = """\
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle d[4];
    const char* names[4] = {"image", "edges", "mask", "dilated"};
    for (int i = 0; i < 4; ++i) d[i] = vs_gui_add_display(names[i], 0, i);
    int threshold = 10;
    vs_gui_add_slider("threshold", -128, 127, 10, &threshold);
    while (1) {
        vs_frame_loop_control();
        scamp5_kernel_begin();
            get_image(A);
            movx(C, A, east);
            sub(B, A, C);
        scamp5_kernel_end();
        scamp5_in(D, threshold);
        scamp5_kernel_begin();
            sub(E, B, D);
            where(E);
                MOV(R5, FLAG);
            all();
            DNEWS(R6, R5, 15);
        scamp5_kernel_end();
        scamp5_output_image(A, d[0]);
        scamp5_output_image(B, d[1]);
        scamp5_output_image(R5, d[2]);
        scamp5_output_image(R6, d[3]);
    }
}
"""


def _frames(n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(4)
    return [rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8) for _ in range(n)]


def _client(urls: list[str], stop: threading.Event, every_s: float, counts: dict) -> None:
    while not urls:
        time.sleep(0.001)
    seen: dict[int, str] = {}
    while not stop.is_set():
        try:
            with urllib.request.urlopen(urls[0] + "state.json", timeout=5) as r:
                state = json.loads(r.read())
            counts["polls"] += 1
            for d in state["displays"]:
                if seen.get(d["id"]) != d["src"]:
                    with urllib.request.urlopen(urls[0] + d["src"], timeout=5) as r:
                        r.read()
                    seen[d["id"]] = d["src"]
                    counts["updates"] += 1
        except OSError:  # the run ended and its server with it
            return
        if every_s:
            time.sleep(every_s)


def measure(fps: float, every_s: float, n: int) -> dict[str, float]:
    """Frames per second without and with the live view (paced to ``fps``), and display
    updates per second a client fetched (polling every ``every_s`` seconds, 0: back to
    back), over ``n`` frames."""
    frames = _frames(n)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench_live.cpp"
        path.write_text(PROGRAM)
        run_program(path, frames[:1])  # compile (cached)
        t0 = time.perf_counter()
        run_program(path, frames)
        plain = n / (time.perf_counter() - t0)
        urls: list[str] = []
        counts = {"polls": 0, "updates": 0}
        stop = threading.Event()
        client = threading.Thread(target=_client, args=(urls, stop, every_s, counts))
        client.start()
        t0 = time.perf_counter()
        run_program(path, frames, live=LiveView(fps=fps, announce=urls.append))
        wall = time.perf_counter() - t0
        stop.set()
        client.join()
    return {
        "plain_fps": plain,
        "live_fps": n / wall,
        "updates_per_s": counts["updates"] / wall,
        "polls_per_s": counts["polls"] / wall,
    }


def _line(fps: float, every_s: float, n: int, m: dict[str, float]) -> str:
    how = f"polling every {every_s * 1000:.0f} ms" if every_s else "polling back to back"
    return (
        f"4 displays of {SIZE}x{SIZE}, {n} frames paced to {fps:g}/s, client {how}: "
        f"{m['updates_per_s']:.0f} display updates/s ({m['polls_per_s']:.0f} polls/s); "
        f"program {m['live_fps']:.1f} frames/s with the live view, {m['plain_fps']:.1f} without"
    )


@pytest.mark.skipif(compiler() is None, reason="no C++ compiler (g++)")
@pytest.mark.parametrize(("fps", "every_s", "n"), SETTINGS)
def test_live_view_updates(fps: float, every_s: float, n: int) -> None:
    m = measure(fps, every_s, n)
    print("\n" + _line(fps, every_s, n, m))
    assert m["updates_per_s"] > 0


if __name__ == "__main__":
    for setting in SETTINGS:
        print(_line(*setting, measure(*setting)))
