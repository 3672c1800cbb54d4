// ppaloc's SCAMP-5d shim: vs_random, the device library's integer random generator.
//
// Marsaglia's multiply-with-carry generator on two 16-bit lags, started from the device's
// constants offset by the seed, so a seed gives the device's sequence and the same seed
// always the same numbers (the default seed is 0). Integer arithmetic only, as on the M0.
#pragma once

#include <cstdint>

class vs_random {
    static constexpr uint32_t W0 = 521288629u, Z0 = 362436069u;
    uint32_t seed_ = 0, w_ = W0, z_ = Z0;

    void step() {
        z_ = 36969u * (z_ & 0xFFFFu) + (z_ >> 16);
        w_ = 18000u * (w_ & 0xFFFFu) + (w_ >> 16);
    }

   public:
    vs_random() = default;
    explicit vs_random(uint32_t seed) { reseed(seed); }
    // Start the sequence again from the current seed.
    void reset() {
        w_ = W0 + seed_;
        z_ = Z0 - seed_;
    }
    // A new seed, and its sequence from the start.
    void reseed(uint32_t seed) {
        seed_ = seed;
        reset();
    }
    uint32_t get_seed() const { return seed_; }
    uint32_t get_uint32() {
        step();
        return (z_ << 16) + (w_ & 0xFFFFu);
    }
    uint16_t get_uint16() {
        step();
        return uint16_t((z_ << 8) + (w_ & 0xFFu));
    }
    // An int in [r_min, r_max], both included.
    int get_int(int r_min, int r_max) {
        uint32_t span = uint32_t(r_max - r_min + 1);
        return int(uint32_t(get_uint16()) * span / 65536u) + r_min;
    }
    // True with probability num/den.
    bool chance(uint16_t num, uint16_t den) {
        return uint32_t(den) * get_uint16() < uint32_t(num) * 65536u;
    }
    int operator()(int r_min, int r_max) { return get_int(r_min, r_max); }
};
