// A program for the live view's tests: a slider whose range the program narrows from
// [0, 100] to [0, 20] in its third frame, and its value posted every frame.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int level = 0, frame = 0;
    vs_handle slider = vs_gui_add_slider("level: ", 0, 100, 10, &level);
    while (1) {
        vs_frame_loop_control();
        if (frame == 2) vs_gui_set_slider_range(slider, 0, 20);
        vs_post_text("frame %d level %d", frame, level);
        ++frame;
    }
    return 0;
}
