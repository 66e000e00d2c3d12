// nightloc C++ example: build a small synthetic map of 50 panoramas, rotate one of them by a
// known number of columns, and find it again with the rotation-invariant matcher.
//
//   cmake -S cpp -B build/cpp && cmake --build build/cpp && ./build/cpp/nightloc_example
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <nightloc/nightloc.hpp>

int main() {
    const nightloc::Index n_refs = 50, height = 24, width = 48;
    nightloc::ImageStack refs(n_refs, height, width);
    // Smooth, distinct panoramas: a few sinusoids whose phases depend on the place.
    for (nightloc::Index i = 0; i < n_refs; ++i) {
        auto image = refs.image(i);
        for (nightloc::Index r = 0; r < height; ++r) {
            for (nightloc::Index c = 0; c < width; ++c) {
                const double a = 2.0 * M_PI * static_cast<double>(c) / static_cast<double>(width);
                const double v = 128.0 + 60.0 * std::sin(3.0 * a + 0.37 * static_cast<double>(i)) +
                                 40.0 * std::cos(a + 0.11 * static_cast<double>(i * i)) +
                                 20.0 * std::sin(0.4 * static_cast<double>(r) + static_cast<double>(i));
                image(r, c) = static_cast<std::uint8_t>(std::lround(std::fmin(255.0, std::fmax(0.0, v))));
            }
        }
    }
    const nightloc::ImageStack prepared = nightloc::patch_normalize(refs);  // radius 4, wrap-around

    // The robot at place 17, turned: its panorama is place 17 rolled right by 5 columns.
    const nightloc::Index place = 17, turn = 5;
    nightloc::ImageU8 query(height, width);
    for (nightloc::Index r = 0; r < height; ++r)
        for (nightloc::Index c = 0; c < width; ++c) query(r, (c + turn) % width) = prepared.image(place)(r, c);

    const nightloc::MatchResult result = nightloc::match(query, prepared);
    const double heading = 2.0 * M_PI * result.shifts[result.best] / static_cast<double>(width);
    const nightloc::SimdBackend path = nightloc::active_simd_backend();  // NIGHTLOC_SIMD=<name> forces one
    std::printf("SIMD path: %s\n", nightloc::simd_backend_name(path));
    std::printf("best reference: %ld (score %.3f), shift %d columns = relative heading %.3f rad\n",
                static_cast<long>(result.best), static_cast<double>(result.scores[result.best]),
                result.shifts[result.best], heading);
    const bool ok = result.best == place && result.shifts[result.best] == turn && result.scores[result.best] == 0.0f;
    std::printf("%s\n", ok ? "OK" : "UNEXPECTED RESULT");
    return ok ? EXIT_SUCCESS : EXIT_FAILURE;
}
