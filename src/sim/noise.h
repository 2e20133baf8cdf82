// Seeded, reproducible noise for the simulated plants.
//
// The generator is our own (splitmix64 seeding a xoshiro256**), not a
// std:: distribution, so a seed gives the same sequence with any standard
// library. Gaussian samples use the Box-Muller transform on top of it.
// Host code only; not thread-safe (one Noise per plant).
#ifndef CONTEGO_SIM_NOISE_H_
#define CONTEGO_SIM_NOISE_H_

#include <cstdint>

namespace contego::sim {

class Noise {
 public:
  explicit Noise(uint64_t seed);

  uint64_t next_u64();
  // Uniform in [0, 1).
  double uniform();
  // Uniform integer in [lo, hi] (inclusive). REQUIRES: lo <= hi.
  int64_t uniform_int(int64_t lo, int64_t hi);
  // Normal with mean 0 and standard deviation `sigma`.
  double gaussian(double sigma);

 private:
  uint64_t s_[4];
  bool have_spare_ = false;
  double spare_ = 0.0;
};

// Derives an independent stream for a named component from a scenario seed,
// so adding noise to one plant does not shift the numbers another one sees.
uint64_t derive_seed(uint64_t seed, uint64_t stream);

}  // namespace contego::sim

#endif  // CONTEGO_SIM_NOISE_H_
