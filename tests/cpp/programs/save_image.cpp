// vs_sim::save_image (tests/cpp/test_save_image.py), one "mode" slider value per case:
// 0 saves A (the frame, as get_image's yf holds it) and R5 (one point) every frame;
// 1 saves nothing (the same program's time without the saves); 2-5 give bad paths.
#include <cstdio>

#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int mode = 0;
    vs_gui_add_slider("mode", 0, 5, 0, &mode);
    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, B);
        scamp5_load_point(R5, 3, 4);
        if (mode == 0) {
            vs_sim::save_image(A, "grey.bmp");
            char name[32];
            std::snprintf(name, sizeof name, "points\\r5_%d.bmp", int(vs_loop_counter_get()));
            vs_sim::save_image(R5, name);
        }
        if (mode == 2) vs_sim::save_image(A, "/tmp/grey.bmp");
        if (mode == 3) vs_sim::save_image(A, "../grey.bmp");
        if (mode == 4) vs_sim::save_image(A, "C:\\images\\grey.bmp");
        if (mode == 5) {
            vs_sim::save_image(A, "grey");
            vs_sim::save_image(A, "grey/a.bmp");
        }
    }
}
