// Usages of public device programs beyond the tutorials, one per `mode`
// (tests/cpp/test_idioms.py).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int mode = 0;
    vs_gui_add_slider("mode", 0, 3, 0, &mode);
    vs_handle shown = vs_gui_add_display("shown", 0, 0);
    if (mode == 0) {
        // a loop that runs free on the device: no frame trigger, the loop counter counts
        while (1) {
            vs_process_message();
            scamp5_get_image(A, B);
            scamp5_output_image(A, shown);
            vs_post_text("pass %d", int(VS_LC));
            vs_loop_counter_inc();
        }
    }
    while (1) {
        vs_frame_loop_control();
    }
}
