"""Kernel objects as the AnalogNet programs use them: ``<vs_import.hpp>``, an array of
kernels each recorded by calling it with a function (``ks[i]([] { ... })``, the device's
``operator()``), launched, and kernels made and deleted in the frame loop."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.cpp import run_program
from ppaloc.errors import PpalocError

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


STACK = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;

// 300 mov = 600 ICWs: two such kernels do not fit the 1024-ICW stack at once
#define LONG_KERNEL(DST, SRC) ([] {                          \
        using namespace scamp5_kernel_api;                   \
        for (int i = 0; i < 300; i++) mov(DST, SRC);         \
    })

int main() {
    vs_init();
    int mode = 0;
    vs_gui_add_slider("mode", 0, 2, 0, &mode);
    vs_handle d = vs_gui_add_display("d", 0, 0);
    while (1) {
        vs_frame_loop_control();
        scamp5_in(A, 10);
        scamp5_in(C, 20);
        if (mode == 0) {  // each deleted after its launch: the next has the room again
            scamp5_kernel* k = new scamp5_kernel(LONG_KERNEL(B, A));
            (*k)();
            delete k;
            k = new scamp5_kernel(LONG_KERNEL(D, C));
            (*k)();
            delete k;
        } else if (mode == 1) {  // a copy going leaves the kernel it copied on the stack
            scamp5_kernel first(LONG_KERNEL(B, A));
            { scamp5_kernel copy = first; }
            first();
            scamp5_kernel second(LONG_KERNEL(D, C));
            second();
        } else {  // both alive at once: the second loses ICWs, as on the device
            static scamp5_kernel first(LONG_KERNEL(B, A));
            static scamp5_kernel second(LONG_KERNEL(D, C));
            first();
            second();
        }
        scamp5_output_image(D, d);
    }
}
"""


def test_a_deleted_kernel_leaves_the_icw_stack(cxx, tmp_path):
    source = tmp_path / "stack.cpp"
    source.write_text(STACK)
    frames = [np.zeros((16, 16), np.uint8)] * 2
    for mode, lost in ((0, False), (1, True), (2, True)):
        result = run_program(source, frames, settings={"mode": str(mode)}, timeout=60)
        warnings = result.summary()["warnings"]
        assert any("lost 176 of its ICWs" in w for w in warnings) == lost, (mode, warnings)
        assert len(warnings) == int(lost)  # once, though recorded again in every frame
        if not lost:
            for out in result.session.outputs:
                np.testing.assert_allclose(out[2], 20, atol=1)  # handle 2: after the slider


LONG = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    int n = 0;
    vs_gui_add_slider("n", 1, 1000000, 1, &n);
    vs_frame_loop_control();
    scamp5_dynamic_kernel_begin();
        for (int i = 0; i < n; i++) mov(A, B);  // 2 ICWs a call
    scamp5_dynamic_kernel_end();
}
"""


def test_a_kernel_of_65536_calls_or_more_keeps_its_first_icws(cxx, tmp_path):
    # the call count was 16 bits: 65,536 calls arrived as an empty kernel, 70,000 as 4,464
    source = tmp_path / "long.cpp"
    source.write_text(LONG)
    frames = [np.zeros((16, 16), np.uint8)]
    for n in (65536, 70000):
        result = run_program(source, frames, settings={"n": str(n)}, timeout=60)
        summary = result.summary()
        assert summary["icws_run"] == 1024, n
        assert summary["warnings"] == [
            f"long.cpp:9: the kernel begun here lost {2 * n - 1024} of its ICWs: the 1024-ICW "
            "stack that static kernels share is full (split it into kernels of at most 1024 "
            "ICWs)"
        ]


NEVER_RECORDED = r"""
#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    scamp5_kernel k;  // made empty, never recorded
    while (1) {
        vs_frame_loop_control();
        scamp5_launch_kernel(k);
    }
}
"""


def test_a_kernel_launched_before_it_is_recorded_is_named_at_the_launch(cxx, tmp_path):
    # the message had no place: ":0: a kernel is launched before it is recorded"
    source = tmp_path / "empty.cpp"
    source.write_text(NEVER_RECORDED)
    with pytest.raises(PpalocError) as err:
        run_program(source, [np.zeros((16, 16), np.uint8)], timeout=60)
    assert str(err.value) == (
        "empty.cpp:9: a kernel is launched before it is recorded: record it first, "
        "scamp5_kernel k([]{ ... }), or call it with a function, k([]{ ... })"
    )
