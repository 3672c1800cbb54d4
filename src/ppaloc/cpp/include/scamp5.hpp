// ppaloc's SCAMP-5d shim: the documented names and types of the SCAMP-5d device API,
// served by ppaloc's Python simulator over a pipe (`ppaloc cpp run PROGRAM.cpp`).
//
// Kernel functions (mov, add, where, DNEWS, ...) are generated from the simulator's own
// list (ppaloc_gen_macros.hpp) and forwarded by name: the simulator expands, checks and
// runs them. A static kernel (scamp5_kernel_begin/end) is recorded once and replayed by
// id. Controller calls that return nothing stream; readouts wait for their answer.
// Positions are the chip's hardware addresses (column 0 at the east edge), as on the
// device. docs/cpp.md describes what is modelled.
#pragma once

#include <unistd.h>
#if defined(__x86_64__) && defined(__linux__)
#include <asm/prctl.h>
#include <sys/syscall.h>
#include <ucontext.h>

#include <csignal>
#endif

#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <array>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

// ------------------------------------------------------------------ register types
// Each register carries the device's fields (its ICW encoding: the write and select bits
// of an analogue register, the word and bits of a digital one's read and write), with the
// device's values, then the simulator's register code.
struct aref_t {
    uint32_t W_bits;
    uint32_t sel_bits;
    uint8_t code;
};
struct areg_t {
    uint32_t W_bits;
    uint32_t sel_bits;
    uint8_t code;
    constexpr operator aref_t() const { return aref_t{W_bits, sel_bits, code}; }
};
struct dref_t {
    uint16_t RR_index;
    uint16_t RR_bits;
    uint16_t LR_index;
    uint16_t LR_bits;
    uint8_t code;
};
struct dreg_t {
    uint16_t RR_index;
    uint16_t RR_bits;
    uint16_t LR_index;
    uint16_t LR_bits;
    uint8_t code;
    constexpr operator dref_t() const { return dref_t{RR_index, RR_bits, LR_index, LR_bits, code}; }
};
enum news_t { east = 1, west = 2, north = 4, south = 8, alldir = 15 };
constexpr news_t operator|(news_t a, news_t b) { return news_t(int(a) | int(b)); }

#define AREG areg_t const&
#define ASRC aref_t const&
#define DREG dreg_t const&
#define DSRC dref_t const&

typedef int vs_handle;

#include "ppaloc_gen_consts.hpp"
#include "vs_random.hpp"
#include "vs_vec.hpp"

// The registers the library's macros use as their temporaries (the simulator's too).
#define SCAMP5_MACRO_T_AREG SCAMP5_PE::NEWS
#define SCAMP5_MACRO_T_DREG SCAMP5_PE::R0

// ------------------------------------------------------------------ the client
namespace ppa {

// Where a call was written: as a default argument, here() takes the caller's file and line.
struct Loc {
    const char* file;
    unsigned line;
    static constexpr Loc here(const char* f = __builtin_FILE(), unsigned l = __builtin_LINE()) {
        return Loc{f, l};
    }
};
#define PPA_HERE ppa::Loc::here()

// One argument of a kernel or controller call, tagged with its kind.
struct Arg {
    uint8_t tag;
    int32_t value;
    const char* text = nullptr;
    constexpr Arg(const areg_t& r) : tag(TAG_AREG), value(r.code) {}
    constexpr Arg(const aref_t& r) : tag(TAG_AREG), value(r.code) {}
    constexpr Arg(const dreg_t& r) : tag(TAG_DREG), value(r.code) {}
    constexpr Arg(const dref_t& r) : tag(TAG_DREG), value(r.code) {}
    constexpr Arg(news_t d) : tag(TAG_DIR), value(int(d)) {}
    constexpr Arg(int v) : tag(TAG_INT), value(v) {}
    Arg(const char* s) : tag(TAG_STR), value(int32_t(s ? std::strlen(s) : 0)), text(s) {}
    // A block of n bytes (posted data, a byte image): sent as they are.
    Arg(const void* p, size_t n)
        : tag(TAG_BYTES), value(int32_t(p ? n : 0)), text(static_cast<const char*>(p)) {}
};

[[noreturn]] inline void fail(const Loc& loc, const std::string& msg) {
    std::fflush(stdout);
    const char* name = std::strrchr(loc.file, '/');  // the file's name, as messages give it
    std::fprintf(stderr, "ppaloc-shim: %s:%u: %s\n", name ? name + 1 : loc.file, loc.line,
                 msg.c_str());
    std::_Exit(SHIM_EXIT);
}

// True once the program's end has been sent: objects destroyed after it free nothing.
inline bool& run_over() {
    static bool over = false;
    return over;
}
class Client {
   public:
    std::vector<uint8_t> buf;
    int out_fd = -1, in_fd = -1;
    bool connected = false;
    int rows = 256, cols = 256;

    void connect() {
        if (connected) return;
        const char* o = std::getenv("PPALOC_FD_OUT");
        const char* i = std::getenv("PPALOC_FD_IN");
        if (!o || !i) {
            std::fprintf(stderr,
                         "ppaloc-shim: this program is built on ppaloc's SCAMP-5d shim; "
                         "run it with `ppaloc cpp run PROGRAM.cpp`\n");
            std::_Exit(SHIM_EXIT);
        }
        out_fd = std::atoi(o);
        in_fd = std::atoi(i);
        connected = true;
        buf.reserve(1 << 16);
        std::atexit([] { Client::get().finish(); });
        size_t at = begin(OP_HELLO);
        u32(PROTOCOL_VERSION);
        end(at);
        std::vector<uint8_t> r = reply();
        rows = r[0] | (r[1] << 8);
        cols = r[2] | (r[3] << 8);
    }

    static Client& get() {
        static Client c;
        return c;
    }

    void u8(uint8_t v) { buf.push_back(v); }
    void u16(uint16_t v) {
        u8(v & 0xFF);
        u8(v >> 8);
    }
    void u32(uint32_t v) {
        for (int k = 0; k < 4; ++k) u8((v >> (8 * k)) & 0xFF);
    }
    void bytes(const void* p, size_t n) {
        const uint8_t* b = static_cast<const uint8_t*>(p);
        buf.insert(buf.end(), b, b + n);
    }
    void name(const char* s) {
        size_t n = std::strlen(s);
        u8(uint8_t(n));
        bytes(s, n);
    }
    void arg(const Arg& a) {
        u8(a.tag);
        u32(uint32_t(a.value));
        if ((a.tag == TAG_STR || a.tag == TAG_BYTES) && a.value) bytes(a.text, size_t(a.value));
    }

    // Start a message; returns where its length goes.
    size_t begin(uint8_t op) {
        connect();
        u8(op);
        size_t at = buf.size();
        u32(0);
        return at;
    }
    void end(size_t at) {
        uint32_t n = uint32_t(buf.size() - at - 4);
        for (int k = 0; k < 4; ++k) buf[at + k] = (n >> (8 * k)) & 0xFF;
        if (buf.size() >= (1 << 16)) flush();
    }

    void write_all(const uint8_t* p, size_t n) {
        while (n) {
            ssize_t w = ::write(out_fd, p, n);
            if (w <= 0) std::_Exit(SERVER_EXIT);  // the simulator has gone
            p += w;
            n -= size_t(w);
        }
    }
    void read_all(uint8_t* p, size_t n) {
        while (n) {
            ssize_t r = ::read(in_fd, p, n);
            if (r <= 0) std::_Exit(SERVER_EXIT);
            p += r;
            n -= size_t(r);
        }
    }
    void flush() {
        if (!buf.empty()) write_all(buf.data(), buf.size());
        buf.clear();
    }

    // Send what is buffered and wait for the answer to the last message.
    std::vector<uint8_t> reply() {
        flush();
        uint8_t head[8];
        read_all(head, 8);
        uint32_t status = head[0] | (head[1] << 8) | (head[2] << 16) | (uint32_t(head[3]) << 24);
        uint32_t n = head[4] | (head[5] << 8) | (head[6] << 16) | (uint32_t(head[7]) << 24);
        std::vector<uint8_t> out(n);
        if (n) read_all(out.data(), n);
        if (status) std::_Exit(SERVER_EXIT);
        return out;
    }

    void finish() {
        if (!connected) return;
        run_over() = true;
        size_t at = begin(OP_EXIT);
        end(at);
        flush();
    }
};

// A location as the wire carries it: the file's id (named once by a FILE message) in the
// top bits, the line in the low LINE_BITS, so the simulator's messages name the file where
// the call was written (a second source, an included header), not the program's.
// Call it before a message is begun: it may send the FILE message itself.
inline uint32_t wire(const char* file, unsigned line) {
    static std::map<const char*, uint32_t> by_pointer;  // __builtin_FILE's strings
    static std::map<std::string, uint32_t> by_name;
    auto hit = by_pointer.find(file);
    uint32_t id;
    if (hit != by_pointer.end()) {
        id = hit->second;
    } else {
        const char* slash = std::strrchr(file, '/');
        std::string name(slash ? slash + 1 : file);
        if (name.size() > 255) name.resize(255);
        auto known = by_name.find(name);
        if (known != by_name.end()) {
            id = known->second;
        } else {
            id = uint32_t(by_name.size());
            by_name[name] = id;
            Client& c = Client::get();
            size_t at = c.begin(OP_FILE);
            c.u32(id);
            c.name(name.c_str());
            c.end(at);
        }
        by_pointer[file] = id;
    }
    return (id << LINE_BITS) | (line & ((1u << LINE_BITS) - 1));
}
inline uint32_t wire(const Loc& loc) { return wire(loc.file, loc.line); }

// True while a static kernel's body runs again only to be compared with its recording
// (scamp5_kernel::begin_static): calls that answer nothing are not sent then, as the
// device, which replays the recording, does not run the body again.
inline bool& comparing() {
    static bool on = false;
    return on;
}

// Whether later passes run a static kernel's body again to compare it (the run's
// --no-kernel-check sets PPALOC_KERNEL_CHECK=0: each body then runs once, as on the device,
// its other C++ statements with it).
inline bool kernel_check() {
    static const bool on = [] {
        const char* v = std::getenv("PPALOC_KERNEL_CHECK");
        return !(v && v[0] == '0' && v[1] == '\0');
    }();
    return on;
}

// A controller call by name; with `want`, its answer.
inline std::vector<uint8_t> call_at(const char* fn, bool want, std::initializer_list<Arg> args,
                                    uint32_t where) {
    Client& c = Client::get();
    size_t at = c.begin(OP_CALL);
    c.u8(want ? 1 : 0);
    c.name(fn);
    c.u32(where);
    c.u8(uint8_t(args.size()));
    for (const Arg& a : args) c.arg(a);
    c.end(at);
    if (!want) return {};
    return c.reply();
}
inline std::vector<uint8_t> call(const char* fn, bool want, std::initializer_list<Arg> args,
                                 const Loc& loc) {
    if (!want && comparing()) return {};
    return call_at(fn, want, args, wire(loc));
}

inline int32_t as_int(const std::vector<uint8_t>& r) {
    uint32_t v = 0;
    for (size_t k = 0; k < 4 && k < r.size(); ++k) v |= uint32_t(r[k]) << (8 * k);
    return int32_t(v);
}

}  // namespace ppa

