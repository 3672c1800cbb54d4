// A loop that runs free on the device, as the public AnalogNet demos' do: no frame trigger
// anywhere in the program, the loop counter counts (tests/cpp/test_idioms.py).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle shown = vs_gui_add_display("shown", 0, 0);
    while (1) {
        vs_process_message();
        scamp5_get_image(A, B);
        scamp5_output_image(A, shown);
        vs_post_text("pass %d", int(VS_LC));
        vs_loop_counter_inc();
    }
}
