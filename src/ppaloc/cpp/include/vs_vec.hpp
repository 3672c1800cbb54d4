// ppaloc's SCAMP-5d shim: the device library's small vector types (vs_vec.hpp).
//
// Pairs of coordinates or offsets, a bounding box as the readouts give it (row and column
// of two corners) and a region of interest in x (column) and y (row) with the operations
// a tracker uses: from a box or a centre and size, clamped or shifted into the 256 x 256
// array, moved, resized about its centre.
#pragma once

#include <algorithm>
#include <cstdint>

struct vs_vec_int8_t {
    int8_t x;
    int8_t y;
    int8_t* data() { return &x; }
};

struct vs_vec_int16_t {
    int16_t x;
    int16_t y;
    int16_t* data() { return &x; }
};

struct vs_vec_int32_t {
    int32_t x;
    int32_t y;
    int32_t* data() { return &x; }
};

struct vs_vec_xy_t {
    uint8_t x;
    uint8_t y;
    uint8_t* data() { return &x; }
};

struct vs_vec_rc_t {
    uint8_t row;
    uint8_t col;
    uint8_t* data() { return &row; }
};

// A box: row and column of its first corner, then of its second.
struct vs_vec_aabb_t {
    uint8_t row0;
    uint8_t col0;
    uint8_t row1;
    uint8_t col1;
    uint8_t* data() { return &row0; }
};

// A region of interest, corners (x0, y0) and (x1, y1) included; data[] is y0, x0, y1, x1.
class vs_vec_roi {
   public:
    union {
        struct {
            int16_t y0;
            int16_t x0;
            int16_t y1;
            int16_t x1;
        };
        int16_t data[4];
    };

    vs_vec_roi() : y0(0), x0(0), y1(0), x1(0) {}
    vs_vec_roi(const uint8_t* rect4v) { convert_from(rect4v); }
    vs_vec_roi(const vs_vec_aabb_t& box) { convert_from(box); }
    // A centre and a size: an even size puts the extra element before the centre.
    vs_vec_roi(int16_t centroid_x, int16_t centroid_y, int16_t width, int16_t height) {
        place(centroid_x, centroid_y, width, height);
    }

    // From 4 bytes as scamp5_scan_boundingbox writes them: row, column, row, column.
    void convert_from(const uint8_t* rect4v) {
        y0 = rect4v[0];
        x0 = rect4v[1];
        y1 = rect4v[2];
        x1 = rect4v[3];
    }
    void convert_from(const vs_vec_aabb_t& box) {
        y0 = box.row0;
        x0 = box.col0;
        y1 = box.row1;
        x1 = box.col1;
    }
    void convert_to(uint8_t* rect4v) const {
        rect4v[0] = uint8_t(y0);
        rect4v[1] = uint8_t(x0);
        rect4v[2] = uint8_t(y1);
        rect4v[3] = uint8_t(x1);
    }
    // Each coordinate limited to 0-255 (the box may shrink).
    void clamp() {
        for (int16_t& v : data) v = std::min<int16_t>(255, std::max<int16_t>(0, v));
    }
    // The box shifted into 0-255, its size kept.
    void bound() {
        if (x0 < 0) {
            x1 = int16_t(x1 - x0);
            x0 = 0;
        }
        if (y0 < 0) {
            y1 = int16_t(y1 - y0);
            y0 = 0;
        }
        if (x1 > 255) {
            x0 = int16_t(x0 - (x1 - 255));
            x1 = 255;
        }
        if (y1 > 255) {
            y0 = int16_t(y0 - (y1 - 255));
            y1 = 255;
        }
    }
    void move(int16_t dx, int16_t dy) {
        x0 = int16_t(x0 + dx);
        x1 = int16_t(x1 + dx);
        y0 = int16_t(y0 + dy);
        y1 = int16_t(y1 + dy);
    }
    int get_width() const { return x1 - x0 + 1; }
    int get_height() const { return y1 - y0 + 1; }
    int get_centroid_x() const { return (x0 + x1 + 1) / 2; }
    int get_centroid_y() const { return (y0 + y1 + 1) / 2; }
    void resize(int16_t width, int16_t height) {
        place(int16_t(get_centroid_x()), int16_t(get_centroid_y()), width, height);
    }

   private:
    void place(int16_t cx, int16_t cy, int16_t width, int16_t height) {
        x0 = int16_t(cx - width / 2);
        x1 = int16_t(cx + (width + 1) / 2 - 1);
        y0 = int16_t(cy - height / 2);
        y1 = int16_t(cy + (height + 1) / 2 - 1);
    }
};