// An integer division by zero. The device's Cortex-M0 has no divide instruction: its
// run-time library's division helper returns 0 for a zero divisor, and the program goes on.
// An x86-64 host traps instead (SIGFPE); the trap is caught here and the division given the
// device's result: quotient 0 (the remainder is the dividend, so a == q * b + r still holds),
// and the program goes on. Each one is reported with its file and line (a warning of the run).
// x86-64 also traps when the quotient does not fit, which C code meets only as INT_MIN / -1
// (LLONG_MIN / -1, ...): the device's software division wraps there, giving INT_MIN and a
// remainder 0, so the handler reads the divisor and, when it is not 0, gives the wrapped
// quotient (its low bits) and the exact remainder, with no report (as for INT_MAX + 1).
// Other hosts (aarch64) give these results without a trap, as the device does.
#if defined(__x86_64__) && defined(__linux__)
extern "C" void __sanitizer_symbolize_pc(void* pc, const char* fmt, char* out, size_t n)
    __attribute__((weak));
namespace ppa {
// General register number r (0 RAX ... 7 RDI, 8 R8 ... 15 R15, as ModRM/SIB/REX number them).
inline greg_t& general_register(greg_t* g, unsigned r) {
    static const int order[16] = {REG_RAX, REG_RCX, REG_RDX, REG_RBX, REG_RSP, REG_RBP,
                                  REG_RSI, REG_RDI, REG_R8,  REG_R9,  REG_R10, REG_R11,
                                  REG_R12, REG_R13, REG_R14, REG_R15};
    return g[order[r & 15]];
}
// A DIV/IDIV instruction: its length (0 if another instruction), its operand size in bytes
// (1 F6; 8 REX.W; 2 the 0x66 prefix; else 4), whether it is IDIV, and its divisor (the
// register or the memory operand, read as the CPU read it, zero-extended).
struct Division {
    size_t length = 0;
    unsigned bytes = 0;
    bool is_signed = false;
    uint64_t divisor = 0;
};
inline int32_t displacement32(const uint8_t* p) {
    int32_t v;
    std::memcpy(&v, p, 4);
    return v;
}
inline Division decode_division(const uint8_t* p, greg_t* g) {
    Division d;
    size_t n = 0;
    bool operand16 = false, address32 = false;
    uint8_t segment = 0;
    for (;; ++n) {
        const uint8_t b = p[n];
        if (b == 0x66) {
            operand16 = true;
        } else if (b == 0x67) {
            address32 = true;
        } else if (b == 0x64 || b == 0x65) {  // FS, GS: thread-local data
            segment = b;
        } else if (!(b == 0x26 || b == 0x2E || b == 0x36 || b == 0x3E || b == 0xF2 ||
                     b == 0xF3)) {  // other segments, REP: no effect here
            break;
        }
    }
    uint8_t rex = 0;
    if ((p[n] & 0xF0) == 0x40) rex = p[n++];  // REX, the last prefix
    if (p[n] != 0xF6 && p[n] != 0xF7) return d;
    const bool bytewise = p[n++] == 0xF6;
    const uint8_t modrm = p[n++];
    const uint8_t mod = modrm >> 6, reg = (modrm >> 3) & 7, rm = modrm & 7;
    if (reg != 6 && reg != 7) return d;  // not DIV, IDIV
    d.is_signed = reg == 7;
    d.bytes = bytewise ? 1 : (rex & 8) ? 8 : operand16 ? 2 : 4;
    uint64_t value = 0;
    if (mod == 3) {
        value = uint64_t(general_register(g, rm | ((rex & 1u) << 3)));
        // Bytewise without REX, rm 4-7 are AH, CH, DH, BH (with REX: SPL, BPL, SIL, DIL).
        if (bytewise && !rex && rm >= 4) value = uint64_t(general_register(g, rm - 4)) >> 8;
    } else {
        uint64_t address = 0;
        bool rip_relative = false;
        if (rm == 4) {  // SIB: base + index << scale
            const uint8_t sib = p[n++];
            const unsigned index = ((sib >> 3) & 7) | ((rex & 2u) << 2);
            if (index != 4) address += uint64_t(general_register(g, index)) << (sib >> 6);
            if (mod == 0 && (sib & 7) == 5) {  // no base: disp32
                address += uint64_t(int64_t(displacement32(p + n)));
                n += 4;
            } else {
                address += uint64_t(general_register(g, (sib & 7) | ((rex & 1u) << 3)));
            }
        } else if (mod == 0 && rm == 5) {  // RIP + disp32
            address += uint64_t(int64_t(displacement32(p + n)));
            n += 4;
            rip_relative = true;
        } else {
            address += uint64_t(general_register(g, rm | ((rex & 1u) << 3)));
        }
        if (mod == 1) address += uint64_t(int64_t(int8_t(p[n++])));
        if (mod == 2) {
            address += uint64_t(int64_t(displacement32(p + n)));
            n += 4;
        }
        if (rip_relative) address += uint64_t(reinterpret_cast<uintptr_t>(p + n));  // the next
        if (address32) address = uint32_t(address);
        if (segment) {
            unsigned long base = 0;
            syscall(SYS_arch_prctl, segment == 0x64 ? ARCH_GET_FS : ARCH_GET_GS, &base);
            address += base;
        }
        std::memcpy(&value, reinterpret_cast<const void*>(uintptr_t(address)), d.bytes);
    }
    d.divisor = d.bytes == 8 ? value : value & ((uint64_t(1) << (8 * d.bytes)) - 1);
    d.length = n;
    return d;
}
inline void on_division_trap(int, siginfo_t*, void* context) {
    ucontext_t* uc = static_cast<ucontext_t*>(context);
    greg_t* g = uc->uc_mcontext.gregs;
    uint8_t* pc = reinterpret_cast<uint8_t*>(g[REG_RIP]);
    const Division d = decode_division(pc, g);
    if (!d.length) {  // not a division: the default action (the run reports the signal)
        std::signal(SIGFPE, SIG_DFL);
        return;
    }
    typedef unsigned __int128 u128;
    const unsigned bits = 8 * d.bytes;
    const uint64_t mask = d.bytes == 8 ? ~uint64_t(0) : (uint64_t(1) << bits) - 1;
    const uint64_t rax = uint64_t(g[REG_RAX]), rdx = uint64_t(g[REG_RDX]);
    // The dividend: AX (bytewise), else DX:AX, EDX:EAX or RDX:RAX, 2 * bits wide.
    const u128 dividend =
        d.bytes == 1 ? u128(rax & 0xFFFF) : (u128(rdx & mask) << bits) | (rax & mask);
    uint64_t quotient = 0, remainder = 0;
    if (d.divisor == 0) {  // the device's 0; the remainder is the dividend (its low part)
        char where[512] = "";
        if (__sanitizer_symbolize_pc) __sanitizer_symbolize_pc(pc, "%s:%l", where, sizeof where);
        call("ppaloc_division_by_zero", false, {Arg(where)}, Loc{"", 0});
        remainder = uint64_t(dividend) & mask;
    } else {  // the quotient does not fit: its low bits (INT_MIN / -1: INT_MIN), exact remainder
        const u128 wide_mask = bits == 64 ? ~u128(0) : (u128(1) << (2 * bits)) - 1;
        const bool a_negative = d.is_signed && ((dividend >> (2 * bits - 1)) & 1);
        const bool b_negative = d.is_signed && ((d.divisor >> (bits - 1)) & 1);
        const u128 a = a_negative ? (-dividend) & wide_mask : dividend;  // magnitudes: no trap
        const u128 b = b_negative ? u128((-d.divisor) & mask) : u128(d.divisor);
        const u128 q = a / b, r = a % b;
        quotient = uint64_t(a_negative != b_negative ? -q : q) & mask;
        remainder = uint64_t(a_negative ? -r : r) & mask;
    }
    if (d.bytes == 1) {  // AL := quotient, AH := remainder
        g[REG_RAX] = greg_t((rax & ~uint64_t(0xFFFF)) | (remainder << 8) | quotient);
    } else if (d.bytes == 2) {  // AX, DX: the rest of RAX, RDX is kept
        g[REG_RAX] = greg_t((rax & ~uint64_t(0xFFFF)) | quotient);
        g[REG_RDX] = greg_t((rdx & ~uint64_t(0xFFFF)) | remainder);
    } else {  // EAX, EDX zero-extended into RAX, RDX (as the CPU writes them); or RAX, RDX
        g[REG_RAX] = greg_t(quotient);
        g[REG_RDX] = greg_t(remainder);
    }
    g[REG_RIP] += greg_t(d.length);
}
inline bool catch_division_traps() {
    struct sigaction sa;
    std::memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_division_trap;
    sa.sa_flags = SA_SIGINFO | SA_NODEFER;
    return sigaction(SIGFPE, &sa, nullptr) == 0;
}
inline const bool division_traps_caught = catch_division_traps();
}  // namespace ppa
#endif


// ------------------------------------------------------------------ kernels
class scamp5_kernel;
namespace ppa {
inline scamp5_kernel*& active() {
    static scamp5_kernel* k = nullptr;
    return k;
}
inline std::map<std::string, uint32_t>& known_bodies() {
    static std::map<std::string, uint32_t> m;
    return m;
}
void emit(const char* fn, const Loc& loc, const Arg* const* args, int n);
// The C++ kernel objects that hold each recorded (not dynamic) kernel: the simulator frees
// a kernel's ICWs when the last one goes, as the device's destructor does. Never destroyed,
// as kernels of static storage may be destroyed after it would be.
inline std::map<uint32_t, int>& kernel_holders() {
    static std::map<uint32_t, int>* m = new std::map<uint32_t, int>;
    return *m;
}
}  // namespace ppa

class scamp5_kernel {
   public:
    uint32_t id = 0;
    uint32_t where = 0;  // the wired place of its recording (messages about it name it)
    std::vector<uint8_t> body;
    uint32_t calls = 0;  // a kernel of 65,536 calls and more is recorded whole
    unsigned line = 0;
    const char* file = "";

    scamp5_kernel() {}
    // A copy holds the same recording; the recording's ICWs stay on the stack while one
    // object holds them (the device's copies would free them twice).
    scamp5_kernel(const scamp5_kernel& o)
        : id(o.id), where(o.where), body(o.body), calls(o.calls), line(o.line), file(o.file),
          dynamic(o.dynamic) {
        hold();
    }
    scamp5_kernel& operator=(const scamp5_kernel& o) {
        if (this != &o) {
            release();
            id = o.id;
            where = o.where;
            body = o.body;
            calls = o.calls;
            line = o.line;
            file = o.file;
            dynamic = o.dynamic;
            hold();
        }
        return *this;
    }
    // Deleted, or out of scope: the last object holding a recording takes its ICWs off the
    // simulator's 1024-ICW stack, as the device's destructor does, so a program that
    // records kernels, runs and deletes them (to fit a long program) has the room again.
    ~scamp5_kernel() { release(); }
    explicit scamp5_kernel(std::function<void(void)> f, ppa::Loc loc = PPA_HERE) {
        recording_start(loc.file, loc.line);
        f();
        recording_stop();
    }
    // A ROM kernel: ICW words compiled beforehand, in the device's own layout, which the
    // public headers do not give; not modelled, so the program stops here in one line.
    scamp5_kernel(const uint32_t (*icw)[5], size_t n, ppa::Loc loc = PPA_HERE) {
        (void)icw;
        (void)n;
        ppa::fail(loc,
                  "scamp5_kernel(icw, n): ROM kernels (precompiled ICW words) are not modelled; "
                  "record the kernel with scamp5_kernel_begin()/scamp5_kernel_end() or from a "
                  "lambda (scamp5_kernel k([] { ... })), or run raw ICW words with "
                  "vs_scamp5_execute_icw");
    }
    bool null() const { return id == 0; }
    // k([] { ... }): a kernel not yet recorded records the function's calls, as the device's
    // operator() does (an array of kernels filled in a loop); one already recorded keeps
    // its recording. Either way the kernel itself, to launch.
    scamp5_kernel& operator()(std::function<void(void)> f, ppa::Loc loc = PPA_HERE) {
        if (null()) {
            recording_start(loc.file, loc.line);
            f();
            recording_stop();
        }
        return *this;
    }
    // Accepted and recorded (host.txt): the kernels' ICWs are in timing.json.
    static void print_debug_info(ppa::Loc loc = PPA_HERE) {
        ppa::call("scamp5_kernel::print_debug_info", false, {}, loc);
    }

