// Programs that go wrong, one per "fault" slider value (tests/cpp/test_errors.py).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int fault = 0, index = 0, gain = 0;
    vs_gui_add_slider("fault", 0, 9, 0, &fault);
    vs_gui_add_slider("index", 0, 100000, 0, &index); vs_gui_add_slider("gain: ", 0, 9, 0, &gain);
    vs_handle disp = vs_gui_add_display("image", 0, 0);
    while (1) {
        vs_frame_loop_control();
        scamp5_kernel_begin();
            get_image(A);
        scamp5_kernel_end();
        scamp5_output_image(A, disp);
        if (fault == 1) {
            while (1) {}  // hangs
        } else if (fault == 2) {
            volatile uint8_t buffer[16];
            buffer[index] = 1;  // out of bounds for index >= 16
            vs_post_text("%d", buffer[0]);
        } else if (fault == 3) {
            scamp5_kernel_begin();
                sub(A, B, A);
            scamp5_kernel_end();
        } else if (fault == 4) {
            using namespace scamp5_kernel_api;
            mov(A, B);  // a kernel function outside a kernel
        } else if (fault == 5) {
            scamp5_load_point(R5, 200, 3);  // beyond a 64 x 64 array
        } else if (fault == 6) {
            volatile int* p = nullptr;
            *p = 1;
        } else if (fault == 7) {
            volatile int zero = index;
            vs_post_text("%d %d", 100 / zero, 100 % zero);  // by zero for index 0
        }
    }
}
