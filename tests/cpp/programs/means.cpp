// Posts the mean grey level of each frame the sensor saw (tests/cpp/test_frame_sources.py).
// scamp5_global_sum_64 adds the 64 blocks' mean ADC values; a pixel of grey g reads 64 + g/2.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    while (1) {
        vs_frame_loop_control();
        scamp5_kernel_begin();
            get_image(A);
        scamp5_kernel_end();
        double adc = scamp5_global_sum_64(A) / 64.0;
        vs_post_text("mean %.1f", 2.0 * (adc - 64.0));
    }
}