    bool dynamic = false;  // a dynamic kernel leaves the ICW stack after its launch

    // scamp5_kernel_begin(): the first pass records the kernel; the device replays that
    // recording at every later pass, and so does the shim, but a later pass runs the body
    // again to compare what it would record (a kernel in a helper function called with
    // other registers records the first call's): the first difference is reported once, a
    // warning of the run, and then the body is no longer run. The body's other C++
    // statements run again with it; without the check (kernel_check()) a body runs once,
    // as on the device. True: run the body.
    bool begin_static(const char* f, unsigned l) {
        if (null()) {
            recording_start(f, l);
            return true;
        }
        if (changed || !ppa::kernel_check()) return false;
        if (ppa::active()) ppa::fail(ppa::Loc{f, l}, "a kernel begins inside another kernel");
        recorded.swap(body);
        body.clear();
        recorded_calls = calls;
        calls = 0;
        ppa::comparing() = true;
        ppa::active() = this;
        return true;
    }

    void recording_start(const char* f = "", unsigned l = 0, bool dyn = false) {
        if (ppa::active()) ppa::fail(ppa::Loc{f, l}, "a kernel begins inside another kernel");
        file = f;
        line = l;
        dynamic = dyn;
        body.clear();
        calls = 0;
        ppa::active() = this;
    }
    void recording_stop() {
        ppa::active() = nullptr;
        if (ppa::comparing()) {
            compare_stop();
            return;
        }
        std::string key(body.begin(), body.end());
        key.push_back(dynamic ? 'd' : 's');
        auto& known = ppa::known_bodies();
        auto it = known.find(key);
        if (it != known.end()) {
            id = it->second;
            where = ppa::wire(file, line);
            hold();
            return;
        }
        id = uint32_t(known.size() + 1);
        known[key] = id;
        hold();
        where = ppa::wire(file, line);
        ppa::Client& c = ppa::Client::get();
        size_t at = c.begin(ppa::OP_DEF);
        c.u32(id);
        c.u32(where);
        c.u8(dynamic ? 1 : 0);
        c.u32(calls);
        c.bytes(body.data(), body.size());
        c.end(at);
    }
    // The end of a pass that only compared: the simulator is told of the first difference
    // (the body this pass would have recorded, beside the id of the one that runs).
    void compare_stop() {
        ppa::comparing() = false;
        if (body != recorded) {
            changed = true;
            ppa::call("ppaloc_static_kernel_changed", false,
                      {int(id), int(calls), ppa::Arg(body.data(), body.size())},
                      ppa::Loc{file, line});
        }
        body.swap(recorded);
        calls = recorded_calls;
        std::vector<uint8_t>().swap(recorded);
    }
    // A launch is named at its own place: a kernel never recorded has none of its own.
    void operator()(ppa::Loc loc = PPA_HERE) {
        if (null()) {
            ppa::fail(loc,
                      "a kernel is launched before it is recorded: record it first, "
                      "scamp5_kernel k([]{ ... }), or call it with a function, k([]{ ... })");
        }
        ppa::Client& c = ppa::Client::get();
        size_t at = c.begin(ppa::OP_RUN);
        c.u32(id);
        c.end(at);
    }
    friend void scamp5_launch_kernel(scamp5_kernel& k, ppa::Loc loc = PPA_HERE) { k(loc); }

   private:
    void hold() {
        if (id != 0 && !dynamic) ppa::kernel_holders()[id]++;
    }
    void release() {
        if (id == 0 || dynamic) return;
        auto& holders = ppa::kernel_holders();
        auto it = holders.find(id);
        if (it == holders.end() || --it->second > 0) return;
        holders.erase(it);
        // where it was recorded, as wired then: a static kernel may outlive the file maps
        if (!ppa::run_over()) ppa::call_at("ppaloc_kernel_freed", false, {int(id)}, where);
    }
    bool changed = false;           // a later pass's body differed: reported, not run again
    std::vector<uint8_t> recorded;  // the recording, aside while a later pass compares
    uint32_t recorded_calls = 0;
};

inline void ppa::emit(const char* fn, const Loc& loc, const Arg* const* args, int n) {
    scamp5_kernel* k = active();
    if (!k) {
        fail(loc, std::string(fn) +
                      "() is a kernel function: call it between scamp5_kernel_begin() and "
                      "scamp5_kernel_end()");
    }
    std::vector<uint8_t>& b = k->body;
    size_t len = std::strlen(fn);
    b.push_back(uint8_t(len));
    b.insert(b.end(), fn, fn + len);
    const uint32_t where = ppa::wire(loc);
    for (int s = 0; s < 4; ++s) b.push_back((where >> (8 * s)) & 0xFF);
    b.push_back(uint8_t(n));
    for (int i = 0; i < n; ++i) {
        b.push_back(args[i]->tag);
        for (int s = 0; s < 4; ++s) b.push_back((uint32_t(args[i]->value) >> (8 * s)) & 0xFF);
    }
    k->calls++;
}

#include "ppaloc_gen_macros.hpp"

namespace scamp5_kernel_api {
// As the device's kernel API headers do: a kernel block (its `using namespace
// scamp5_kernel_api`) sees the registers without `using namespace SCAMP5_PE`.
using namespace SCAMP5_PE;
// The several-destination form: bus({a, b, ...}, {x, y, ...}), one ICW.
inline void bus(std::initializer_list<ppa::Arg> dst, std::initializer_list<ppa::Arg> src,
                ppa::Loc loc = PPA_HERE) {
    scamp5_kernel* k = ppa::active();
    if (!k) ppa::fail(loc, "bus() is a kernel function: call it inside a kernel");
    std::vector<uint8_t>& b = k->body;
    auto put = [&b](uint8_t tag, uint32_t v) {
        b.push_back(tag);
        for (int s = 0; s < 4; ++s) b.push_back((v >> (8 * s)) & 0xFF);
    };
    b.push_back(3);
    b.insert(b.end(), {'b', 'u', 's'});
    const uint32_t where = ppa::wire(loc);
    for (int s = 0; s < 4; ++s) b.push_back((where >> (8 * s)) & 0xFF);
    b.push_back(2);
    for (auto* list : {&dst, &src}) {
        put(ppa::TAG_LIST, uint32_t(list->size()));
        for (const ppa::Arg& a : *list) put(a.tag, uint32_t(a.value));
    }
    k->calls++;
}
// The device's high-speed clock for this kernel: accepted and recorded (the timing model
// charges every kernel at one clock).
inline void allow_highspeed(bool k, ppa::Loc loc = PPA_HERE) {
    if (!ppa::active()) ppa::fail(loc, "allow_highspeed() is a kernel function: call it inside a kernel");
    ppa::call("allow_highspeed", false, {int(k)}, loc);
}
}  // namespace scamp5_kernel_api
namespace ppa {
// A raw word into the kernel being recorded: its clock and its set bit positions.
inline void emit_icw(scamp5_kernel* k, uint8_t clock, const uint8_t* bits, size_t n,
                     const Loc& loc) {
    std::vector<uint8_t>& b = k->body;
    auto put = [&b](uint8_t tag, uint32_t v) {
        b.push_back(tag);
        for (int s = 0; s < 4; ++s) b.push_back((v >> (8 * s)) & 0xFF);
    };
    b.push_back(3);
    b.insert(b.end(), {'i', 'c', 'w'});
    const uint32_t where = ppa::wire(loc);
    for (int s = 0; s < 4; ++s) b.push_back((where >> (8 * s)) & 0xFF);
    b.push_back(2);
    put(ppa::TAG_INT, clock);
    put(ppa::TAG_LIST, uint32_t(n));
    for (size_t i = 0; i < n; ++i) put(ppa::TAG_INT, bits[i]);
    k->calls++;
}
}  // namespace ppa
namespace scamp5_kernel_api {
// The raw word: icw(clock, {bit positions of SCAMP5_ICW_BITS}), decoded by the simulator.
inline void icw(uint8_t clock, std::initializer_list<uint8_t> bits, ppa::Loc loc = PPA_HERE) {
    scamp5_kernel* k = ppa::active();
    if (!k) ppa::fail(loc, "icw() is a kernel function: call it inside a kernel");
    ppa::emit_icw(k, clock, bits.begin(), bits.size(), loc);
}
}  // namespace scamp5_kernel_api

#define scamp5_kernel_begin()                   \
    {                                           \
        using namespace SCAMP5_ICW_BITS;        \
        using namespace scamp5_kernel_api;      \
        static scamp5_kernel __ppa_sk;          \
        if (__ppa_sk.begin_static(__FILE__, __LINE__)) {
#define scamp5_kernel_end()      \
    __ppa_sk.recording_stop();   \
    }                            \
    scamp5_launch_kernel(__ppa_sk); \
    }
