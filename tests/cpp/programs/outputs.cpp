// Display outputs and the modelled time (tests/cpp/test_outputs.py): "mode" 0 outputs a
// register's events and bounding box every frame, 1 the same program without them.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle d0 = vs_gui_add_display("events", 0, 0);
    vs_handle d1 = vs_gui_add_display("box", 0, 1);
    int mode = 0;
    vs_gui_add_slider("mode", 0, 1, 0, &mode);
    uint8_t box[4];
    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, B);
        scamp5_load_rect(R5, 2, 3, 5, 9);
        if (mode == 0) {
            scamp5_output_events(R5, d0, 16);
            scamp5_output_boundingbox(R5, d1, box);
        }
    }
}
