// Device API names beyond the tutorials' (docs/cpp.md "The shim"): the GUI's connect
// callbacks under their device names, the callbacks the host never triggers here, a
// slider's range, a line plot, a printed kernel, kernels begun without a ';' and the
// host-only rests and waits.
// One "mode" slider value per case (tests/cpp/test_more_api.py).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle d0 = vs_gui_add_display("image", 0, 0);
    vs_handle d1 = vs_gui_add_display("plot", 0, 1);
    int mode = 0;
    vs_gui_add_slider("mode", 0, 30, 0, &mode);
    vs_handle level = vs_gui_add_slider("level", 0, 10, 5);
    vs_on_gui_connect([&] { vs_post_text("gui connected"); });
    vs_on_gui_disconnect([&] { vs_post_text("gui disconnected"); });
    vs_on_gui_start_recording([&] { vs_post_text("recording"); });
    vs_on_gui_stop_recording([&] { vs_post_text("stopped"); });
    vs_on_user_value([&](uint8_t id, int32_t v) { vs_post_text("user %d %d", id, v); });

    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, B);
        if (mode == 0) {
            vs_gui_set_slider_range(level, -5, 20);
            vs_gui_set_lineplot(d1, 0, 100, 1);
            scamp5_kernel_begin_print();
                mov(C, A);
            scamp5_kernel_end();
            scamp5_output_image(C, d0);
            scamp5_kernel_begin()  // no ';': the device's macros end in one
                mov(D, A);
            scamp5_kernel_end();
            scamp5_dynamic_kernel_begin()
                mov(E, A);
            scamp5_dynamic_kernel_end();
            vs_wait_io_agent(vs_usb);
            vs_vision_chip_rest();
            vs_gui_save_snapshots();
            vs_scamp5_rest();
            vs_post_text("level %d", vs_gui_read_slider(level));
        } else if (mode == 1) {
            vs_gui_set_slider_range(level, 20, -5);
        } else if (mode == 2) {
            vs_gui_set_slider_range(d1, 0, 1);
        } else if (mode == 3) {
            vs_gui_set_lineplot(d1, 0, 100, 3);
        } else if (mode == 4) {
            vs_wait_io_agent(NULL);
        }
    }
    return 0;
}