// A static kernel whose compiled ICWs the device prints to the host when its recording
// stops: the printing is recorded once in host.txt (the kernels' ICWs are in timing.json).
class scamp5_kernel_printable : public scamp5_kernel {
   public:
    scamp5_kernel_printable(const char* f, int l) {
        file = f;
        line = unsigned(l);
    }
    void print_const_kernel_source() {
        ppa::call("scamp5_kernel_begin_print", false, {int(line)}, ppa::Loc{file, line});
    }
    void recording_start() { scamp5_kernel::recording_start(file, line); }
    void recording_stop() {
        const bool recording = !ppa::comparing();
        scamp5_kernel::recording_stop();
        if (recording) print_const_kernel_source();
    }
};
// It ends with scamp5_kernel_end(), as on the device.
#define scamp5_kernel_begin_print()                                         \
    {                                                                       \
        using namespace SCAMP5_ICW_BITS;                                    \
        using namespace scamp5_kernel_api;                                  \
        static scamp5_kernel_printable __ppa_sk(__FILE__, __LINE__);        \
        if (__ppa_sk.begin_static(__FILE__, __LINE__)) {
#define scamp5_dynamic_kernel_begin()      \
    {                                      \
        using namespace SCAMP5_ICW_BITS;   \
        using namespace scamp5_kernel_api; \
        scamp5_kernel __ppa_sk;            \
        __ppa_sk.recording_start(__FILE__, __LINE__, true);
#define scamp5_dynamic_kernel_end() \
    __ppa_sk.recording_stop();      \
    scamp5_launch_kernel(__ppa_sk); \
    }

// ------------------------------------------------------------------ controller: analogue
#define PPA_CALL(fn, want, ...) ppa::call(fn, want, {__VA_ARGS__}, loc)

inline void scamp5_get_image(AREG yf, AREG yh, int gain = 1, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_get_image", false, yf, yh, gain);
}
inline void scamp5_in(AREG areg, int8_t value, AREG temp = SCAMP5_PE::NEWS,
                      ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_in", false, areg, int(value), temp);
}
inline void scamp5_load_in(AREG areg, int8_t value, AREG temp = SCAMP5_PE::NEWS,
                           ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_in", false, areg, int(value), temp);
}
inline void scamp5_load_in(int8_t value, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_in_value", false, int(value));
}
inline void scamp5_shift(AREG areg, int h, int v, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_shift", false, areg, h, v, 0, 2);
}
inline uint8_t scamp5_read_areg(ASRC areg, uint8_t r, uint8_t c, ppa::Loc loc = PPA_HERE) {
    return uint8_t(ppa::as_int(PPA_CALL("scamp5_read_areg", true, areg, int(r), int(c))));
}
inline uint32_t ppa_global_sum(const char* fn, AREG areg, uint8_t* out, int n, ppa::Loc loc) {
    std::vector<uint8_t> r = PPA_CALL(fn, true, areg);
    if (out) std::memcpy(out, r.data() + 4, size_t(n));
    return uint32_t(ppa::as_int(r));
}
inline uint32_t scamp5_global_sum_16(AREG areg, uint8_t* result16v = NULL,
                                     ppa::Loc loc = PPA_HERE) {
    return ppa_global_sum("scamp5_global_sum_16", areg, result16v, 16, loc);
}
inline uint32_t scamp5_global_sum_64(AREG areg, uint8_t* result64v = NULL,
                                     ppa::Loc loc = PPA_HERE) {
    return ppa_global_sum("scamp5_global_sum_64", areg, result64v, 64, loc);
}

// ------------------------------------------------------------------ controller: digital
inline void scamp5_shift(DREG dreg, int h, int v, const int boundary = 0, const int refresh = 2,
                         ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_shift", false, dreg, h, v, boundary, refresh);
}
inline int scamp5_global_or(DSRC dreg, uint8_t r = 0, uint8_t c = 0, uint8_t rx = 255,
                            uint8_t cx = 255, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(
        PPA_CALL("scamp5_global_or", true, dreg, int(r), int(c), int(rx), int(cx)));
}
inline int scamp5_global_count(DSRC dreg, AREG temp, int options = 0, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("scamp5_global_count", true, dreg, temp, options));
}
inline void scamp5_load_point(DREG dr, uint8_t r, uint8_t c, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_point", false, dr, int(r), int(c));
}
inline void scamp5_load_rect(DREG dr, uint8_t r0, uint8_t c0, uint8_t r1, uint8_t c1,
                             ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_rect", false, dr, int(r0), int(c0), int(r1), int(c1));
}
inline void scamp5_load_pattern(DREG dr, uint8_t r, uint8_t c, uint8_t rx, uint8_t cx,
                                ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_pattern", false, dr, int(r), int(c), int(rx), int(cx));
}
inline void scamp5_select_point(uint8_t r, uint8_t c, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_point", false, int(r), int(c));
}
inline void scamp5_select_rect(uint8_t r0, uint8_t c0, uint8_t r1, uint8_t c1,
                               ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_rect", false, int(r0), int(c0), int(r1), int(c1));
}
inline void scamp5_select_pattern(uint8_t r, uint8_t c, uint8_t rx, uint8_t cx,
                                  ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_pattern", false, int(r), int(c), int(rx), int(cx));
}

// ------------------------------------------------------------------ controller: the rest
inline void scamp5_load_dac(AREG areg, uint16_t dac_db, AREG temp = SCAMP5_PE::NEWS,
                            ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_dac", false, areg, int(dac_db), temp);
}
inline void scamp5_load_dac(uint16_t dac_db, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_load_dac_value", false, int(dac_db));
}
inline void scamp5_diffuse(AREG target, int iterations, bool vertical = true,
                           bool horizontal = true, AREG t0 = SCAMP5_PE::NEWS,
                           ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_diffuse", false, target, iterations, int(vertical), int(horizontal), t0);
}
inline void scamp5_flood(DREG dreg_target, DSRC dreg_mask, int boundary, int iterations = 5,
                         bool use_local = false, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_flood", false, dreg_target, dreg_mask, boundary, iterations,
             int(use_local));
}
inline void scamp5_kernel_all(ppa::Loc loc = PPA_HERE) { PPA_CALL("scamp5_kernel_all", false, 0); }
inline void scamp5_kernel_refresh_dreg(ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_kernel_refresh_dreg", false, 0);
}
inline void scamp5_select_col(uint8_t c, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_col", false, int(c));
}
inline void scamp5_select_row(uint8_t r, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_row", false, int(r));
}
inline void scamp5_select_colx(uint8_t cx, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_colx", false, int(cx));
}
inline void scamp5_select_rowx(uint8_t rx, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_select_rowx", false, int(rx));
}
inline uint8_t scamp5_global_sum_fast(AREG areg, ppa::Loc loc = PPA_HERE) {
    return uint8_t(ppa::as_int(PPA_CALL("scamp5_global_sum_fast", true, areg)));
}
inline uint8_t scamp5_global_sum_sparse(AREG areg, uint8_t r = 2, uint8_t c = 2, uint8_t rx = 254,
                                        uint8_t cx = 254, ppa::Loc loc = PPA_HERE) {
    return uint8_t(ppa::as_int(
        PPA_CALL("scamp5_global_sum_sparse", true, areg, int(r), int(c), int(rx), int(cx))));
}
inline uint8_t scamp5_global_sum_region(const areg_t& areg, uint8_t r0, uint8_t c0, uint8_t r1,
                                        uint8_t c1, ppa::Loc loc = PPA_HERE) {
    return uint8_t(ppa::as_int(PPA_CALL("scamp5_global_sum_region", true, areg, int(r0), int(c0),
                                        int(r1), int(c1))));
}
inline int32_t vs_scamp5_get_parameter(int which, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("vs_scamp5_get_parameter", true, which));
}
inline int32_t vs_vision_chip_get_parameter(int which, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("vs_scamp5_get_parameter", true, which));  // the same table
}
inline void scamp5_draw_begin(DREG dr, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_begin", false, dr);
}
inline void scamp5_draw_end(ppa::Loc loc = PPA_HERE) { PPA_CALL("scamp5_draw_end", false, 0); }
inline void scamp5_draw_pixel(uint8_t r, uint8_t c, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_pixel", false, int(r), int(c));
}
inline bool scamp5_draw_point(int r, int c, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("scamp5_draw_point", true, r, c)) != 0;
}
inline void scamp5_draw_rect(uint8_t r0, uint8_t c0, uint8_t r1, uint8_t c1,
                             ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_rect", false, int(r0), int(c0), int(r1), int(c1));
}
inline void scamp5_draw_line(int r0, int c0, int r1, int c1, bool repeat = false,
                             ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_line", false, r0, c0, r1, c1, int(repeat));
}
inline void scamp5_draw_circle(int r, int c, int radius, bool repeat = false,
                               ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_circle", false, r, c, radius, int(repeat));
}
inline void scamp5_draw_negate(ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_draw_negate", false, 0);
}

// ------------------------------------------------------------------ readouts and outputs
inline void ppa_fill(const std::vector<uint8_t>& r, uint8_t* out) {
    if (out && !r.empty()) std::memcpy(out, r.data(), r.size());
}
inline void scamp5_scan_areg(ASRC areg, uint8_t* buffer, uint8_t r0, uint8_t c0, uint8_t r1,
                             uint8_t c1, uint8_t rs, uint8_t cs, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_areg", true, areg, int(r0), int(c0), int(r1), int(c1),
                      int(rs), int(cs)),
             buffer);
}
inline void scamp5_scan_areg_8x8(ASRC areg, uint8_t* result8x8, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_areg_8x8", true, areg), result8x8);
}
inline void scamp5_scan_areg_mean_8x8(ASRC areg, uint8_t* result8x8, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_areg_mean_8x8", true, areg), result8x8);
}
inline void scamp5_scan_dreg(DSRC dreg, uint8_t* mem, uint8_t r0 = 0, uint8_t r1 = 255,
                             ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_dreg", true, dreg, int(r0), int(r1)), mem);
}
inline void scamp5_scan_events(DSRC dreg, uint8_t* cr2v, uint16_t max_num = 1, uint8_t h_dir = 0,
                               uint8_t v_dir = 0, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_events", true, dreg, int(max_num), int(h_dir), int(v_dir)),
             cr2v);
}
inline void scamp5_scan_events_cr(DSRC dreg, uint8_t* cr2v, uint16_t max_num = 1,
                                  uint8_t h_dir = 0, uint8_t v_dir = 0, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_events", true, dreg, int(max_num), int(h_dir), int(v_dir)),
             cr2v);
}
inline void scamp5_scan_events_rc(DSRC dreg, uint8_t* rc2v, uint16_t max_num = 1,
                                  uint8_t h_dir = 0, uint8_t v_dir = 0, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_events_rc", true, dreg, int(max_num), int(h_dir), int(v_dir)),
             rc2v);
}
inline void scamp5_scan_boundingbox(DSRC dreg, uint8_t* vec4v, ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_scan_boundingbox", true, dreg), vec4v);
}
inline void scamp5_output_image(ASRC areg, vs_handle display, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_image", false, areg, display);
}
inline void scamp5_output_image(DSRC dreg, vs_handle display, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_image", false, dreg, display);
}
inline void scamp5_output_bitstack_begin(vs_handle display, int n_bits, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_bitstack_begin", false, display, n_bits);
}
inline void scamp5_output_bitstack_bit(DSRC dreg, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_bitstack_bit", false, dreg);
}
inline void scamp5_output_bitstack_end(ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_bitstack_end", false, 0);
}

// ------------------------------------------------------------------ vs_*: loop, text, GUI
namespace ppa {
inline uint32_t& loop_counter() {
    static uint32_t n = 0;
    return n;
}
// The host's own GUI items (the device's VS_GUI_* handles) and their values here: the host
// is connected, the frame gain is 1 (scamp5_get_image's default), the frame rate 30 fps.
constexpr vs_handle GUI_HOST_STATUS = 128, GUI_FRAME_RATE = 130, GUI_FRAME_GAIN = 131;
// The host's other sliders vs_on_gui_update names (vector and image data length, image
// blend): the headers give no value, so none is held (a callback set on one is never
// called; reading one stops the program in one line).
constexpr vs_handle GUI_VECTOR_LENGTH = 132, GUI_IMAGE_LENGTH = 133, GUI_IMAGE_BLEND = 134;
struct Gui {
    std::map<vs_handle, int32_t> values{
        {GUI_HOST_STATUS, 1}, {GUI_FRAME_RATE, 30}, {GUI_FRAME_GAIN, 1}};
    std::map<vs_handle, volatile int*> writeback;
    std::map<vs_handle, std::function<void(int32_t)>> callbacks;
    std::vector<vs_handle> due;  // callbacks set since the last message processing
    std::set<vs_handle> buttons;  // their callbacks run only when pressed
    vs_handle next = 1;
};
inline Gui& gui() {
    static Gui g;
    return g;
}
inline vs_handle gui_item(const char* kind, const char* text, int32_t lo, int32_t hi,
                          int32_t init, volatile int* wb, const Loc& loc) {
    Gui& g = gui();
    vs_handle h = g.next++;
    int32_t v = as_int(call(kind, true, {Arg(text), lo, hi, init, int32_t(h)}, loc));
    g.values[h] = v;
    if (wb) {
        *wb = v;
        g.writeback[h] = wb;
    }
    return h;
}
}  // namespace ppa

// The host's side of a run: it is connected throughout (its connect callbacks run at the
// first message processing after they are set), and at the end of the run it disconnects
// and the core shuts down (those callbacks run once, in that order, as the program exits).
namespace ppa {
struct Hooks {
    std::vector<std::function<void(void)>> connect, disconnect, shutdown;
    size_t connected = 0;  // connect callbacks already run
    bool ended = false;
    std::function<void(void)> request;  // a host request's answer, due at the next processing
};
inline Hooks& hooks() {
    static Hooks h;
    return h;
}
inline void host_event(const char* what) {
    call("vs_host_event", false, {Arg(what)}, Loc{"", 0});
}
inline void process_messages() {
    Hooks& h = hooks();
    if (h.connected < h.connect.size()) {
        host_event("connected (vs_on_host_connect)");
        while (h.connected < h.connect.size()) h.connect[h.connected++]();
    }
    // The host's values of the items whose callbacks were set since the last processing,
    // as the host's GUI messages reach the device: each callback once, with its item's value.
    Gui& g = gui();
    while (!g.due.empty()) {
        vs_handle item = g.due.front();
        g.due.erase(g.due.begin());
        if (g.callbacks.count(item) && g.values.count(item)) g.callbacks[item](g.values[item]);
    }
    if (h.request) {
        std::function<void(void)> answer = std::move(h.request);
        h.request = nullptr;
        answer();
    }
}
inline void end_of_run() {
    Hooks& h = hooks();
    if (h.ended) return;
    h.ended = true;
    if (!h.disconnect.empty()) host_event("disconnected (vs_on_host_disconnect)");
    for (auto& f : h.disconnect) f();
    if (!h.shutdown.empty()) host_event("shutting down (vs_on_shutdown)");
    for (auto& f : h.shutdown) f();
}
}  // namespace ppa

