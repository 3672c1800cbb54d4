// vs_post_text's console commands (tests/cpp/test_console.py): "!clear" empties the host
// app's console, "!save NAME" keeps its text; four frames, each posting a few lines.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    for (int k = 0;; k++) {
        vs_frame_loop_control();
        if (k == 0) {
            vs_post_text("a%d", k);
            vs_post_text("!save first");
        } else if (k == 1) {
            vs_post_text("!clear");
            vs_post_text("b%d", k);
            vs_post_text("!clear\nc%d", k);
        } else if (k == 2) {
            vs_post_text("!save");
            vs_post_text("!save ../outside");
            vs_post_text("!saved");
        } else {
            vs_post_text("!save notes/log.txt");
        }
    }
}
