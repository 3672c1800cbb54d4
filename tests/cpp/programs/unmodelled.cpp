#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    // scamp5_output_events(R5, 1); in a comment is fine
    while (1) {
        vs_frame_loop_control();
        scamp5_output_events(R5, 1);
    }
}
