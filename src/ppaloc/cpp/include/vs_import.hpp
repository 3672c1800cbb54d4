// ppaloc's SCAMP-5d shim: the device library's vs_import.hpp.
//
// On the device it gathers the board's software objects (posting, dot matrices, the random
// generator, the stopwatch, the io agents); the shim serves them through <scamp5.hpp> and
// <vs_random.hpp>, so including it gives the same names.
#pragma once

#include <scamp5.hpp>
#include <vs_random.hpp>
