#include <chrono>
#include <cstdio>
#include "core/transform/sht.h"
using namespace shrm;
int main() {
  for (int lmax : {392, 511, 241}) {
    auto t0 = std::chrono::steady_clock::now();
    auto p = GetShtPlan(ShtGrid{1024, 512, ShtGridKind::kEquiangular}, lmax, 3, ShtQuadrature::kPixelSum);
    auto t1 = std::chrono::steady_clock::now();
    std::printf("plan %d: %.2f ms\n", lmax, std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
}
