// The last names of the device folder's own headers (docs/cpp.md "The shim"): the registers'
// ICW fields, raw ICWs run with vs_scamp5_execute_icw, the macros' temporaries, the DAC, the
// exposure reset, the vector types, the error flags, host graphics and requests, and the
// calibration calls the host only records. One "mode" slider value per case
// (tests/cpp/test_device_names.py).
#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    vs_handle d0 = vs_gui_add_display("moved", 0, 0);
    vs_handle d1 = vs_gui_add_display("negated", 0, 1);
    vs_handle d2 = vs_gui_add_display("dac", 0, 2);
    int mode = 0;
    vs_gui_add_slider("mode", 0, 10, 0, &mode);
    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, F);
        if (mode == 0) {
            // the device's field values of a register, and registers compared by them
            vs_post_text("R5 %d %d %d %d", R5.RR_index, R5.RR_bits, R5.LR_index, R5.LR_bits);
            vs_post_text("A %u %u NEWS %u %u", unsigned(A.W_bits), unsigned(A.sel_bits),
                         unsigned(NEWS.W_bits), unsigned(NEWS.sel_bits));
            vs_post_text("FLAG %d %d", FLAG.RR_index, FLAG.RR_bits);
            dreg_t t = SCAMP5_MACRO_T_DREG;
            areg_t n = SCAMP5_MACRO_T_AREG;
            vs_post_text("temporaries %d %d", t.LR_bits == R0.LR_bits && t.RR_bits == R0.RR_bits,
                         n.sel_bits == NEWS.sel_bits);
            // raw ICWs: R5 := A > 0 by kernel, then MOV(R6, R5), bus(B, A), NOT(R7, R6)
            scamp5_kernel_begin();
                where(A);
                    MOV(R5, FLAG);
                all();
                CLR(R6);
            scamp5_kernel_end();
            {
                using namespace SCAMP5_ICW_BITS;
                scamp5_icw words[3];
                words[0].set_bits(SCAMP5_CLOCK_DIGITAL, {s_in, plrb, bit, bitmode});
                words[0].set_LR(R6).set_RR(R5);
                words[1] = scamp5_icw(SCAMP5_CLOCK_ANALOG, {}).set_W(B).set_sel(B).set_sel(A);
                words[2] = scamp5_icw().NOT(R7, R6);  // the class's own instruction
                vs_scamp5_execute_icw(words, 3);
            }
            scamp5_output_image(R7, d0);
            scamp5_output_image(B, d1);
            // the DAC's highest code drives IN to the top of the range
            vs_scamp5_set_dac(4095);
            scamp5_kernel_begin();
                mov(D, IN);
            scamp5_kernel_end();
            scamp5_output_image(D, d2);
            vs_vision_chip_reset_exposure();
            // vectors: a region from a centre and a size, moved past the edge and bound
            vs_vec_roi roi(100, 50, 10, 6);
            vs_post_text("roi %d %d %d %d", roi.x0, roi.y0, roi.x1, roi.y1);
            roi.move(160, 0);
            roi.bound();
            vs_post_text("bound %d %d %d %d w %d h %d c %d %d", roi.x0, roi.y0, roi.x1, roi.y1,
                         roi.get_width(), roi.get_height(), roi.get_centroid_x(),
                         roi.get_centroid_y());
            vs_vec_aabb_t box = {1, 2, 3, 4};
            uint8_t out[4];
            vs_vec_roi(box).convert_to(out);
            vs_vec_rc_t rc = {7, 9};
            vs_post_text("box %d %d %d %d rc %d %d", out[0], out[1], out[2], out[3], rc.data()[0],
                         rc.data()[1]);
            vs_post_text("errors %d", int(vs_device_error_bits->icw_stack_overflow));
            // host-only: calibrations, clocks, graphics, requests
            vs_scamp5_calibrate_dac();
            vs_scamp5_calibrate_mid(1);
            vs_scamp5_calibrate_global_sum();
            vs_scamp5_configure_clock(NULL);
            vs_gui_display_graphics(d0, [] {
                using namespace vs_gui_graphics_api;
                set_color({255, 0, 0, 255});
                draw_line(0, 0, 10, 10);
                m_scale(1.5f, 2.0f);
            });
            int busy = vs_gui_request_image("image.bmp", 1, [](vs_dotmat const& m, int s) {
                vs_post_text("image status %d size %d x %d", s, m.get_width(), m.get_height());
            });
            int again = vs_gui_request_file("data.bin", [](const uint8_t*, size_t, size_t) {});
            vs_post_text("requests %d %d done %d", busy, again, int(vs_gui_request_done()));
            do {
                vs_process_message();
            } while (!vs_gui_request_done());
        } else if (mode == 1) {
            scamp5_icw w(SCAMP5_CLOCK_AER, {});
            vs_scamp5_execute_icw(&w, 1);
        } else if (mode == 2) {
            vs_gui_graphics_api::draw_point(1, 2);
        } else if (mode == 4) {
            // two static kernels of 600 ICWs each overflow the 1024-ICW stack they share
            vs_post_text("overflow %d", int(vs_device_error_bits->icw_stack_overflow));
            scamp5_kernel_begin();
                for (int i = 0; i < 600; ++i) bus(A, B);
            scamp5_kernel_end();
            scamp5_kernel_begin();
                for (int i = 0; i < 600; ++i) bus(C, B);
            scamp5_kernel_end();
        } else if (mode == 3) {
            // a loop that writes the parts of vs_frame_loop_control itself: the trigger
            // starts each frame, and after the last the program ends
            while (1) {
                vs_process_message();
                vs_wait_frame_trigger();
                vs_loop_counter_inc();
                scamp5_get_image(A, F);
                vs_post_text("frame %d: %d", int(vs_loop_counter_get()),
                             int(scamp5_global_sum_fast(A)));
            }
        }
    }
    return 0;
}
