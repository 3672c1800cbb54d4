// A program for the live view's page test: a slider whose range the program narrows from
// [0, 100] to [0, 20] once it has been set to 42 (by the page, which shows it by then).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int level = 0, narrowed = 0;
    vs_handle slider = vs_gui_add_slider("level: ", 0, 100, 10, &level);
    while (1) {
        vs_frame_loop_control();
        if (level == 42 && !narrowed) {
            vs_gui_set_slider_range(slider, 0, 20);
            narrowed = 1;
        }
        vs_post_text("level %d narrowed %d", level, narrowed);
    }
    return 0;
}
