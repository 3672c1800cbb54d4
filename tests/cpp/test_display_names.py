"""A display's text never makes a path outside its own folder under ``displays/``: ``..``
or ``.`` wrote a run's frames at its top (where the next run refused them), and a long
text failed the whole run with 'File name too long' after the program had run."""

from __future__ import annotations

import numpy as np

from ppaloc.cpp import run_program

PROGRAM = r"""
#include <scamp5.hpp>
#include <string>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    std::string long_name(300, 'x');
    vs_handle up = vs_gui_add_display("..", 0, 0);
    vs_handle here = vs_gui_add_display(".", 0, 1);
    vs_handle wide = vs_gui_add_display(long_name.c_str(), 0, 2);
    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, B);
        scamp5_output_image(A, up);
        scamp5_output_image(B, here);
        scamp5_output_image(A, wide);
    }
}
"""


def test_display_texts_stay_inside_their_folders(cxx, tmp_path):
    source = tmp_path / "names.cpp"
    source.write_text(PROGRAM)
    out = tmp_path / "run"
    frames = [np.zeros((16, 16), np.uint8)]
    for _ in range(2):  # the second run replaces the first's folder
        run_program(source, frames, timeout=60, out=out)
        pngs = sorted(str(p.relative_to(out)) for p in out.rglob("frame_*.png"))
        assert pngs == [
            "displays/display_1/frame_0000.png",
            "displays/display_2/frame_0000.png",
            f"displays/{'x' * 64}/frame_0000.png",
        ]
