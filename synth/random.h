// Internal to synth/ (namespace synth_internal): the seeded generator of the sensor noise (both chains).
#pragma once

#include <cmath>
#include <cstdint>

namespace curvecheck::synth_internal {

// SplitMix64's output function: a bijective 64-bit mix.
inline uint64_t Mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// SplitMix64 (Steele, Lea, Flood 2014): a small, fast generator, one stream per row seeded from (seed, row).
struct SplitMix64 {
  uint64_t state;
  uint64_t Next() { return Mix64(state += 0x9E3779B97F4A7C15ull); }
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }  // [0, 1)
  // Standard normal by Marsaglia's polar method (two per accepted pair; the second is kept).
  double Normal() {
    if (has_spare) {
      has_spare = false;
      return spare;
    }
    double a, b, r2;
    do {
      a = 2 * Uniform() - 1;
      b = 2 * Uniform() - 1;
      r2 = a * a + b * b;
    } while (r2 >= 1 || r2 == 0);
    const double f = std::sqrt(-2 * std::log(r2) / r2);
    spare = b * f;
    has_spare = true;
    return a * f;
  }
  // Poisson by Knuth's product of uniforms (for small means only: about mean + 1 uniforms).
  int Poisson(double mean) {
    const double limit = std::exp(-mean);
    int n = 0;
    for (double p = Uniform(); p > limit; p *= Uniform()) ++n;
    return n;
  }
  double spare = 0;
  bool has_spare = false;
};

// The stream of row `row` of the noise field `field` (0: the temporal noise, 1: the fixed PRNU pattern) for
// `seed`. The start is hashed: consecutive multiples of the increment would make each row the previous row's
// stream shifted by one number.
inline SplitMix64 RowStream(uint64_t seed, int row, uint64_t field = 0) {
  return SplitMix64{Mix64(seed ^ Mix64(static_cast<uint64_t>(row) + 0x632BE59BD9B4E019ull + field * 0x9E3779B97F4A7C15ull))};
}

// Electrons after shot and read noise: Poisson-Gaussian. Above 20 e the shot noise is Gaussian, and the sum of
// the two Gaussians is one Gaussian of variance e + read^2; below, Poisson plus read noise.
inline double NoisyElectrons(double electrons, double read_noise_e, SplitMix64& rng) {
  electrons = electrons > 0 ? electrons : 0.0;
  return electrons > 20 ? electrons + std::sqrt(electrons + read_noise_e * read_noise_e) * rng.Normal()
                        : rng.Poisson(electrons) + read_noise_e * rng.Normal();
}

}  // namespace curvecheck::synth_internal
