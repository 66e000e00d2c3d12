// nightloc C++ example: the per-frame path of a robot, without Python or OpenCV. A 3 x 3 lattice
// of reference places (1 m apart) is mapped from synthetic 192 x 96 BGR panoramas; the robot
// then drives along the middle row in 0.25 m steps, its camera frames darker and noisier than
// the map's. Each frame is prepared (nightloc::prepare_frame), matched against the map, turned
// into a heat map over a 21 x 21 grid and fused with the earlier frames moved by odometry
// (nightloc::HeatSequence), and the hottest cell is the position estimate.
//
//   cmake -S cpp -B build/cpp && cmake --build build/cpp && ./build/cpp/nightloc_localize_example
//
// The heat-map weights here give every cell its nearest place (a valid CSR matrix, simple to
// write down); nightloc's Python HeatMapper computes linear-interpolation weights over a
// Delaunay triangulation (HeatMapper.weights), which a robot can load instead.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include <nightloc/heatmap.hpp>
#include <nightloc/nightloc.hpp>
#include <nightloc/prepare.hpp>

namespace {

constexpr std::size_t kFrameHeight = 96, kFrameWidth = 192;

// A BGR panorama of the place at (x, y) metres: smooth bands whose phases depend on the place,
// scaled by `gain` (night) with noise.
std::vector<std::uint8_t> panorama(double x, double y, double gain, std::mt19937& rng) {
    std::normal_distribution<double> noise(0.0, gain < 1.0 ? 2.0 : 0.0);
    std::vector<std::uint8_t> frame(kFrameHeight * kFrameWidth * 3);
    for (std::size_t r = 0; r < kFrameHeight; ++r) {
        for (std::size_t c = 0; c < kFrameWidth; ++c) {
            const double a = 2.0 * M_PI * static_cast<double>(c) / static_cast<double>(kFrameWidth);
            const double v = 120.0 + 50.0 * std::sin(2.0 * a + 1.3 * x + 0.4 * y) + 40.0 * std::cos(3.0 * a - 0.9 * y) +
                             25.0 * std::sin(0.15 * static_cast<double>(r) + x * y);
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const double value = gain * v * (0.9 + 0.1 * static_cast<double>(ch)) + noise(rng);
                frame[(r * kFrameWidth + c) * 3 + ch] =
                    static_cast<std::uint8_t>(std::lround(std::fmin(255.0, std::fmax(0.0, value))));
            }
        }
    }
    return frame;
}

}  // namespace