inline void vs_init(ppa::Loc loc = PPA_HERE) {
    ppa::Client::get().connect();
    static bool once = false;
    if (once) return;
    once = true;
    ppa::hooks();  // built before the exit handler, so alive when it runs
    ppa::gui();
    ppa::wire(loc);  // its file maps too: the exit handler's calls use them
    std::atexit([] { ppa::end_of_run(); });
}
// The device's error flags. The simulator stops the run with a message where the device
// would fail to boot, allocate or calibrate; an overflow of the 1024-ICW stack that static
// kernels share is its one flag here (also a warning in summary.json), set from the frame
// loop's answer after the kernel that overflowed it was first run.
struct vs_device_error_bits_t {
    uint32_t booting_failed : 1;
    uint32_t shutdown_failed : 1;
    uint32_t watchdog_timeout : 1;
    uint32_t coroutine_timeout : 1;
    uint32_t bank0_malloc_failed : 1;
    uint32_t bank1_malloc_failed : 1;
    uint32_t shared_malloc_failed : 1;
    uint32_t icw_stack_overflow : 1;
    uint32_t calibration_failed : 1;
};
namespace ppa {
inline vs_device_error_bits_t device_errors{};
}
inline vs_device_error_bits_t* vs_device_error_bits = &ppa::device_errors;
namespace ppa {
// Slider and switch values the host changed while the program runs (a live view): the
// frame loop's answer carries (handle, value) pairs after its own value, applied here as the
// device applies the host's GUI messages: the value, its writeback variable, its callback.
inline void gui_changes(const std::vector<uint8_t>& r) {
    Gui& g = gui();
    for (size_t at = 4; at + 8 <= r.size(); at += 8) {
        vs_handle h = vs_handle(as_int(std::vector<uint8_t>(r.begin() + at, r.begin() + at + 4)));
        int32_t v = as_int(std::vector<uint8_t>(r.begin() + at + 4, r.begin() + at + 8));
        if (h == DEVICE_ERRORS) {
            device_errors.icw_stack_overflow = (uint32_t(v) & ICW_STACK_OVERFLOW) ? 1 : 0;
            continue;
        }
        if (!g.values.count(h)) continue;
        g.values[h] = v;
        if (g.writeback.count(h)) *g.writeback[h] = v;
        g.due.erase(std::remove(g.due.begin(), g.due.end(), h), g.due.end());
        if (g.callbacks.count(h)) g.callbacks[h](v);
    }
}
}  // namespace ppa
// The frame trigger is the frame boundary: each wait for it starts the next frame (after the
// last, the program ends). vs_frame_loop_control is the loop counter's increment, that wait
// and the message processing at once, as on the device; a program may write the three itself.
// A program that never waits for the trigger (its loop runs free on the device:
// vs_process_message, the body, vs_loop_counter_inc) counts its frames with the loop
// counter: each vs_loop_counter_inc ends a frame and starts the next, in a program whose
// sources call neither vs_frame_loop_control nor vs_wait_frame_trigger (the build defines
// PPA_PACED=1 where one of them is called anywhere, so a program that counts its loops
// before its first wait loses no frame).
#ifndef PPA_PACED
#define PPA_PACED 0
#endif
namespace ppa {
inline bool& paced() {
    static bool p = PPA_PACED;
    return p;
}
inline void next_frame(const char* fn, const Loc& loc) {
    std::vector<uint8_t> r = call(fn, true, {0}, loc);
    gui_changes(r);
    if (!as_int(r)) std::exit(0);
}
}  // namespace ppa
inline void vs_wait_frame_trigger(ppa::Loc loc = PPA_HERE) {
    ppa::paced() = true;
    ppa::next_frame("vs_wait_frame_trigger", loc);
}
inline void vs_frame_loop_control(ppa::Loc loc = PPA_HERE) {
    ppa::paced() = true;
    ppa::loop_counter()++;
    ppa::next_frame("vs_frame_loop_control", loc);
    ppa::process_messages();
}
inline void vs_process_message() { ppa::process_messages(); }
inline void vs_on_host_connect(std::function<void(void)> f) { ppa::hooks().connect.push_back(f); }
inline void vs_on_host_disconnect(std::function<void(void)> f) {
    ppa::hooks().disconnect.push_back(f);
}
inline void vs_on_shutdown(std::function<void(void)> f) { ppa::hooks().shutdown.push_back(f); }
// The device's own names of the two above (vs_on_host_connect is its alias of these).
inline void vs_on_gui_connect(std::function<void(void)> f) { vs_on_host_connect(f); }
inline void vs_on_gui_disconnect(std::function<void(void)> f) { vs_on_host_disconnect(f); }
// The host never records a run nor sends a user value here: accepted and recorded
// (host.txt), never called.
inline void vs_on_gui_start_recording(std::function<void(void)> f, ppa::Loc loc = PPA_HERE) {
    (void)f;
    ppa::call("vs_on_gui_start_recording", false, {}, loc);
}
inline void vs_on_gui_stop_recording(std::function<void(void)> f, ppa::Loc loc = PPA_HERE) {
    (void)f;
    ppa::call("vs_on_gui_stop_recording", false, {}, loc);
}
inline void vs_on_user_value(std::function<void(uint8_t, int32_t)> f, ppa::Loc loc = PPA_HERE) {
    (void)f;
    ppa::call("vs_on_user_value", false, {}, loc);
}
// A polled delay on the controller: no wall-clock wait here; the modelled clock
// (vs_stopwatch, timing.json) advances by usec, on the chip's side of the frame as a
// kernel's time is (programs wait out an exposure with it), not the host link's loop.
inline void vs_wait(uint32_t usec, ppa::Loc loc = PPA_HERE) {
    if (usec) PPA_CALL("vs_wait", false, ppa::Arg(&usec, sizeof usec));
}
inline void vs_loop_counter_inc(ppa::Loc loc = PPA_HERE) {
    ppa::loop_counter()++;
    if (!ppa::paced()) ppa::next_frame("vs_loop_counter_inc", loc);
}
inline void vs_loop_counter_reset() { ppa::loop_counter() = 0; }
inline uint32_t vs_loop_counter_get() { return ppa::loop_counter(); }
#define VS_LC vs_loop_counter_get()

__attribute__((format(printf, 1, 2))) inline void vs_post_text(const char* format, ...) {
    char text[1024];
    va_list ap;
    va_start(ap, format);
    std::vsnprintf(text, sizeof text, format, ap);
    va_end(ap);
    ppa::call("vs_post_text", false, {ppa::Arg(text)}, ppa::Loc{"", 0});
}
inline bool vs_gui_is_on() { return true; }
inline void vs_gui_set_info(const char* str) { (void)str; }
inline void vs_gui_push_items() {}
inline void vs_gui_clear_items() {}
inline vs_handle vs_gui_add_display(const char* text, uint8_t row, uint8_t col, int size = 1,
                                    const char* style = NULL, ppa::Loc loc = PPA_HERE) {
    (void)style;
    vs_handle h = ppa::gui().next++;
    PPA_CALL("vs_gui_add_display", false, ppa::Arg(text), h, int(row), int(col), size);
    return h;
}
inline void vs_gui_set_display_style(vs_handle display, const char* style) {
    (void)display;
    (void)style;
}
inline vs_handle vs_gui_add_slider(const char* text, int32_t min, int32_t max, int32_t init,
                                   volatile int* writeback = NULL, ppa::Loc loc = PPA_HERE) {
    return ppa::gui_item("vs_gui_add_slider", text, min, max, init, writeback, loc);
}
inline vs_handle vs_gui_add_slider_latched(const char* text, int32_t min, int32_t max,
                                           int32_t init, volatile int* writeback = NULL,
                                           ppa::Loc loc = PPA_HERE) {
    return ppa::gui_item("vs_gui_add_slider", text, min, max, init, writeback, loc);
}
inline vs_handle vs_gui_add_switch(const char* text, bool init, volatile int* writeback = NULL,
                                   ppa::Loc loc = PPA_HERE) {
    return ppa::gui_item("vs_gui_add_switch", text, 0, 1, init ? 1 : 0, writeback, loc);
}
// A button is pressed once at the start where the run was given --set NAME=1 (its value 1
// then, its callback called with 1 at the next message processing), else only from a live
// view; its value is 0 otherwise.
inline vs_handle vs_gui_add_button(const char* text, ppa::Loc loc = PPA_HERE) {
    vs_handle h = ppa::gui_item("vs_gui_add_button", text, 0, 1, 0, NULL, loc);
    ppa::gui().buttons.insert(h);
    return h;
}
namespace ppa {
inline int32_t& gui_value(const char* fn, vs_handle h, const Loc& loc) {
    Gui& g = gui();
    auto it = g.values.find(h);
    if (it == g.values.end() && h >= GUI_VECTOR_LENGTH && h <= GUI_IMAGE_BLEND) {
        static const char* const names[] = {"VS_GUI_VECTOR_LENGTH", "VS_GUI_IMAGE_LENGTH",
                                            "VS_GUI_IMAGE_BLEND"};
        fail(loc, std::string(fn) + "(" + names[h - GUI_VECTOR_LENGTH] +
                      ", ...): the host's own slider, whose value the headers do not give "
                      "and this run does not hold");
    }
    if (it == g.values.end()) {
        fail(loc, std::string(fn) + "(" + std::to_string(h) +
                      ", ...): no slider, switch or button has this handle; give one that "
                      "vs_gui_add_slider/_switch/_button returned, VS_GUI_FRAME_RATE or "
                      "VS_GUI_FRAME_GAIN");
    }
    return it->second;
}
}  // namespace ppa
inline int32_t vs_gui_read_slider(vs_handle h, ppa::Loc loc = PPA_HERE) {
    return ppa::gui_value("vs_gui_read_slider", h, loc);
}
inline int32_t vs_gui_read_switch(vs_handle h, ppa::Loc loc = PPA_HERE) {
    return ppa::gui_value("vs_gui_read_switch", h, loc);
}
inline void vs_gui_set_slider(vs_handle h, int32_t value, ppa::Loc loc = PPA_HERE) {
    ppa::Gui& g = ppa::gui();
    ppa::gui_value("vs_gui_set_slider", h, loc) = value;
    if (g.writeback.count(h)) *g.writeback[h] = value;
}
inline void vs_gui_move_slider(vs_handle h, int32_t value, bool feedback = true,
                               ppa::Loc loc = PPA_HERE) {
    vs_gui_set_slider(h, value, loc);
    ppa::Gui& g = ppa::gui();
    if (feedback && g.callbacks.count(h)) {
        g.due.erase(std::remove(g.due.begin(), g.due.end(), h), g.due.end());  // delivered
        g.callbacks[h](value);
    }
}
// A slider's new range: checked (a slider's handle, min <= max) and recorded; its value
// is left as it is (the headers do not say the host moves it into the range).
inline void vs_gui_set_slider_range(vs_handle h, int32_t min, int32_t max,
                                    ppa::Loc loc = PPA_HERE) {
    ppa::gui_value("vs_gui_set_slider_range", h, loc);
    if (min > max) {
        ppa::fail(loc, "vs_gui_set_slider_range(" + std::to_string(h) + ", " +
                           std::to_string(min) + ", " + std::to_string(max) +
                           "): the minimum is above the maximum");
    }
    PPA_CALL("vs_gui_set_slider_range", false, h, min, max);
}
inline void vs_on_gui_update(vs_handle item, std::function<void(int32_t)> f) {
    ppa::Gui& g = ppa::gui();
    g.callbacks[item] = f;
    // Called with the value given to this run, once, at the next message processing (the
    // next vs_frame_loop_control or vs_process_message), as the device calls it when the
    // host's value arrives, never from here. A button's callback runs when it is pressed:
    // at the start only where the run pressed it (--set NAME=1).
    if (g.buttons.count(item) && !g.values[item]) return;
    if (std::find(g.due.begin(), g.due.end(), item) == g.due.end()) g.due.push_back(item);
}

