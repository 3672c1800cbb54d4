// A button and its callback, and the presses counted every frame (tests/cpp/test_more_api.py
// presses it with --set, tests/cpp/test_live.py from the live view).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle store = vs_gui_add_button("store");
    int presses = 0;
    vs_on_gui_update(store, [&](int32_t v) {
        ++presses;
        vs_post_text("pressed %d", v);
    });
    while (1) {
        vs_frame_loop_control();
        vs_post_text("frame %d", presses);
    }
}
