// nightloc C++ example: the per-frame path of a robot, without Python or OpenCV. A 3 x 3 lattice
// of reference places (1 m apart) is mapped from synthetic 192 x 96 BGR panoramas; the robot
// then drives along the middle row in 0.25 m steps, its camera frames darker and noisier than
// the map's. Each frame is prepared (nightloc::prepare_frame) and localized by the default
// localizer, the grid Bayes filter over position x heading (nightloc::GridFilter with the default
// settings and the odometry noise of Table III model 1): predict by the wheel odometry, update by
// the frame's rotational SAD table against the map, estimate position, heading and uncertainty.
//
//   cmake -S cpp -B build/cpp && cmake --build build/cpp && ./build/cpp/nightloc_localize_example
//
// The interpolation weights here give every cell of a 21 x 21 grid its nearest place (a valid
// CSR matrix, simple to write down). A robot loads nightloc's own map instead, with the weights of
// the Delaunay triangulation that Python's Localizer uses: nightloc::load_map_file and
// nightloc::Localizer (nightloc/localizer.hpp; the program nightloc_replay, docs/cpp_core.md).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include <nightloc/grid_filter.hpp>
#include <nightloc/heatmap.hpp>
#include <nightloc/nightloc.hpp>
#include <nightloc/prepare.hpp>

namespace {

constexpr std::size_t kFrameHeight = 96, kFrameWidth = 192;

// A BGR panorama of the place at (x, y) metres seen with `heading` radians (column c looks along
// the world azimuth heading - 2 pi c / width): smooth bands whose phases depend on the place,
// scaled by `gain` (night) with noise.
std::vector<std::uint8_t> panorama(double x, double y, double gain, std::mt19937& rng, double heading = 0.0) {
    std::normal_distribution<double> noise(0.0, gain < 1.0 ? 2.0 : 0.0);
    std::vector<std::uint8_t> frame(kFrameHeight * kFrameWidth * 3);
    for (std::size_t r = 0; r < kFrameHeight; ++r) {
        for (std::size_t c = 0; c < kFrameWidth; ++c) {
            const double a = 2.0 * M_PI * static_cast<double>(c) / static_cast<double>(kFrameWidth) - heading;
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

    // --- the default localizer: the grid filter over these cells x 48 heading bins
    nightloc::GridFilterMap map;
    map.weights = std::make_shared<nightloc::HeatWeights>(cells, cells, places.size(), indptr, indices, data);
    map.x0 = map.y0 = x0;
    map.dx = map.dy = step;
    for (std::size_t p = 0; p < places.size(); ++p) map.place_of_ref.push_back(static_cast<std::int32_t>(p));
    map.ref_headings.assign(places.size(), 0.0);  // every reference panorama faces +x
    map.columns = 48;
    map.shifts = nightloc::all_shifts(48);         // a panorama: every rotation
    nightloc::GridFilterSettings filter_settings;  // the defaults of nightloc.localization.FilterParams
    filter_settings.distance_std = 0.1;            // odometry noise per frame: Table III model 1
    filter_settings.heading_std = 0.02;
    nightloc::GridFilter filter(map, filter_settings);

    // --- the drive: along y = 1 from x = 0 to 2, a turn on the spot, back to 0; night frames and
    //     the wheel odometry since the previous frame (0.25 m ahead, or the half turn)
    int wrong = 0;
    std::vector<std::uint8_t> query(24 * 48);
    for (int t = 0; t <= 17; ++t) {
        const bool back = t > 8;
        const double x = back ? 2.0 - 0.25 * (t - 9) : 0.25 * t, y = 1.0, heading = back ? M_PI : 0.0;
        const auto frame = panorama(x, y, 0.35, rng, heading);
        nightloc::prepare_frame({frame.data(), kFrameHeight, kFrameWidth, kFrameWidth * 3, nightloc::PixelOrder::bgr},
                                settings, query.data(), workspace);
        if (t == 9)
            filter.predict_robot(0.0, 0.0, M_PI);  // forward, left (m), turn (rad)
        else if (t > 0)
            filter.predict_robot(0.25, 0.0, 0.0);
        filter.update_image(query.data(), refs.pixels.data(), places.size(), 24);
        const nightloc::GridEstimate e = filter.estimate();
        const bool right = std::hypot(e.x - x, e.y - y) <= 0.5;
        wrong += t >= 3 && !right;  // the first frames: the belief is still spread over look-alikes
        std::printf(
            "frame %2d at (%.2f, %.2f): estimate (%.2f, %.2f) heading %5.2f rad, confidence %.2f, credible radius "
            "%.2f m%s\n",
            t, x, y, e.x, e.y, e.heading, e.confidence, e.credible_radius, right ? "" : "  <- off");
    }
    std::printf("%d of 15 estimates after the first three off by more than 0.5 m\n", wrong);
    return wrong <= 1 ? EXIT_SUCCESS : EXIT_FAILURE;
}
