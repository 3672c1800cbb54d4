// Programs that go wrong, one per "fault" slider value (tests/cpp/test_errors.py).
#include <climits>
#include <scamp5.hpp>
using namespace SCAMP5_PE;

void divide_every_form(int index);  // x86-64 only: below

int main() {
    vs_init();
    int fault = 0, index = 0, gain = 0;
    vs_gui_add_slider("fault", 0, 9, 0, &fault);
    vs_gui_add_slider("index", 0, 100000, 0, &index); vs_gui_add_slider("gain: ", 0, 9, 0, &gain);
    vs_handle disp = vs_gui_add_display("image", 0, 0);
    while (1) {
        vs_frame_loop_control();
        scamp5_kernel_begin();
            get_image(A);
        scamp5_kernel_end();
        scamp5_output_image(A, disp);
        if (fault == 1) {
            while (1) {}  // hangs
        } else if (fault == 2) {
            volatile uint8_t buffer[16];
            buffer[index] = 1;  // out of bounds for index >= 16
            vs_post_text("%d", buffer[0]);
        } else if (fault == 3) {
            scamp5_kernel_begin();
                sub(A, B, A);
            scamp5_kernel_end();
        } else if (fault == 4) {
            using namespace scamp5_kernel_api;
            mov(A, B);  // a kernel function outside a kernel
        } else if (fault == 5) {
            scamp5_load_point(R5, 200, 3);  // beyond a 64 x 64 array
        } else if (fault == 6) {
            volatile int* p = nullptr;
            *p = 1;
        } else if (fault == 7) {
            volatile int zero = index;
            vs_post_text("%d %d", 100 / zero, 100 % zero);  // by zero for index 0
        } else if (fault == 8) {  // the device wraps: INT_MIN / -1 is INT_MIN (for index 0)
            volatile int int_min = INT_MIN, minus_one = index - 1;
            volatile long long llong_min = LLONG_MIN, minus_one_ll = index - 1;
            vs_post_text("%d %d %lld %lld", int_min / minus_one, int_min % minus_one,
                         llong_min / minus_one_ll, llong_min % minus_one_ll);
        } else if (fault == 9) {
#if defined(__x86_64__)
            divide_every_form(index);
#endif
        }
    }
}

#if defined(__x86_64__)
// x86-64 division instructions of every operand form (fault 9): "RAX RDX" after each, in hex.
static int rip_minus_one = -1;               // a RIP-relative operand
static thread_local int tls_minus_one = -1;  // an FS-relative operand (thread-local)
#define DIVIDE(INSN, RAX, RDX, ...)                                                   \
    do {                                                                             \
        uint64_t rax = RAX, rdx = RDX;                                               \
        asm volatile(INSN : "+a"(rax), "+d"(rdx) : __VA_ARGS__ : "cc");              \
        vs_post_text("%016llx %016llx", (unsigned long long)rax, (unsigned long long)rdx); \
    } while (0)
void divide_every_form(int index) {
    volatile int16_t minus_one16 = int16_t(index - 1), zero16 = int16_t(index);
    volatile int32_t minus_one32 = index - 1, zero32 = index;
    const int32_t table[3] = {7, index - 1, 9};
    register const int32_t* base asm("r13") = table;  // callee-saved, as r12 and r15
    register int64_t at asm("r12") = 2;
    register int64_t minus_one64 asm("r15") = index - 1;  // callee-saved: kept across calls
    // INT16_MIN / -1 in DX:AX (a register): AX INT16_MIN, DX 0; the rest of RAX, RDX kept
    DIVIDE("idivw %w2", 0x1111222233338000, 0xAAAABBBBCCCCFFFF, "r"(int16_t(minus_one16)));
    // 100 / 0 in DX:AX (a register): AX 0, DX 100; the rest kept
    DIVIDE("idivw %w2", 0x1111222233330064, 0xAAAABBBBCCCC0000, "r"(int16_t(zero16)));
    // INT_MIN / -1, a stack operand (disp8): EAX INT_MIN, EDX 0, zero-extended
    DIVIDE("idivl %2", 0x1111222280000000, 0xAAAABBBBFFFFFFFF, "m"(minus_one32));
    // INT_MIN / -1, table[at - 1] with REX.X and REX.B (r13 + r12 * 4 - 4)
    DIVIDE("idivl -4(%2,%3,4)", 0x80000000, 0xFFFFFFFF, "r"(base), "r"(at));
    // LLONG_MIN / -1 in R15 (REX.W, REX.B): RAX LLONG_MIN, RDX 0
    DIVIDE("idivq %2", 0x8000000000000000, 0xFFFFFFFFFFFFFFFF, "r"(minus_one64));
    // INT_MIN / -1, RIP-relative and FS-relative
    DIVIDE("idivl %2", 0x80000000, 0xFFFFFFFF, "m"(rip_minus_one));
    DIVIDE("idivl %2", 0x80000000, 0xFFFFFFFF, "m"(tls_minus_one));
    // -128 / -1 by CH (bytewise, no REX): AL -128, AH 0; RDX kept
    DIVIDE("idivb %%ch", 0x111122223333FF80, 0x5, "c"(uint64_t(uint8_t(index - 1)) << 8));
    // 100 / 0 by SIL (bytewise with REX; DH is 1): AL 0, AH 100
    DIVIDE("idivb %%sil", 0x1111222233330064, 0x100, "S"(uint64_t(index) << 8 | index));
    // unsigned 100 / 0, a stack operand: EAX 0, EDX 100, zero-extended
    DIVIDE("divl %2", 0x1111222200000064, 0xAAAABBBB00000000, "m"(zero32));
    // Quotients too wide that no C division gives: their low bits, the exact remainder.
    // -(2^33 + 7) / -2 (EDX:EAX): 2^32 + 3 remainder -1, so EAX 3, EDX -1
    DIVIDE("idivl %2", 0xFFFFFFF9, 0xFFFFFFFD, "r"(int32_t(minus_one32 * 2)));
    // unsigned 0xFFFFFFFF00000005 / 0xFFFFFFFE: 0x100000001 remainder 7, so EAX 1, EDX 7
    DIVIDE("divl %2", 0x00000005, 0xFFFFFFFF, "r"(uint32_t(0xFFFFFFFE - index)));
}
#endif
