#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    // vs_post_message(0, 1); in a comment is fine
    while (1) {
        vs_frame_loop_control();
        vs_post_message(0, 1);
    }
}