// Modelled time: microseconds of the simulator's timing model, not the host's clock.
class vs_stopwatch {
    double start_us = 0;
    static double now() {
        std::vector<uint8_t> r =
            ppa::call("vs_stopwatch_now", true, {0}, ppa::Loc{"", 0});
        double v;
        std::memcpy(&v, r.data(), sizeof v);
        return v;
    }

   public:
    vs_stopwatch() { reset(); }
    void reset() { start_us = now(); }
    uint32_t get_usec() const { return uint32_t(now() - start_us + 0.5); }
};

// ------------------------------------------------------------------ the device beyond the chip
// The M0 core's project string, as vs_gui_set_info takes it.
#define VS_M0_PROJECT_INFO_STRING \
    "Simulation (ppaloc): " __FILE__ "\n" \
    "Compile Time: " __TIME__ " " __DATE__ "\n"


// The host's GUI items, readable with vs_gui_read_slider and vs_on_gui_update.
#define VS_GUI_HOST_STATUS ppa::GUI_HOST_STATUS
#define VS_GUI_FRAME_RATE ppa::GUI_FRAME_RATE
#define VS_GUI_FRAME_GAIN ppa::GUI_FRAME_GAIN
#define VS_GUI_VECTOR_LENGTH ppa::GUI_VECTOR_LENGTH
#define VS_GUI_IMAGE_LENGTH ppa::GUI_IMAGE_LENGTH
#define VS_GUI_IMAGE_BLEND ppa::GUI_IMAGE_BLEND

// A display style given by name to vs_gui_add_display (its JSON is for the host's GUI).
class vs_gui_script {
    const char* name_;
    const char* content_;

   public:
    vs_gui_script(const char* name, const char* content) : name_(name), content_(content) {}
    operator const char*() const { return name_; }
    const char* content() const { return content_; }
};
#define VS_GUI_DISPLAY_STYLE(var_name, content) static vs_gui_script var_name(#var_name, content);

// Frame triggers: accepted and recorded; the frames are the ones the run is given.
#define VS_FRAME_TRIGGER_CONST_LOOP 0
#define VS_FRAME_TRIGGER_CONST_PIX 1
#define VS_FRAME_TRIGGER_GPIO_HIGH 2
#define VS_FRAME_TRIGGER_GPIO_LOW 3
#define VS_FRAME_TRIGGER_GPIO_RISE 4
#define VS_FRAME_TRIGGER_GPIO_FALL 5
#define VS_FRAME_TRIGGER_SYNC 6
inline void vs_configure_frame_trigger(uint16_t mode, int arg, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_configure_frame_trigger", false, int(mode), arg);
}
inline void vs_frame_trigger_set(uint16_t f_num, uint16_t f_den, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_frame_trigger_set", false, int(f_num), int(f_den));
}
inline void vs_enable_frame_trigger(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_enable_frame_trigger", false, {}, loc);
}
inline void vs_disable_frame_trigger(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_disable_frame_trigger", false, {}, loc);
}

// The board's LEDs: accepted and recorded.
#define VS_LED_0 0
#define VS_LED_1 1
#define VS_LED_2 2
inline void vs_led_on(int idx, ppa::Loc loc = PPA_HERE) { PPA_CALL("vs_led_on", false, idx); }
inline void vs_led_off(int idx, ppa::Loc loc = PPA_HERE) { PPA_CALL("vs_led_off", false, idx); }
inline void vs_led_toggle(int idx, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_led_toggle", false, idx);
}

// The board's GPIO pins (vs_gpio.h), wired to nothing here: configurations and outputs are
// recorded; an input reads its pull, an output the level it drives.
#define VS_GPIO_X0 23
#define VS_GPIO_X1 27
#define VS_GPIO_X2 28
#define VS_GPIO_X3 29
#define VS_GPIO_X4 30
inline void vs_gpio_as_input(uint8_t pin, int pu, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_gpio_as_input", false, int(pin), pu);
}
inline void vs_gpio_as_output(uint8_t pin, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_gpio_as_output", false, int(pin));
}
inline int vs_gpio_input(uint8_t pin, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("vs_gpio_input", true, int(pin)));
}
inline void vs_gpio_output(uint8_t pin, int output, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_gpio_output", false, int(pin), output);
}

// The chip's bias voltages: accepted and recorded (the simulator has no analogue biases).
inline void vs_scamp5_configure_voltage(int e, uint16_t d, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_scamp5_configure_voltage", false, e, int(d));
}

// IO agents: the buses a program may send its output through; here everything reaches
// the run's folder, whichever is bound (the binding is recorded).
struct vs_io_agent_api {
    const char* name;
};
namespace ppa {
inline vs_io_agent_api usb_agent{"vs_usb"}, spi_agent{"vs_spi"}, uart_agent{"vs_uart"};
inline void bind_agent(const char* fn, vs_io_agent_api* p, const Loc& loc) {
    if (!p) fail(loc, std::string(fn) + "(NULL): give an io agent: vs_usb, vs_spi or vs_uart");
    call(fn, false, {Arg(p->name)}, loc);
}
}  // namespace ppa
inline vs_io_agent_api* vs_usb = &ppa::usb_agent;
inline vs_io_agent_api* vs_spi = &ppa::spi_agent;
inline vs_io_agent_api* vs_uart = &ppa::uart_agent;
// The agents bound for posts and for the scamp5 outputs: vs_usb until a program binds
// another (the host's link; the headers do not name the agent bound at the start).
namespace ppa {
inline vs_io_agent_api*& post_agent() {
    static vs_io_agent_api* p = vs_usb;
    return p;
}
inline vs_io_agent_api*& scamp5_agent() {
    static vs_io_agent_api* p = vs_usb;
    return p;
}
}  // namespace ppa
inline void vs_post_bind_io_agent(vs_io_agent_api* u, ppa::Loc loc = PPA_HERE) {
    ppa::bind_agent("vs_post_bind_io_agent", u, loc);
    ppa::post_agent() = u;
}
inline void scamp5_bind_io_agent(vs_io_agent_api* p, ppa::Loc loc = PPA_HERE) {
    ppa::bind_agent("scamp5_bind_io_agent", p, loc);
    ppa::scamp5_agent() = p;
}
inline vs_io_agent_api* vs_post_get_io_agent(void) { return ppa::post_agent(); }
inline vs_io_agent_api* scamp5_get_io_agent() { return ppa::scamp5_agent(); }
// Waiting for an io agent to finish sending: output reaches the run's folder at once, so
// there is nothing to wait for (checked and recorded).
inline void vs_wait_io_agent(vs_io_agent_api* p, ppa::Loc loc = PPA_HERE) {
    ppa::bind_agent("vs_wait_io_agent", p, loc);
}
// Resting the chip (or its ADC) during a long wait on the M0: no meaning here (recorded).
inline void vs_vision_chip_rest(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_vision_chip_rest", false, {}, loc);
}
inline void vs_scamp5_rest(ppa::Loc loc = PPA_HERE) { ppa::call("vs_scamp5_rest", false, {}, loc); }
// The exposure accumulated so far is reset: PIX is reset (the rpix instruction).
inline void vs_vision_chip_reset_exposure(ppa::Loc loc = PPA_HERE) {
    if (ppa::active()) ppa::fail(loc, "vs_vision_chip_reset_exposure() is called inside a kernel");
    scamp5_kernel k;
    k.recording_start(loc.file, loc.line, true);
    const ppa::Arg* none[] = {nullptr};
    ppa::emit("rpix", loc, none, 0);
    k.recording_stop();
    k();
}

// The chip's DAC, clocks and calibration. The DAC: vs_scamp5_set_dac drives IN with the level
// of a 12-bit code, as scamp5_load_dac(code). The simulator's DAC, mid-point voltages and
// global sums are calibrated by construction and its clock is the timing model's:
// calibrating and clock settings are accepted and recorded (host.txt).
inline void vs_scamp5_set_dac(uint16_t dac12, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_scamp5_set_dac", false, int(dac12));
}
inline void vs_scamp5_calibrate_dac(int print_result = 0, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_scamp5_calibrate_dac", false, print_result);
}
inline void vs_scamp5_calibrate_mid(int print_result = 0, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_scamp5_calibrate_mid", false, print_result);
}
inline void vs_scamp5_calibrate_global_sum(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_scamp5_calibrate_global_sum", false, {}, loc);
}
inline void vs_scamp5_configure_clock(const uint8_t (*clock_setting)[8], ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_scamp5_configure_clock", false,
             ppa::Arg(clock_setting ? "a clock table" : "NULL: the default clocks"));
}

// An ICW, the chip's machine code: five 16-bit words of bits (SCAMP5_ICW_BITS positions
// 0-79), each in the low half of a port word that also holds its index (bits 16-18) and,
// in the first, the clock (bits 19-21). Built from bit positions or from the registers'
// fields, run with vs_scamp5_execute_icw.
namespace ppa::icw_bits {
using namespace SCAMP5_ICW_BITS;  // the bit names, for the instructions below
class scamp5_icw {
   public:
    uint32_t port_data[5];

    scamp5_icw() { clear_bits(); }
    scamp5_icw(uint8_t clock, const std::initializer_list<uint8_t>& bits) {
        clear_bits();
        set_bits(clock, bits);
    }
    scamp5_icw& clear_bits() {
        for (uint32_t k = 0; k < 5; ++k) port_data[k] = k << 16;
        return *this;
    }
    scamp5_icw& set_bits(uint8_t clock, const std::initializer_list<uint8_t>& bits) {
        port_data[0] = (port_data[0] & ~(7u << 19)) | (uint32_t(clock & 7) << 19);
        for (uint8_t b : bits) port_data[(b / 16) % 5] |= 1u << (b % 16);
        return *this;
    }
    scamp5_icw& set_sel(const aref_t& r) { return low32(r.sel_bits); }
    scamp5_icw& set_sel(const areg_t& r) { return low32(r.sel_bits); }
    scamp5_icw& set_W(const areg_t& r) { return low32(r.W_bits); }
    scamp5_icw& set_RR(const dref_t& r) { return word(r.RR_index, r.RR_bits); }
    scamp5_icw& set_RR(const dreg_t& r) { return word(r.RR_index, r.RR_bits); }
    scamp5_icw& set_LR(const dreg_t& r) { return word(r.LR_index, r.LR_bits); }
    scamp5_icw& nop() { return clear_bits(); }
    uint8_t clock() const { return uint8_t((port_data[0] >> 19) & 7); }

