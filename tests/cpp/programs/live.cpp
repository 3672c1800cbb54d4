// A program for the live view's tests: two displays, a slider read three ways (its value,
// its writeback variable, its callback), a switch, and text posted every frame.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle image = vs_gui_add_display("image", 0, 0);
    vs_handle mask = vs_gui_add_display("mask", 0, 1);
    int level_wb = 0, calls = 0, last = 0;
    vs_handle level = vs_gui_add_slider("level: ", 0, 100, 10, &level_wb);
    vs_handle invert = vs_gui_add_switch("invert", false);
    vs_on_gui_update(level, [&](int32_t v) { ++calls; last = v; });

    while (1) {
        vs_frame_loop_control();
        int v = vs_gui_read_slider(level);
        scamp5_kernel_begin();
            get_image(A);
        scamp5_kernel_end();
        scamp5_in(C, v - 64);
        scamp5_kernel_begin();
            sub(D, A, C);
            where(D);
                MOV(R5, FLAG);
            all();
        scamp5_kernel_end();
        if (vs_gui_read_switch(invert)) {
            scamp5_kernel_begin();
                NOT(R6, R5);
            scamp5_kernel_end();
            scamp5_output_image(R6, mask);
        } else {
            scamp5_output_image(R5, mask);
        }
        scamp5_output_image(A, image);
        vs_post_text("level %d writeback %d callback %d (%d calls) invert %d", v, level_wb, last,
                     calls, vs_gui_read_switch(invert));
    }
    return 0;
}
