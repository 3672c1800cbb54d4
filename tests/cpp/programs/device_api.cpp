// The device API around the chip, used as device programs use it: the host's GUI items,
// vs_random, outputs other than whole images, host graphics and data posts, and the
// host-only calls (LEDs, frame triggers, io agents, the device simulator's controls).
// One "mode" slider value per case, so tests/cpp/test_device_api.py compiles it once.
#include <scamp5.hpp>
#include <vs_random.hpp>
using namespace SCAMP5_PE;

VS_GUI_DISPLAY_STYLE(style_plot, R"JSON({"plot_palette": "plot_4"})JSON")

int main() {
    vs_sim::reset_model(0);
    vs_init();
    vs_gui_set_info(VS_M0_PROJECT_INFO_STRING);
    vs_handle d0 = vs_gui_add_display("first", 0, 0);
    vs_handle d1 = vs_gui_add_display("second", 0, 1, 1, style_plot);
    vs_handle d2 = vs_gui_add_display("third", 0, 2);
    int mode = 0;
    vs_gui_add_slider("mode", 0, 30, 0, &mode);
    int rate = -1;
    vs_on_gui_update(VS_GUI_FRAME_RATE, [&](int32_t v) { rate = v; });
    vs_on_host_connect([&] { vs_led_on(VS_LED_2); });
    vs_on_host_disconnect([&] { vs_led_off(VS_LED_2); });
    vs_on_shutdown([&] { vs_post_text("shutdown"); });

    while (1) {
        vs_frame_loop_control();
        int gain = vs_gui_read_slider(VS_GUI_FRAME_GAIN);
        scamp5_get_image(A, B, gain);

        if (mode == 0) {  // the host's GUI items
            vs_post_text("gain %d rate %d callback %d simulation %d", gain,
                         vs_gui_read_slider(VS_GUI_FRAME_RATE), rate, vs_sim::is_simulation());
            scamp5_output_image(A, d0);
        } else if (mode == 1) {  // vs_random: seeded, reproducible
            vs_random rng(7);
            uint32_t first = rng.get_uint32();
            int a = rng.get_int(0, 99);
            int b = rng(-5, 5);
            rng.reset();
            uint32_t again = rng.get_uint32();
            vs_random plain;
            unsigned plain16 = plain.get_uint16();
            int sure = plain.chance(1, 1);
            vs_post_text("%u %d %d %u %u %u %d", first, a, b, again, plain.get_seed(), plain16,
                         sure);
        } else if (mode == 2) {  // outputs of registers other than whole images
            scamp5_load_point(R5, 3, 2);
            scamp5_load_point(R6, 10, 20);
            scamp5_kernel_begin();
                OR(R7, R5, R6);
            scamp5_kernel_end();
            scamp5_output_areg(A, d0, 2, 1, 0);
            scamp5_output_events(R7, d1, 4);
            uint8_t box[4];
            scamp5_output_boundingbox(R7, d2, box);
            vs_post_text("box %d %d %d %d", box[0], box[1], box[2], box[3]);
        } else if (mode == 3) {  // the program's own data drawn on displays
            const uint8_t image[8] = {0, 50, 100, 150, 200, 250, 255, 5};
            scamp5_display_image(d0, image, 4, 2);
            scamp5_output_image(A, d1);
            scamp5_display_image_patch(d1, image, 2, 2, 5, 6);
            const uint8_t events[6] = {1, 2, 63, 0, 0, 0};
            scamp5_display_events(d2, events, 3);
        } else if (mode == 4) {  // boxes, an RGB host image, text and graphics
            const uint8_t boxes[8] = {1, 60, 3, 62, 10, 10, 10, 10};
            scamp5_display_boundingbox(d0, boxes, 2);
            const uint8_t rgb[6] = {30, 60, 90, 255, 255, 255};
            vs_gui_imageformat_t format = {0};
            format.pixel_bytes = 3;
            format.is_bottom_to_top = 1;
            vs_gui_display_image(d1, rgb, 1, 2, format);
            vs_gui_display_graphics(d2, [&] { vs_gui_display_text(d2, 4, 5, "hello"); });
        } else if (mode == 5) {  // host-only calls, accepted and recorded
            vs_configure_frame_trigger(VS_FRAME_TRIGGER_CONST_PIX, 60);
            vs_frame_trigger_set(1, 30);
            vs_disable_frame_trigger();
            vs_enable_frame_trigger();
            vs_led_toggle(VS_LED_1);
            vs_scamp5_configure_voltage(3, 1200);
            vs_post_bind_io_agent(vs_usb);
            scamp5_bind_io_agent(vs_spi);
            vs_gui_set_scope(d0, 0, 100, 64);
            vs_gui_set_barplot(d1, -10, 10, 4);
            vs_gui_save_image(d0, "saved/first.bmp");
            vs_sim::config("server_port", "27715");
            vs_sim::save_image(A, "a.bmp");
            scamp5_kernel::print_debug_info();
            scamp5_kernel_begin();
                allow_highspeed(true);
                mov(C, A);
            scamp5_kernel_end();
        } else if (mode == 6) {  // data posted to the host
            const int16_t h16[3] = {-1, 2, 300};
            const int32_t h32[4] = {1, -2, 3, 70000};
            const int8_t h8[2] = {-128, 127};
            const float hf[1] = {0.5f};
            vs_post_set_channel(d1);
            vs_post_int16(h16, 1, 3);
            vs_post_int32(h32, 2, 2);
            vs_post_set_channel(9);
            vs_post_int8(h8, 2, 1);
            vs_post_float(hf, 1, 1);
        } else if (mode == 7) {  // a scanned region displayed whole and pasted back
            static uint8_t whole[64 * 64], part[5 * 3];
            scamp5_scan_areg(A, whole, 0, 0, 63, 63, 1, 1);
            scamp5_display_image(d0, whole, 64, 64);
            scamp5_scan_areg(A, part, 10, 20, 12, 24, 1, 1);  // 3 rows x 5 hardware columns
            scamp5_display_image_patch(d1, part, 5, 3, 10, 20);
            scamp5_output_image(A, d2);
            scamp5_display_image_patch(d2, part, 5, 3, 10, 20);  // over itself: unchanged
        } else if (mode == 8) {  // the bounding box of a 1 at the top-right element alone
            uint8_t box[4] = {9, 9, 9, 9}, none[4] = {9, 9, 9, 9};
            scamp5_load_point(R5, 0, 0);
            scamp5_output_boundingbox(R5, d0, box);
            scamp5_kernel_begin();
                CLR(R6);
            scamp5_kernel_end();
            scamp5_output_boundingbox(R6, d1, none);  // an empty register: nothing drawn
            vs_post_text("box %d %d %d %d none %d %d %d %d", box[0], box[1], box[2], box[3],
                         none[0], none[1], none[2], none[3]);
        } else if (mode == 9) {  // a polled delay, on the modelled clock
            vs_stopwatch watch;
            vs_wait(2500);
            vs_wait(0);
            vs_post_text("waited %u", watch.get_usec());
        } else if (mode == 22) {  // the bound io agents, read back
            vs_io_agent_api* scamp5_first = scamp5_get_io_agent();
            vs_io_agent_api* post_first = vs_post_get_io_agent();
            scamp5_bind_io_agent(vs_spi);
            vs_post_bind_io_agent(vs_uart);
            int bound = scamp5_get_io_agent() == vs_spi && vs_post_get_io_agent() == vs_uart;
            scamp5_bind_io_agent(scamp5_first);  // put back as it was
            vs_post_text("agents %d %d %d %d", scamp5_first == vs_usb, post_first == vs_usb,
                         bound, scamp5_get_io_agent() == vs_usb);
        } else if (mode == 26) {  // patches over the display's previous image
            static int frame = 0;
            const uint8_t image[4] = {10, 20, 30, 40};
            if (frame++ == 0) {
                scamp5_load_point(R5, 3, 2);
                scamp5_output_image(R5, d0);  // a digital register's image
                scamp5_display_image_patch(d0, image, 2, 2, 10, 10);
                scamp5_output_image(A, d1);
            } else {  // over the image an earlier frame left
                scamp5_display_image_patch(d1, image, 2, 2, 20, 20);
            }
        } else if (mode == 23) {  // the host's sliders of vs_on_gui_update's table
            int blend = -1;
            vs_on_gui_update(VS_GUI_IMAGE_BLEND, [&](int32_t v) { blend = v; });
            vs_on_gui_update(VS_GUI_VECTOR_LENGTH, [&](int32_t v) { blend = v; });
            vs_process_message();
            vs_post_text("blend %d handles %d %d %d", blend, VS_GUI_VECTOR_LENGTH,
                         VS_GUI_IMAGE_LENGTH, VS_GUI_IMAGE_BLEND);
        }
        // misuse, one line each
        else if (mode == 10) {
            vs_gui_read_slider(77);
        } else if (mode == 11) {
            vs_led_on(7);
        } else if (mode == 12) {
            vs_configure_frame_trigger(9, 60);
        } else if (mode == 14) {
            scamp5_output_areg(A, d0, 2, 3, 0);
        } else if (mode == 15) {
            vs_gui_set_scope(55, 0, 10, 8);
        } else if (mode == 16) {
            const uint8_t image[4] = {1, 2, 3, 4};
            scamp5_display_image_patch(d0, image, 2, 2, 63, 0);
        } else if (mode == 25) {  // off the west edge: hardware columns 63 and 64
            const uint8_t image[4] = {1, 2, 3, 4};
            scamp5_display_image_patch(d0, image, 2, 2, 0, 63);
        } else if (mode == 17) {
            vs_post_bind_io_agent(NULL);
        } else if (mode == 18) {
            scamp5_kernel_api::allow_highspeed(true);  // outside a kernel
        } else if (mode == 19) {
            vs_frame_trigger_set(1, 0);
        } else if (mode == 20) {
            const int16_t values[4] = {1, 2, 3, 4};
            int rows = -1;  // a size_t of 2^64 - 1
            vs_post_int16(values, rows, 4);
        } else if (mode == 24) {
            vs_gui_read_slider(VS_GUI_IMAGE_LENGTH);
        } else if (mode == 21) {
            const uint8_t events[2] = {1, 2};
            scamp5_display_events(d0, events, size_t(-1));
        }
    }
}
