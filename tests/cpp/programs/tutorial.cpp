// Small SCAMP-5d programs in the style of the device tutorials, one per "mode" slider
// value, so one compiled executable serves every test of tests/cpp/test_programs.py.
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle out_a = vs_gui_add_display("analog", 0, 0);
    vs_handle out_d = vs_gui_add_display("digital", 0, 1);
    vs_handle out_b = vs_gui_add_display("bits", 0, 2);
    int mode = 0, threshold = 20;
    vs_gui_add_slider("mode", 0, 19, 0, &mode);
    vs_gui_add_slider("threshold", -128, 127, 20, &threshold);
    vs_handle use_or = vs_gui_add_switch("dilate", true);

    while (1) {
        vs_frame_loop_control();

        // every frame: capture, A = the half-range image (p/2 - 64)
        scamp5_kernel_begin();
            get_image(A);
        scamp5_kernel_end();

        if (mode == 0 || mode == 2 || mode == 4) {  // threshold (slider), dilation, events
            scamp5_in(C, threshold);
            scamp5_kernel_begin();
                sub(D, A, C);
                where(D);
                    MOV(R5, FLAG);
                all();
            scamp5_kernel_end();
            if (mode == 2 && vs_gui_read_switch(use_or)) {
                scamp5_kernel_begin();
                    DNEWS(R6, R5, 15);  // an int, as the device's DNEWS takes: alldir
                    OR(R7, R5, R6);
                scamp5_kernel_end();
                scamp5_output_image(R7, out_d);
            } else {
                scamp5_output_image(R5, out_d);
            }
            if (mode == 4) {
                uint8_t events[2 * 16];
                scamp5_scan_events(R5, events, 16);
                for (int i = 0; i < 16; ++i) {
                    if (events[2 * i] == 0 && events[2 * i + 1] == 0) break;
                    vs_post_text("event %d %d", events[2 * i], events[2 * i + 1]);
                }
            }
        } else if (mode == 1) {  // horizontal edges with a neighbour move
            scamp5_kernel_begin();
                movx(C, A, east);
                sub(E, A, C);
                abs(D, E);
            scamp5_kernel_end();
            scamp5_output_image(D, out_a);
        } else if (mode == 3) {  // load_pattern grid
            scamp5_load_pattern(R5, 0, 0, 0x07 ^ 0xFF, 0xFF);
            scamp5_load_pattern(R6, 0, 0, 0xFF, 0x07 ^ 0xFF);
            scamp5_kernel_begin();
                OR(R7, R5, R6);
            scamp5_kernel_end();
            scamp5_output_image(R7, out_d);
        } else if (mode == 5) {  // global sums and readouts
            uint8_t grid[16];
            uint32_t s16 = scamp5_global_sum_16(A, grid);
            uint32_t s64 = scamp5_global_sum_64(A);
            scamp5_in(C, threshold);
            scamp5_kernel_begin();
                sub(D, A, C);
                where(D);
                    MOV(R5, FLAG);
                all();
            scamp5_kernel_end();
            int count = scamp5_global_count(R5, F);
            int any = scamp5_global_or(R5);
            uint8_t px = scamp5_read_areg(A, 3, 5);
            vs_post_text("sums %u %u %d %d %d %d", s16, s64, count, any, px, grid[0]);
        } else if (mode == 6) {  // control flow on readouts: the largest t with A > t
            int lo = -128, hi = 127;
            while (lo < hi) {
                int mid = (lo + hi + 1) / 2;
                scamp5_in(C, mid);
                scamp5_kernel_begin();
                    sub(D, A, C);
                    where(D);
                        MOV(R5, FLAG);
                    all();
                scamp5_kernel_end();
                if (scamp5_global_or(R5)) lo = mid; else hi = mid - 1;
            }
            vs_post_text("max %d", lo);
        } else if (mode == 7) {  // bit-stack output and a digital scan
            scamp5_load_pattern(R5, 0, 0, 0xFE, 0xFF);  // even rows
            scamp5_load_pattern(R6, 0, 0, 0xFF, 0xFE);  // even hardware columns
            scamp5_output_bitstack_begin(out_b, 2);
            scamp5_output_bitstack_bit(R5);
            scamp5_output_bitstack_bit(R6);
            scamp5_output_bitstack_end();
            uint8_t rows[2 * 32];
            scamp5_scan_dreg(R6, rows, 0, 1);
            vs_post_text("dreg %d %d", rows[0], rows[32]);
        } else if (mode == 8) {  // drawing, flood, bounding box, the fast sum
            scamp5_draw_begin(R5);
            scamp5_draw_rect(2, 3, 10, 20);
            scamp5_draw_line(0, 0, 5, 5);
            scamp5_draw_end();
            scamp5_output_image(R5, out_d);
            uint8_t box[4];
            scamp5_scan_boundingbox(R5, box);
            vs_post_text("box %d %d %d %d", box[0], box[1], box[2], box[3]);
            scamp5_load_point(R6, 40, 40);
            scamp5_load_rect(R7, 30, 30, 50, 50);
            scamp5_load_point(R8, 5, 5);
            scamp5_kernel_begin();
                OR(R7, R8);  // a second island the flood must not reach
            scamp5_kernel_end();
            scamp5_flood(R6, R7, 0);
            scamp5_output_image(R6, out_b);
            vs_post_text("fast %d", scamp5_global_sum_fast(A));
        } else if (mode == 9) {  // the several-destination bus: one ICW, the current split
            scamp5_kernel_begin();
                bus({C, D}, {A});
                add(E, C, D);
            scamp5_kernel_end();
            scamp5_output_image(C, out_a);
            scamp5_output_image(E, out_b);
        } else if (mode == 10) {  // a raw ICW word: bus(A, B) written as its bits
            scamp5_kernel_begin();
                mov(B, A);
                icw(SCAMP5_CLOCK_ANALOG, {W1, SEL1, SEL2});
            scamp5_kernel_end();
            scamp5_output_image(A, out_a);
        } else if (mode == 11) {  // dynamic kernels: each leaves the ICW stack after use
            for (int i = 0; i < 12; ++i) {
                scamp5_dynamic_kernel_begin();
                    newsblur(C, A, 50 + i);
                scamp5_dynamic_kernel_end();
            }
            scamp5_output_image(C, out_a);
        } else if (mode == 12) {  // kernel objects stay on the stack: 1300 ICWs overflow it
            static scamp5_kernel* kernels[12];
            for (int i = 0; i < 12; ++i) {
                if (!kernels[i]) {
                    using namespace scamp5_kernel_api;
                    kernels[i] = new scamp5_kernel([=] { newsblur(C, A, 50 + i); });
                }
                scamp5_launch_kernel(*kernels[i]);
            }
        }
        vs_post_text("frame %u done", vs_loop_counter_get());
    }
    return 0;
}
