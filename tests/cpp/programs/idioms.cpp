// Usages of public device programs beyond the tutorials, one per `mode`
// (tests/cpp/test_idioms.py; mode 0 does nothing, free_running.cpp runs without triggers).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int mode = 0;
    vs_gui_add_slider("mode", 0, 3, 0, &mode);
    vs_handle shown = vs_gui_add_display("shown", 0, 0);
    static uint8_t events[5000 * 2];
    while (1) {
        vs_frame_loop_control();
        if (mode == 1) {  // more event slots than the 4000 a scan gives
            std::memset(events, 0xff, sizeof(events));
            scamp5_kernel_begin();
                SET(R5);
            scamp5_kernel_end();
            scamp5_scan_events(R5, events, 5000);
            int last = -1;
            for (int k = 0; k < 5000; k++)
                if (events[2 * k] || events[2 * k + 1]) last = k;
            vs_post_text("last %d: %d %d; then %d %d", last, events[2 * last],
                         events[2 * last + 1], events[2 * last + 2], events[9999]);
        } else if (mode == 2) {  // the board's GPIO pins, wired to nothing
            vs_gpio_as_input(VS_GPIO_X0, 1);
            vs_gpio_as_input(VS_GPIO_X1, 0);
            vs_gpio_as_output(VS_GPIO_X2);
            vs_gpio_output(VS_GPIO_X2, 1);
            vs_post_text("gpio %d %d %d %d", vs_gpio_input(VS_GPIO_X0), vs_gpio_input(VS_GPIO_X1),
                         vs_gpio_input(VS_GPIO_X2), vs_gpio_input(VS_GPIO_X4));
        } else if (mode == 3) {
            vs_gpio_output(40, 1);
        }
    }
}
