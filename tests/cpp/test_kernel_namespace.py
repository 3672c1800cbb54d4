"""A kernel block sees the registers without ``using namespace SCAMP5_PE``, as on the
device, whose ``scamp5_kernel_api`` namespace says ``using namespace SCAMP5_PE`` itself
(the files of a multi-file public program, such as a class's methods, rarely say it)."""

from __future__ import annotations

import numpy as np

from ppaloc.cpp import run_program

PROGRAM = r"""
#include <scamp5.hpp>

static void negate_into_b() {  // a helper kernel in a file that never names SCAMP5_PE
    scamp5_kernel_begin();
        mov(B, A);
        WHERE(R6);
        ALL();
    scamp5_kernel_end();
}

int main() {
    vs_init();
    vs_handle out = vs_gui_add_display("b", 0, 0);
    scamp5_kernel k([] {
        using namespace scamp5_kernel_api;
        get_image(A);
        CLR(R6);
    });
    while (1) {
        vs_frame_loop_control();
        k();
        negate_into_b();
        scamp5_output_image(SCAMP5_PE::B, out);
    }
}
"""


def test_kernel_blocks_see_registers_without_using_scamp5_pe(cxx, tmp_path):
    source = tmp_path / "prog.cpp"
    source.write_text(PROGRAM)
    frame = np.full((16, 16), 200, np.uint8)
    result = run_program(source, [frame], timeout=60)
    assert len(result.session.outputs) == 1
    # get_image gives p/2 - 64 = 36; mov through the bus gives it back negated twice
    assert np.all(np.abs(result.session.outputs[0][1] - 36) <= 1)
