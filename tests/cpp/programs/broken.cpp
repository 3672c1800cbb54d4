#include <scamp5.hpp>
using namespace SCAMP5_PE;

int main() {
    vs_init();
    int x = undefined_name + 1;
    return x;
}
