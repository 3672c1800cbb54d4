"""Kernel objects as the AnalogNet programs use them: ``<vs_import.hpp>``, an array of
kernels each recorded by calling it with a function (``ks[i]([] { ... })``, the device's
``operator()``), launched, and kernels made and deleted in the frame loop."""

from __future__ import annotations

import numpy as np

from ppaloc.cpp import run_program

PROGRAM = r"""
#include <scamp5.hpp>
#include <vs_import.hpp>
using namespace SCAMP5_PE;

scamp5_kernel kernels[2];

int main() {
    vs_init();
    vs_handle da = vs_gui_add_display("a", 0, 0);
    vs_handle db = vs_gui_add_display("b", 0, 1);
    vs_random rng;  // from <vs_import.hpp> as on the device
    (void)rng;
    while (1) {
        vs_frame_loop_control();
        scamp5_in(A, 100);
        scamp5_in(B, 100);
        kernels[0]([] {
            using namespace scamp5_kernel_api;
            diva(A, E, F);
        });
        // recorded already: calling it with another function keeps the first recording
        kernels[0]([] {
            using namespace scamp5_kernel_api;
            res(A);
        });
        scamp5_launch_kernel(kernels[0]);
        scamp5_kernel* made = new scamp5_kernel[1];
        made[0]([] {
            using namespace scamp5_kernel_api;
            diva(B, E, F);
            diva(B, E, F);
        })();
        delete[] made;
        vs_post_text("%d %d", kernels[0].null() ? 1 : 0, VS_LC);
        scamp5_output_image(A, da);
        scamp5_output_image(B, db);
    }
}
"""


def test_kernels_recorded_by_calling_them_with_a_function(cxx, tmp_path):
    source = tmp_path / "kernels.cpp"
    source.write_text(PROGRAM)
    frames = [np.zeros((16, 16), np.uint8)] * 2
    result = run_program(source, frames, timeout=60)
    assert result.texts == ["0 1", "0 2"]
    for out in result.session.outputs:
        np.testing.assert_allclose(out[1], 50, atol=1)  # 100 / 2
        np.testing.assert_allclose(out[2], 25, atol=1)  # 100 / 4