    // The instructions, each adding its bits to the word (start from a cleared one:
    // scamp5_icw().MOV(R6, R5)). Analogue: the bus and its variants.
    scamp5_icw& rpix() { return on({rstpix, selpix}); }
    scamp5_icw& aout(const aref_t& a) { return set_sel(a).on({ana}); }
    template <class... S>
    scamp5_icw& bus(const areg_t& a, const S&... srcs) {
        set_sel(a).set_W(a);
        (set_sel(aref_t(srcs)), ...);
        return *this;
    }
    scamp5_icw& bus(std::initializer_list<areg_t> dst, std::initializer_list<aref_t> src) {
        for (const areg_t& a : dst) set_sel(a).set_W(a);
        for (const aref_t& a : src) set_sel(a);
        return *this;
    }
    template <class... S>
    scamp5_icw& bus2(const areg_t& a, const areg_t& b, const S&... srcs) {
        set_sel(a).set_sel(b).set_W(a).set_W(b);
        (set_sel(aref_t(srcs)), ...);
        return *this;
    }
    scamp5_icw& bus3(const areg_t& a, const areg_t& b, const areg_t& c, const aref_t& a0) {
        return set_sel(a).set_sel(b).set_sel(c).set_W(a).set_W(b).set_W(c).set_sel(a0);
    }
    scamp5_icw& blurset() { return clk(SCAMP5_CLOCK_DIGITAL).set_RR(SCAMP5_PE::R1).set_RR(SCAMP5_PE::R2); }
    scamp5_icw& blur(const areg_t& a, const aref_t& a0) { return diffuse(a, a0).on({seldiffe, seldiffs}); }
    scamp5_icw& blurh(const areg_t& a, const aref_t& a0) { return diffuse(a, a0).on({seldiffe}); }
    scamp5_icw& blurv(const areg_t& a, const aref_t& a0) { return diffuse(a, a0).on({seldiffs}); }
    scamp5_icw& sq(const aref_t& a0, const aref_t& a1) {
        return set_sel(SCAMP5_PE::NEWS).set_W(SCAMP5_PE::NEWS).set_sel(a0).set_sel(a1).on({selsq});
    }
    template <class... S>
    scamp5_icw& where(const S&... srcs) {
        on({wrf});
        (set_sel(aref_t(srcs)), ...);
        return *this;
    }
    // Digital: the latch operations on the R registers and FLAG.
    template <class... S>
    scamp5_icw& WHERE(const S&... srcs) {
        clk(SCAMP5_CLOCK_DIGITAL).on({wrf, plrb, rid});
        (set_RR(dref_t(srcs)), ...);
        return *this;
    }
    scamp5_icw& all() { return on({setf, plrb, rid}); }
    template <class... D>
    scamp5_icw& SET(const D&... d) {
        clk(SCAMP5_CLOCK_DIGITAL).on({s_in, plwb});
        (set_LR(d), ...);
        return *this;
    }
    template <class... D>
    scamp5_icw& CLR(const D&... d) {
        latch();
        (set_LR(d), ...);
        return *this;
    }
    scamp5_icw& MOV(const dreg_t& d, const dref_t& d0) { return latch().set_LR(d).set_RR(d0); }
    template <class... S>
    scamp5_icw& OR(const dreg_t& d, const S&... srcs) {
        latch().set_LR(d);
        (set_RR(dref_t(srcs)), ...);
        return *this;
    }
    scamp5_icw& NOT(const dreg_t& d, const dref_t& d0) { return inverted().set_LR(d).set_RR(d0); }
    template <class... S>
    scamp5_icw& NOR(const dreg_t& d, const S&... srcs) {
        inverted().set_LR(d);
        (set_RR(dref_t(srcs)), ...);
        return *this;
    }
    scamp5_icw& REFRESH_R(const dreg_t& d) { return latch().set_RR(d); }
    scamp5_icw& REFRESH_L(const dreg_t& d) {
        return clk(SCAMP5_CLOCK_DIGITAL).on({s_in, bit, bitmode}).set_LR(d);
    }
    scamp5_icw& DNEWS0(const dreg_t& d, const dref_t& d0) { return dnews(d, d0); }
    scamp5_icw& DNEWS1(const dreg_t& d, const dref_t& d0) { return dnews(d, d0).on({pupd}); }
    scamp5_icw& PROP_R() { return on({s_in, RR12, plrb, bit, bitmode}); }
    scamp5_icw& PROP_0() { return clk(SCAMP5_CLOCK_PROP).on({s_in, RR12, LR12, fbus, rid, nb}); }
    scamp5_icw& PROP_1() { return PROP_0().on({pupd}); }

   private:
    scamp5_icw& on(std::initializer_list<uint8_t> bits) {
        for (uint8_t b : bits) port_data[(b / 16) % 5] |= 1u << (b % 16);
        return *this;
    }
    scamp5_icw& clk(uint8_t clock) {
        port_data[0] = (port_data[0] & ~(7u << 19)) | (uint32_t(clock & 7) << 19);
        return *this;
    }
    scamp5_icw& diffuse(const areg_t& a, const aref_t& a0) { return set_sel(a0).set_W(a).set_sel(a); }
    scamp5_icw& latch() { return clk(SCAMP5_CLOCK_DIGITAL).on({s_in, plrb, bit, bitmode}); }
    scamp5_icw& inverted() { return clk(SCAMP5_CLOCK_DIGITAL).on({s_in, plwb, plrb, nbit, bitmode}); }
    scamp5_icw& dnews(const dreg_t& d, const dref_t& d0) {
        return clk(SCAMP5_CLOCK_DNEWS).on({s_in, rid, nb, plrb, bit, fbus}).set_LR(d).set_RR(d0);
    }

    scamp5_icw& low32(uint32_t bits) {
        port_data[0] |= bits & 0xFFFFu;
        port_data[1] |= bits >> 16;
        return *this;
    }
    scamp5_icw& word(uint16_t index, uint16_t bits) {
        port_data[index % 5] |= bits;
        return *this;
    }
};
}  // namespace ppa::icw_bits
using ppa::icw_bits::scamp5_icw;

// Run a sequence of ICWs: one kernel of their raw words (each decoded by the simulator, so
// a word that matches no modelled instruction stops the run in one line). highspeed is
// recorded, as allow_highspeed is.
inline void vs_scamp5_execute_icw(const void* icw_addr, uint32_t icw_count, bool highspeed = false,
                                  ppa::Loc loc = PPA_HERE) {
    if (ppa::active()) ppa::fail(loc, "vs_scamp5_execute_icw() is called inside a kernel");
    if (!icw_addr && icw_count) ppa::fail(loc, "vs_scamp5_execute_icw: the ICW address is NULL");
    if (!icw_count) return;
    const scamp5_icw* words = static_cast<const scamp5_icw*>(icw_addr);
    scamp5_kernel k;
    k.recording_start(loc.file, loc.line, true);
    if (highspeed) ppa::call("allow_highspeed", false, {1}, loc);
    for (uint32_t i = 0; i < icw_count; ++i) {
        uint8_t bits[80];
        size_t n = 0;
        for (uint8_t b = 0; b < 80; ++b)
            if (words[i].port_data[b / 16] & (1u << (b % 16))) bits[n++] = b;
        ppa::emit_icw(&k, words[i].clock(), bits, n, loc);
    }
    k.recording_stop();
    k();
}

// Data posted to the host: kept with the frame and the channel (posts.json).
inline void vs_post_set_channel(uint32_t ch, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_post_set_channel", false, int(ch));
}
namespace ppa {
// The most bytes one posted array or drawn list carries (a 2048 x 2048 float array; the
// device's own memory holds far less): a size beyond it is a bad count, e.g. -1 made a size_t.
constexpr size_t MAX_POST_BYTES = size_t(1) << 24;
inline void check_bytes(const std::string& shown, size_t n, size_t item, const char* fix,
                        const Loc& loc) {
    if (n > MAX_POST_BYTES / item) {
        fail(loc, shown + ": more than a post carries (" + std::to_string(MAX_POST_BYTES) +
                      " bytes); give " + fix);
    }
}
template <typename T>
inline void post(const char* fn, const T* data, size_t rows, size_t cols, const Loc& loc) {
    std::string shown = std::string(fn) + "(" + std::to_string(rows) + " rows, " +
                        std::to_string(cols) + " cols)";
    const char* fix = "the array's rows and columns";
    check_bytes(shown, rows, sizeof(T), fix, loc);
    check_bytes(shown, cols, sizeof(T), fix, loc);
    check_bytes(shown, rows * cols, sizeof(T), fix, loc);
    if (!data && rows * cols) fail(loc, std::string(fn) + ": the data pointer is NULL");
    call(fn, false, {Arg(data, rows * cols * sizeof(T)), int(rows), int(cols)}, loc);
}
}  // namespace ppa
inline void vs_post_int8(const int8_t* data, size_t rows, size_t cols, ppa::Loc loc = PPA_HERE) {
    ppa::post("vs_post_int8", data, rows, cols, loc);
}
inline void vs_post_int16(const int16_t* data, size_t rows, size_t cols,
                          ppa::Loc loc = PPA_HERE) {
    ppa::post("vs_post_int16", data, rows, cols, loc);
}
inline void vs_post_int32(const int32_t* data, size_t rows, size_t cols,
                          ppa::Loc loc = PPA_HERE) {
    ppa::post("vs_post_int32", data, rows, cols, loc);
}
inline void vs_post_float(const float* data, size_t rows, size_t cols, ppa::Loc loc = PPA_HERE) {
    ppa::post("vs_post_float", data, rows, cols, loc);
}

// Displays drawn as graphs of posted data: checked and recorded.
inline vs_handle vs_gui_set_scope(vs_handle h, int32_t min, int32_t max, uint16_t time,
                                  uint16_t opt = 0, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("vs_gui_set_scope", true, h, min, max, int(time), int(opt)));
}
inline vs_handle vs_gui_set_barplot(vs_handle h, int32_t min, int32_t max, uint16_t width,
                                    uint16_t opt = 0, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(PPA_CALL("vs_gui_set_barplot", true, h, min, max, int(width), int(opt)));
}
inline vs_handle vs_gui_set_lineplot(vs_handle h, int32_t min, int32_t max, uint16_t format = 0,
                                     uint16_t opt = 0, ppa::Loc loc = PPA_HERE) {
    return ppa::as_int(
        PPA_CALL("vs_gui_set_lineplot", true, h, min, max, int(format), int(opt)));
}
// The host saving every display's data for one loop iteration: the run's folder keeps
// every frame's already (recorded).
inline void vs_gui_save_snapshots(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_gui_save_snapshots", false, {}, loc);
}
inline void vs_gui_save_image(vs_handle h, const char* filepath, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_gui_save_image", false, h, ppa::Arg(filepath));
}

