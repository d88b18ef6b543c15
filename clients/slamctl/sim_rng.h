// Rng: the random numbers of `slamctl sim`'s worlds (sim_world.h, sim_camera_world.h), the same on
// every platform. std::mt19937_64's raw output is fixed by the standard; the conversions to
// uniform and normal numbers are ours, never the <random> distributions (their algorithms differ
// between standard libraries). Not thread-safe: one generator per world.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace slamd::clients::sim {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double Uniform(double a, double b) { return a + (b - a) * Uniform(); }
  int Index(int n) { return static_cast<int>(engine_() % static_cast<std::uint64_t>(n)); }
  // Box–Muller: two independent N(0, 1) per pair of uniforms; the second is kept for next time.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - Uniform();  // (0, 1]: log is finite
    const double u2 = Uniform();
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * std::numbers::pi * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace slamd::clients::sim