int main() {
    // every path gives the same results; NIGHTLOC_SIMD=<name> forces one (e.g. scalar, neon)
    std::printf("SIMD path: %s\n", nightloc::simd_backend_name(nightloc::active_simd_backend()));
    std::mt19937 rng(7);
    // --- the map: 9 places, prepared once
    std::vector<std::pair<double, double>> places;
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) places.emplace_back(i, j);
    const nightloc::PrepareSettings settings;  // 48 x 24, equalized, patch-normalized (Table II)
    nightloc::PrepareWorkspace workspace;      // reused by every frame: no allocation per frame
    nightloc::ImageStack refs(static_cast<nightloc::Index>(places.size()), 24, 48);
    for (std::size_t p = 0; p < places.size(); ++p) {
        const auto frame = panorama(places[p].first, places[p].second, 1.0, rng);
        nightloc::prepare_frame({frame.data(), kFrameHeight, kFrameWidth, kFrameWidth * 3, nightloc::PixelOrder::bgr},
                                settings, refs.pixels.row(static_cast<nightloc::Index>(p)).data(), workspace);
    }

    // --- the grid: 21 x 21 cells from -0.25 to 2.25 m, each weighted to its nearest place
    const std::size_t cells = 21;
    const double x0 = -0.25, step = 0.125;
    std::vector<std::int32_t> indptr{0}, indices;
    std::vector<float> data;
    for (std::size_t j = 0; j < cells; ++j) {
        for (std::size_t i = 0; i < cells; ++i) {
            const double x = x0 + step * static_cast<double>(i), y = x0 + step * static_cast<double>(j);
            std::size_t nearest = 0;
            for (std::size_t p = 1; p < places.size(); ++p) {
                if (std::hypot(places[p].first - x, places[p].second - y) <
                    std::hypot(places[nearest].first - x, places[nearest].second - y))
                    nearest = p;
            }
            indices.push_back(static_cast<std::int32_t>(nearest));
            data.push_back(1.f);
            indptr.push_back(static_cast<std::int32_t>(indices.size()));
        }
    }
    auto weights = std::make_shared<nightloc::HeatWeights>(cells, cells, places.size(), indptr, indices, data);
    nightloc::HeatSequence sequence(weights, 4);  // the last 4 frames
    nightloc::PeakExclusion exclusion;            // the runner-up: farther than 1 m (8 cells) from the peak
    exclusion.rows = exclusion.cols = 8;
    exclusion.mask.resize(17 * 17);
    for (int a = -8; a <= 8; ++a)
        for (int b = -8; b <= 8; ++b) {
            exclusion.mask[static_cast<std::size_t>((a + 8) * 17 + b + 8)] = a * a + b * b <= 64;
        }

    // --- the drive: along y = 1 from x = 0 to 2, night frames, odometry 0.25 m per frame
    int wrong = 0;
    std::vector<double> odometry_steps;  // x displacement (m) between consecutive frames
    std::vector<std::uint8_t> query(24 * 48);
    for (int t = 0; t <= 8; ++t) {
        const double x = 0.25 * t, y = 1.0;
        const auto frame = panorama(x, y, 0.35, rng);
        nightloc::prepare_frame({frame.data(), kFrameHeight, kFrameWidth, kFrameWidth * 3, nightloc::PixelOrder::bgr},
                                settings, query.data(), workspace);
        const nightloc::MatchResult match =
            nightloc::match(Eigen::Map<const nightloc::ImageU8>(query.data(), 24, 48), refs);
        // heat: scores inverted to (max - s) / (max - min), minus the frame's lowest heat (0)
        const float hi = match.scores.maxCoeff(), lo = match.scores.minCoeff();
        std::vector<float> values(places.size());
        for (std::size_t p = 0; p < places.size(); ++p)
            values[p] = hi > lo ? (hi - match.scores[static_cast<nightloc::Index>(p)]) / (hi - lo) : 0.f;
        sequence.push(values.data(), 0.0);
        if (t > 0) odometry_steps.push_back(0.25);
        // offsets (cells) of the earlier frames in the sequence, oldest first
        std::vector<double> offsets;
        const std::size_t earlier = sequence.size() - 1;
        for (std::size_t k = 0; k < earlier; ++k) {
            double dx = 0;
            for (std::size_t m = odometry_steps.size() - earlier + k; m < odometry_steps.size(); ++m) {
                dx += odometry_steps[m];
            }
            offsets.insert(offsets.end(), {dx / step, 0.0});
        }
        sequence.fuse(offsets.data());
        const nightloc::HeatPeak peak = nightloc::find_peak(sequence.fused(), cells, cells, exclusion);
        // with nearest-place weights the estimate is the place whose region holds the hottest cell
        const auto& place = places[static_cast<std::size_t>(indices[peak.cell])];
        const double confidence = peak.has_second ? (peak.peak - peak.second) / (peak.peak - peak.floor) : 1.0;
        const bool right = place.second == y && std::fabs(place.first - x) <= 0.5;  // a nearest place
        wrong += !right;
        std::printf(
            "frame %d at (%.2f, %.2f): best match place %ld, estimate (%.0f, %.0f) from %zu frames, "
            "confidence %.2f%s\n",
            t, x, y, static_cast<long>(match.best), place.first, place.second, sequence.size(), confidence,
            right ? "" : "  <- off");
    }
    std::printf("%d of 9 estimates off the nearest place\n", wrong);
    return wrong <= 1 ? EXIT_SUCCESS : EXIT_FAILURE;
}
