// Links nightloc::core from an installed package and matches a rolled image.
#include <cstdio>
#include <cstdlib>

#include <nightloc/nightloc.hpp>

int main() {
    nightloc::ImageStack refs(3, 4, 16);
    for (nightloc::Index i = 0; i < refs.count(); ++i)
        for (nightloc::Index p = 0; p < refs.pixels.cols(); ++p)
            refs.pixels(i, p) = static_cast<std::uint8_t>((p * 37 + i * 101) % 251);
    nightloc::ImageU8 query(4, 16);
    for (nightloc::Index r = 0; r < 4; ++r)
        for (nightloc::Index c = 0; c < 16; ++c) query(r, (c + 6) % 16) = refs.image(1)(r, c);
    const auto result = nightloc::match(query, refs);
    std::printf("consumer: best %ld, shift %d, path %s\n", static_cast<long>(result.best), result.shifts[result.best],
                nightloc::simd_backend_name(nightloc::active_simd_backend()));
    return result.best == 1 && result.shifts[1] == 6 ? EXIT_SUCCESS : EXIT_FAILURE;
}