// Host graphics: an image or a text over a display.
struct vs_gui_imageformat_t {
    uint16_t pixel_bytes : 4;
    uint16_t is_bottom_to_top : 1;
    uint16_t is_right_to_left : 1;
    uint16_t is_column_major : 1;
    uint16_t is_channel_array : 1;
};
inline void vs_gui_display_image(vs_handle display, const uint8_t* buffer, uint8_t w, uint8_t h,
                                 vs_gui_imageformat_t format = {1, 0, 0, 0, 0},
                                 ppa::Loc loc = PPA_HERE) {
    if (!buffer) ppa::fail(loc, "vs_gui_display_image: the buffer is NULL");
    int fmt = format.pixel_bytes | format.is_bottom_to_top << 4 | format.is_right_to_left << 5 |
              format.is_column_major << 6 | format.is_channel_array << 7;
    size_t n = size_t(w) * h * (format.pixel_bytes ? format.pixel_bytes : 1);
    PPA_CALL("vs_gui_display_image", false, display, ppa::Arg(buffer, n), int(w), int(h), fmt);
}
inline void vs_gui_display_text(vs_handle display, int16_t c, int16_t r, const char* str,
                                std::array<uint8_t, 4> color = {255, 255, 255, 255},
                                ppa::Loc loc = PPA_HERE) {
    int rgba = color[0] | color[1] << 8 | color[2] << 16 | int(uint32_t(color[3]) << 24);
    PPA_CALL("vs_gui_display_text", false, display, int(c), int(r), ppa::Arg(str), rgba);
}
// The drawing callback runs at once (its display_* calls are served as they come); the
// vs_gui_graphics_api calls inside it are checked and recorded (host.txt), as texts over a
// display are.
namespace ppa {
inline bool& in_graphics() {
    static bool on = false;
    return on;
}
}  // namespace ppa
inline void vs_gui_display_graphics(vs_handle display, std::function<void(void)> f) {
    (void)display;
    ppa::in_graphics() = true;
    if (f) f();
    ppa::in_graphics() = false;
}
namespace ppa {
inline void draw(const char* fn, std::initializer_list<Arg> args, const Loc& loc) {
    if (!in_graphics()) {
        fail(loc, std::string("vs_gui_graphics_api::") + fn +
                      " draws over a display: call it inside the callback of "
                      "vs_gui_display_graphics");
    }
    call((std::string("vs_gui_graphics_api::") + fn).c_str(), false, args, loc);
}
}  // namespace ppa
namespace vs_gui_graphics_api {
inline void m_push(ppa::Loc loc = PPA_HERE) { ppa::draw("m_push", {}, loc); }
inline void m_pop(ppa::Loc loc = PPA_HERE) { ppa::draw("m_pop", {}, loc); }
inline void m_translate(int16_t x, int16_t y, ppa::Loc loc = PPA_HERE) {
    ppa::draw("m_translate", {int(x), int(y)}, loc);
}
inline void m_rotate(int16_t deg, ppa::Loc loc = PPA_HERE) { ppa::draw("m_rotate", {int(deg)}, loc); }
inline void m_rotate_atan2(int16_t y, int16_t x, ppa::Loc loc = PPA_HERE) {
    ppa::draw("m_rotate_atan2", {int(y), int(x)}, loc);
}
inline void m_scale(int16_t x, int16_t y, int16_t den, ppa::Loc loc = PPA_HERE) {
    if (den == 0) ppa::fail(loc, "vs_gui_graphics_api::m_scale: the denominator is 0");
    ppa::draw("m_scale", {int(x), int(y), int(den)}, loc);
}
inline void m_scale(float x, float y, ppa::Loc loc = PPA_HERE) {
    char text[64];
    std::snprintf(text, sizeof text, "%g, %g", double(x), double(y));
    ppa::draw("m_scale", {ppa::Arg(text)}, loc);
}
inline void set_color(uint8_t r, uint8_t g, uint8_t b, uint8_t a = 255, ppa::Loc loc = PPA_HERE) {
    ppa::draw("set_color", {int(r), int(g), int(b), int(a)}, loc);
}
inline void set_color(const std::array<uint8_t, 4>& rgba, ppa::Loc loc = PPA_HERE) {
    set_color(rgba[0], rgba[1], rgba[2], rgba[3], loc);
}
inline void set_linewidth(int16_t w, int16_t den = 1, ppa::Loc loc = PPA_HERE) {
    if (den == 0) ppa::fail(loc, "vs_gui_graphics_api::set_linewidth: the denominator is 0");
    ppa::draw("set_linewidth", {int(w), int(den)}, loc);
}
inline void set_pointsize(int16_t w, int16_t den = 1, ppa::Loc loc = PPA_HERE) {
    if (den == 0) ppa::fail(loc, "vs_gui_graphics_api::set_pointsize: the denominator is 0");
    ppa::draw("set_pointsize", {int(w), int(den)}, loc);
}
inline void draw_point(int16_t x0, int16_t y0, ppa::Loc loc = PPA_HERE) {
    ppa::draw("draw_point", {int(x0), int(y0)}, loc);
}
inline void draw_line(int16_t x0, int16_t y0, int16_t x1, int16_t y1, ppa::Loc loc = PPA_HERE) {
    ppa::draw("draw_line", {int(x0), int(y0), int(x1), int(y1)}, loc);
}
inline void draw_rect(int16_t x0, int16_t y0, int16_t x1, int16_t y1, ppa::Loc loc = PPA_HERE) {
    ppa::draw("draw_rect", {int(x0), int(y0), int(x1), int(y1)}, loc);
}
inline void draw_circle(int16_t x0, int16_t y0, int16_t radius, int16_t n_segments = 24,
                        ppa::Loc loc = PPA_HERE) {
    ppa::draw("draw_circle", {int(x0), int(y0), int(radius), int(n_segments)}, loc);
}
}  // namespace vs_gui_graphics_api

// A dot-matrix image (1 bit a pixel, rows of w/8 bytes) on a buffer the program binds.
class vs_dotmat {
   public:
    static size_t get_buffer_size(uint16_t w, uint16_t h) { return size_t(w) * h / 8; }
    void bind_buffer(void* mem, uint16_t w, uint16_t h) {
        dotmap_ = static_cast<uint8_t*>(mem);
        w_ = w;
        h_ = h;
    }
    void* get_buffer(size_t* size = NULL) const {
        if (size) *size = get_buffer_size(w_, h_);
        return dotmap_;
    }
    uint16_t get_width() const { return w_; }
    uint16_t get_height() const { return h_; }

   private:
    uint8_t* dotmap_ = nullptr;
    uint16_t w_ = 0, h_ = 0;
};

// Requests to the host for a file or an image. The host here holds no files for the
// program: a request is recorded (host.txt) and, at the next vs_frame_loop_control or
// vs_process_message, ends as a request that timed out: an image request's callback gets
// an empty image and a negative status (the device's "not received in time"); a file
// request's callback is not called (no chunk arrives). One request at a time, as on the
// device: another while one is under way returns non-zero.
namespace ppa {
inline bool& request_pending() {
    static bool on = false;
    return on;
}
inline int request(const char* fn, const char* filepath, int extra, uint32_t timeout,
                   std::function<void(void)> answer, const Loc& loc) {
    if (!filepath) fail(loc, std::string(fn) + ": the file path is NULL");
    if (request_pending()) return 1;
    call(fn, false, {Arg(filepath), extra, int(timeout)}, loc);
    request_pending() = true;
    hooks().request = [answer] {
        request_pending() = false;
        if (answer) answer();
    };
    return 0;
}
}  // namespace ppa
inline int vs_gui_request_file(const char* filepath,
                               std::function<void(const uint8_t*, size_t, size_t)> cb,
                               uint32_t timeout_msec = 1000, ppa::Loc loc = PPA_HERE) {
    (void)cb;
    return ppa::request("vs_gui_request_file", filepath, 0, timeout_msec, nullptr, loc);
}
inline int vs_gui_request_image(const char* filepath, int bits,
                                std::function<void(vs_dotmat const&, int)> cb,
                                uint32_t timeout_msec = 1000, ppa::Loc loc = PPA_HERE) {
    if (bits < 1 || bits > 8) ppa::fail(loc, "vs_gui_request_image: bits per pixel must be 1 to 8");
    return ppa::request("vs_gui_request_image", filepath, bits, timeout_msec, [cb] {
        if (cb) cb(vs_dotmat(), -1);
    }, loc);
}
inline bool vs_gui_request_done() { return !ppa::request_pending(); }

// Outputs of a register other than its whole image, drawn on a display.
inline void scamp5_output_areg(ASRC areg, vs_handle display, int s = 1, int r0 = 0, int c0 = 0,
                               ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_areg", false, areg, display, s, r0, c0);
}
inline void scamp5_output_events(DSRC dreg, vs_handle display, uint16_t max_num = 1000,
                                 uint8_t h_dir = 0, uint8_t v_dir = 0, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("scamp5_output_events", false, dreg, display, int(max_num), int(h_dir), int(v_dir));
}
inline void scamp5_output_boundingbox(DSRC dr, vs_handle display, uint8_t* result = NULL,
                                      ppa::Loc loc = PPA_HERE) {
    ppa_fill(PPA_CALL("scamp5_output_boundingbox", true, dr, display), result);
}
// Data the program computed, drawn on a display: boxes (4 bytes each, the layout of
// scamp5_scan_boundingbox), events ((column, row) pairs) and byte images.
inline void scamp5_display_boundingbox(vs_handle display, const uint8_t* vec4v, size_t count,
                                       ppa::Loc loc = PPA_HERE) {
    if (!vec4v && count) ppa::fail(loc, "scamp5_display_boundingbox: the buffer is NULL");
    ppa::check_bytes("scamp5_display_boundingbox(" + std::to_string(count) + " boxes)", count, 4,
                     "the number of boxes in the buffer", loc);
    PPA_CALL("scamp5_display_boundingbox", false, display, ppa::Arg(vec4v, 4 * count),
             int(count));
}
inline void scamp5_display_events(vs_handle display, const uint8_t* vec2v, size_t count,
                                  ppa::Loc loc = PPA_HERE) {
    if (!vec2v && count) ppa::fail(loc, "scamp5_display_events: the buffer is NULL");
    ppa::check_bytes("scamp5_display_events(" + std::to_string(count) + " events)", count, 2,
                     "the number of events in the buffer", loc);
    PPA_CALL("scamp5_display_events", false, display, ppa::Arg(vec2v, 2 * count), int(count));
}
inline void scamp5_display_image(vs_handle display, const uint8_t* buffer, uint8_t w, uint8_t h,
                                 ppa::Loc loc = PPA_HERE) {
    if (!buffer) ppa::fail(loc, "scamp5_display_image: the buffer is NULL");
    PPA_CALL("scamp5_display_image", false, display, ppa::Arg(buffer, size_t(w) * h), int(w),
             int(h));
}
inline void scamp5_display_image_patch(vs_handle display, const uint8_t* buffer, uint8_t w,
                                       uint8_t h, uint8_t r0, uint8_t c0,
                                       ppa::Loc loc = PPA_HERE) {
    if (!buffer) ppa::fail(loc, "scamp5_display_image_patch: the buffer is NULL");
    PPA_CALL("scamp5_display_image_patch", false, display, ppa::Arg(buffer, size_t(w) * h),
             int(w), int(h), int(r0), int(c0));
}

// The device simulator's own controls: this is a simulation; the rest is accepted and
// recorded (the noise model is the run's --noise preset, the frames its --image/--dataset).
namespace vs_sim {
inline bool is_simulation() { return true; }
inline void config(const char* field, const char* value, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::config", false, ppa::Arg(field), ppa::Arg(value));
}
inline void enable_keyboard_control(ppa::Loc loc = PPA_HERE) {
    ppa::call("vs_sim::enable_keyboard_control", false, {}, loc);
}
inline void reset_model(uint32_t level, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::reset_model", false, int(level));
}
inline void pix_integrate(uint16_t increment_num, uint16_t increment_den,
                          ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::pix_integrate", false, int(increment_num), int(increment_den));
}
inline void save_image(ASRC areg, const char* filepath, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::save_image", false, areg, ppa::Arg(filepath));
}
inline void save_image(DSRC dreg, const char* filepath, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::save_image", false, dreg, ppa::Arg(filepath));
}
inline void reset_video(int16_t arg = 0, ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::reset_video", false, int(arg));
}
inline void use_subpix(uint16_t r_check, uint16_t c_check, uint16_t div,
                       ppa::Loc loc = PPA_HERE) {
    PPA_CALL("vs_sim::use_subpix", false, int(r_check), int(c_check), int(div));
}
}  // namespace vs_sim
#define scamp5_sim vs_sim
