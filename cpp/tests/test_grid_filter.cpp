// C++ tests of the grid Bayes filter (nightloc/grid_filter.hpp), run by ctest: the exp2
// approximation against std::exp2, one extended-box pass against a direct sum in long double and
// its exact variance, exact integer motions of a delta, the credible radius against a full sort,
// mode changes and errors that leave the belief unchanged; every SIMD path the CPU supports must
// give the same belief and estimate as the scalar path, bit for bit. (The whole filter is checked
// against its numpy oracle in tests/localization/test_grid_filter.py.)
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

#include "check.hpp"
#include "localization/grid_filter_kernels.hpp"

#include <nightloc/grid_filter.hpp>
#include <nightloc/heatmap.hpp>
#include <nightloc/simd.hpp>

namespace {

using nightloc::GridEstimate;
using nightloc::GridFilter;
using nightloc::GridFilterMap;
using nightloc::GridFilterSettings;
using nightloc::HeatWeights;

constexpr double kTwoPi = 6.283185307179586476925286766559;

void test_exp2() {
    double worst = 0;
    for (int k = 0; k <= 600000; ++k) {
        const float y = -60.f * static_cast<float>(k) / 600000.f;
        const double exact = std::exp2(static_cast<double>(y));
        worst = std::max(worst, std::fabs(nightloc::detail::exp2_approx(y) / exact - 1.0));
    }
    std::printf("exp2 approximation: worst relative error %.3g\n", worst);
    CHECK(worst < 3e-7);
    CHECK(nightloc::detail::exp2_approx(0.f) == 1.f);
    CHECK(nightloc::detail::exp2_approx(-1.f) == 0.5f);
}

void test_box_pass() {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> value(0.f, 1.f);
    for (auto backend : nightloc::supported_simd_backends()) {
        const auto& k = nightloc::detail::filter_kernels(backend);
        for (int trial = 0; trial < 40; ++trial) {
            const std::size_t rows = 1 + rng() % 40, cols = 1 + rng() % 37;
            const std::size_t r = rng() % 8;
            const double alpha = static_cast<double>(rng() % 1000) / 1000.0;
            const nightloc::detail::BoxPass pass{r, alpha, 1.0 / (2.0 * static_cast<double>(r) + 1 + 2 * alpha)};
            std::vector<float> src(rows * cols), dst(rows * cols), zeros(cols, 0.f);
            std::vector<float> acc(cols);
            for (float& v : src) v = value(rng) < 0.3f ? 0.f : value(rng);
            k.box_rows(src.data(), dst.data(), rows, cols, pass, acc.data(), zeros.data());
            double worst = 0;
            for (std::size_t j = 0; j < rows; ++j)
                for (std::size_t i = 0; i < cols; ++i) {
                    long double sum = 0;
                    for (long t = -static_cast<long>(r) - 1; t <= static_cast<long>(r) + 1; ++t) {
                        const long row = static_cast<long>(j) + t;
                        if (row < 0 || row >= static_cast<long>(rows)) continue;
                        const long double weight = std::labs(t) == static_cast<long>(r) + 1 ? alpha : 1.0;
                        sum += weight * src[static_cast<std::size_t>(row) * cols + i];
                    }
                    worst = std::max(worst, static_cast<double>(std::fabs(sum * pass.inv_w - dst[j * cols + i])));
                }
            CHECK(worst < 2e-6);  // a running float sum: rounding of ~1e-7 of the values it carried
        }
    }
}

// A small map: references on a jittered lattice, weights by inverse distance to the 3 nearest
// places (any non-negative weights summing to one will do for the filter's arithmetic).
struct SmallMap {
    GridFilterMap map;
    std::vector<double> ref_x, ref_y;
};

SmallMap small_map(std::size_t height, std::size_t width, std::size_t n_refs, bool headings, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    SmallMap m;
    const double dx = 0.1, dy = 0.12;
    for (std::size_t i = 0; i < n_refs; ++i) {
        m.ref_x.push_back(unit(rng) * dx * static_cast<double>(width - 1));
        m.ref_y.push_back(unit(rng) * dy * static_cast<double>(height - 1));
    }
    std::vector<std::int32_t> indptr{0}, indices;
    std::vector<float> data;
    for (std::size_t j = 0; j < height; ++j)
        for (std::size_t i = 0; i < width; ++i) {
            if ((i + 2 * j) % 11 == 0) {  // a few cells without weights ("outside")
                indptr.push_back(static_cast<std::int32_t>(indices.size()));
                continue;
            }
            std::vector<std::pair<double, std::size_t>> near;
            for (std::size_t p = 0; p < n_refs; ++p)
                near.emplace_back(
                    std::hypot(m.ref_x[p] - dx * static_cast<double>(i), m.ref_y[p] - dy * static_cast<double>(j)), p);
            std::sort(near.begin(), near.end());
            const std::size_t take = std::min<std::size_t>(3, n_refs);
            double total = 0;
            for (std::size_t t = 0; t < take; ++t) total += 1.0 / (near[t].first + 0.05);
            for (std::size_t t = 0; t < take; ++t) {
                indices.push_back(static_cast<std::int32_t>(near[t].second));
                data.push_back(static_cast<float>(1.0 / (near[t].first + 0.05) / total));
            }
            indptr.push_back(static_cast<std::int32_t>(indices.size()));
        }
    m.map.weights = std::make_shared<HeatWeights>(height, width, n_refs, indptr, indices, data);
    m.map.x0 = 0;
    m.map.y0 = 0;
    m.map.dx = dx;
    m.map.dy = dy;
    for (std::size_t i = 0; i < n_refs; ++i) m.map.place_of_ref.push_back(static_cast<std::int32_t>(i));
    if (headings) {
        for (std::size_t i = 0; i < n_refs; ++i) m.map.ref_headings.push_back((unit(rng) - 0.5) * kTwoPi);
    }
    m.map.columns = 16;
    for (std::int32_t s = 0; s < 16; ++s) m.map.shifts.push_back(s);
    return m;
}

std::vector<float> random_table(std::size_t n_refs, std::size_t n_shifts, std::mt19937& rng) {
    std::uniform_real_distribution<float> score(15.f, 25.f);
    std::vector<float> t(n_refs * n_shifts);
    for (float& v : t) v = score(rng);
    return t;
}

std::vector<float> normalized_belief(const GridFilter& f) {
    const std::size_t n = f.active_bins() * f.height() * f.width();
    std::vector<float> out(f.belief(), f.belief() + n);
    for (float& v : out) v = static_cast<float>(v * f.scale());
    return out;
}

// Runs a fixed scenario and returns the beliefs and estimates after each step.
struct Trace {
    std::vector<std::vector<float>> beliefs;
    std::vector<GridEstimate> estimates;
};

// settle: reference 0 matches best (at shift 3) in every frame, and a few more frames follow: a
// belief whose bins are mostly negligible (moved without the blur).
Trace run_scenario(const SmallMap& m, GridFilterSettings settings, bool settle = false) {
    GridFilter filter(m.map, settings);
    std::mt19937 rng(77);
    Trace trace;
    auto record = [&]() {
        trace.beliefs.push_back(normalized_belief(filter));
        trace.estimates.push_back(filter.estimate());
    };
    const std::size_t n = filter.n_refs(), S = filter.n_shifts();
    auto table = [&]() {
        std::vector<float> t = random_table(n, S, rng);
        if (settle) t[3] = 5.f;
        return t;
    };
    filter.update(table().data());
    record();
    filter.predict_robot(0.31, 0.05, 0.4);
    filter.update(table().data());
    record();
    filter.predict_robot(-0.2, 0.0, -1.3);
    filter.update(table().data());
    record();
    filter.predict_map(0.15, -0.27);
    filter.update(table().data());
    record();
    filter.predict_unknown();
    record();
    filter.predict_robot(0.5, 0.1, 7.0);
    filter.update(table().data());
    record();
    for (int k = 0; settle && k < 16; ++k) {  // standing still, then turning slowly
        filter.predict_robot(0.0, 0.0, k < 10 ? 0.0 : 0.02);
        filter.update(table().data());
        record();
    }
    if (settle) {  // the scenario reaches the rule: bins below settings.negligible of the peak
        const std::vector<float>& b = trace.beliefs.back();
        const std::size_t cells = filter.height() * filter.width();
        std::vector<float> top(filter.active_bins(), 0.f);
        for (std::size_t c = 0; c < b.size(); ++c) top[c / cells] = std::max(top[c / cells], b[c]);
        const float peak = *std::max_element(top.begin(), top.end());
        CHECK(std::count_if(top.begin(), top.end(), [&](float v) { return v < settings.negligible * peak; }) > 4);
    }
    return trace;
}

bool same_estimate(const GridEstimate& a, const GridEstimate& b) {
    auto same = [](double x, double y) { return x == y || (std::isnan(x) && std::isnan(y)); };
    return same(a.x, b.x) && same(a.y, b.y) && same(a.heading, b.heading) && a.cov_xx == b.cov_xx &&
           a.cov_xy == b.cov_xy && a.cov_yy == b.cov_yy && a.credible_radius == b.credible_radius &&
           a.confidence == b.confidence && a.cell == b.cell && a.flat == b.flat && same(a.heading_var, b.heading_var);
}

void check_paths_identical(const char* name, const SmallMap& m, const GridFilterSettings& settings, bool settle) {
    nightloc::set_simd_backend(nightloc::SimdBackend::scalar);
    const Trace reference = run_scenario(m, settings, settle);
    for (auto backend : nightloc::supported_simd_backends()) {
        nightloc::set_simd_backend(backend);
        const Trace trace = run_scenario(m, settings, settle);
        bool same = trace.beliefs.size() == reference.beliefs.size();
        for (std::size_t s = 0; same && s < trace.beliefs.size(); ++s) {
            same =
                trace.beliefs[s] == reference.beliefs[s] && same_estimate(trace.estimates[s], reference.estimates[s]);
        }
        std::printf("grid filter (%s) on %s: %s the scalar path\n", name, nightloc::simd_backend_name(backend),
                    same ? "identical to" : "DIFFERS from");
        CHECK(same);
    }
    nightloc::reset_simd_backend();
}

void test_paths_identical() {
    GridFilterSettings settings;
    settings.heading_bins = 16;
    settings.distance_std = 0.2;
    settings.heading_std = 0.1;
    check_paths_identical("a few places", small_map(23, 37, 9, true, 3), settings, false);
    // many places: most blocks of 16 cells use more than a dense block holds (interpolated for
    // each pass of bins beforehand); two references share place 0, place 299 has none
    SmallMap many = small_map(30, 40, 300, true, 5);
    many.map.place_of_ref[299] = 0;
    const GridFilter probe(many.map, settings);
    CHECK(probe.sparse_blocks() > 0);
    // 299 places with references, more than lookalike_places: the cap is tempered by ln 64 / ln 299
    CHECK(std::fabs(probe.score_cap() - settings.score_cap * std::log(64.0) / std::log(299.0)) < 1e-12);
    check_paths_identical("many places, tempered cap", many, settings, false);
    GridFilterSettings untempered = settings;  // the full cap settles the belief: negligible bins
    untempered.lookalike_places = 0;
    check_paths_identical("many places, settling: negligible bins", many, untempered, true);
    GridFilterSettings other_bins = settings;  // bins other than the columns: a shift per bin
    other_bins.heading_bins = 12;
    check_paths_identical("12 bins over 16 columns", many, other_bins, false);
    // a forward camera: its table's columns are the offsets -4 .. 4 of a column window, its
    // heading bins see the references in view
    SmallMap forward = small_map(23, 37, 30, true, 6);
    forward.map.shifts = {0};
    forward.map.window = {4, 0};
    forward.map.field_of_view = kTwoPi / 6;
    const GridFilter probe_forward(forward.map, settings);
    CHECK(probe_forward.can_pose() && probe_forward.forward() && probe_forward.n_shifts() == 9);
    check_paths_identical("a forward camera", forward, settings, false);
}

void test_integer_motion_moves_a_delta() {
    const SmallMap m = small_map(20, 30, 6, true, 9);
    GridFilterSettings settings;
    settings.heading_bins = 16;
    settings.position_floor = 0;
    settings.heading_floor = 0;
    settings.uniform_floor = 0;
    GridFilter filter(m.map, settings);
    const std::size_t cells = 20 * 30;
    std::vector<float> belief(16 * cells, 0.f);
    belief[4 * cells + 5 * 30 + 7] = 1.f;  // bin 4 (heading pi/2), row 5, column 7
    filter.set_belief(belief.data(), true, 0.0);
    // forward 3 cells of dy = 0.36 m along +y, turn by one bin (+2 pi / 16)
    filter.predict_robot(0.36, 0.0, kTwoPi / 16);
    const std::vector<float> after = normalized_belief(filter);
    const std::size_t target = 5 * cells + 8 * 30 + 7;
    CHECK(std::fabs(after[target] - 1.f) < 1e-5f);
    CHECK(filter.offset() < 1e-9);
    const GridEstimate e = filter.estimate();
    CHECK(std::fabs(e.x - 0.7) < 1e-9 && std::fabs(e.y - 0.96) < 1e-9);
    CHECK(std::fabs(e.heading - 5 * kTwoPi / 16) < 1e-9);
    CHECK(e.credible_radius < 1e-12);
    // map-frame motion: position only, the heading forgotten
    filter.predict_map(-0.2, 0.0);
    CHECK(!filter.pose_mode());
    const GridEstimate moved = filter.estimate();
    CHECK(std::fabs(moved.x - 0.5) < 1e-9 && std::fabs(moved.y - 0.96) < 1e-9);
    CHECK(std::isnan(moved.heading));
    // a robot motion expands the belief again, uniform over heading
    filter.predict_robot(0.0, 0.0, 0.0);
    CHECK(filter.pose_mode());
    const std::vector<float> spread = normalized_belief(filter);
    for (std::size_t b = 0; b < 16; ++b) CHECK(std::fabs(spread[b * cells + 8 * 30 + 5] - 1.f / 16) < 1e-6f);
}

void test_credible_radius_and_confidence() {
    const SmallMap m = small_map(17, 19, 5, false, 11);
    GridFilterSettings settings;
    settings.credibility = 0.8;
    settings.confidence_radius = 0.35;
    GridFilter filter(m.map, settings);
    std::mt19937 rng(2);
    for (int trial = 0; trial < 20; ++trial) {
        filter.update(random_table(5, 16, rng).data());
        const GridEstimate e = filter.estimate();
        const float* M = filter.marginal();
        std::vector<std::pair<double, double>> cells;
        double total = 0, near = 0;
        for (std::size_t j = 0; j < 17; ++j)
            for (std::size_t i = 0; i < 19; ++i) {
                const double d = std::hypot(0.1 * static_cast<double>(i) - e.x, 0.12 * static_cast<double>(j) - e.y);
                const double v = M[j * 19 + i] * filter.scale();
                cells.emplace_back(d, v);
                total += v;
                if (d <= 0.35) near += v;
            }
        std::sort(cells.begin(), cells.end());
        double cum = 0, radius = cells.back().first;
        for (const auto& [d, v] : cells) {
            cum += v;
            if (cum >= 0.8 * total) {
                radius = d;
                break;
            }
        }
        CHECK(std::fabs(e.credible_radius - radius) < 1e-12);
        CHECK(std::fabs(e.confidence - near / total) < 1e-6);
        CHECK(std::fabs(total - 1.0) < 1e-5);
        filter.predict_map(0.05 * trial, -0.02 * trial);
    }
}

void test_errors_leave_the_belief() {
    const SmallMap m = small_map(12, 14, 4, false, 1);
    GridFilter filter(m.map, GridFilterSettings{});
    CHECK(!filter.can_pose());
    CHECK(filter.settings().heading_bins == m.map.columns);  // 0: one bin per image column
    CHECK_THROWS(filter.predict_robot(0.1, 0, 0), std::logic_error);
    std::mt19937 rng(4);
    filter.update(random_table(4, 16, rng).data());
    const std::vector<float> before = normalized_belief(filter);
    std::vector<float> bad = random_table(4, 16, rng);
    bad[17] = std::numeric_limits<float>::quiet_NaN();
    CHECK_THROWS(filter.update(bad.data()), std::invalid_argument);
    CHECK(normalized_belief(filter) == before);
    CHECK_THROWS(filter.predict_map(std::numeric_limits<double>::infinity(), 0), std::invalid_argument);
    CHECK(normalized_belief(filter) == before);
    // ties: a frame of equal scores carries no position (lambda 0), the belief is unchanged
    std::vector<float> ties(4 * 16, 20.f);
    filter.update(ties.data());
    CHECK(filter.lambda() == 0);
    const std::vector<float> after = normalized_belief(filter);
    double worst = 0;
    for (std::size_t c = 0; c < after.size(); ++c)
        worst = std::max(worst, static_cast<double>(std::fabs(after[c] - before[c])));
    CHECK(worst < 1e-9);
    GridFilterSettings bad_settings;
    bad_settings.uniform_floor = 1.0;
    CHECK_THROWS(GridFilter(m.map, bad_settings), std::invalid_argument);
    GridFilterSettings bad_noise;
    bad_noise.distance_per_metre = -0.1;
    CHECK_THROWS(GridFilter(m.map, bad_noise), std::invalid_argument);
    CHECK_THROWS(filter.set_noise(0.1, 0.02, 0.0, std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
    set_setting(bad_noise, "heading_per_radian", 0.25);
    CHECK(bad_noise.heading_per_radian == 0.25);
    GridFilterMap no_weights = m.map;
    no_weights.weights = nullptr;
    CHECK_THROWS(GridFilter(no_weights, GridFilterSettings{}), std::invalid_argument);
}

void test_unknown_motion_and_uniform() {
    const SmallMap m = small_map(15, 15, 4, true, 8);
    GridFilterSettings settings;
    settings.heading_bins = 8;
    GridFilter filter(m.map, settings);
    const GridEstimate e = filter.estimate();  // uniform: flat, the grid's mean
    CHECK(e.flat);
    CHECK(std::fabs(e.x - 0.7) < 1e-9 && std::fabs(e.y - 0.84) < 1e-9);
    // a motion far beyond the grid leaves nothing: the belief starts again, uniform
    GridFilterSettings no_floor = settings;
    no_floor.uniform_floor = 0;
    GridFilter lost(m.map, no_floor);
    lost.predict_robot(100.0, 0.0, 0.0);
    const std::vector<float> b = normalized_belief(lost);
    CHECK(std::fabs(b[0] - 1.f / static_cast<float>(b.size())) < 1e-9f);
    CHECK(std::fabs(b[b.size() / 2] - b[0]) < 1e-12f);
}

// The prediction's operator on one axis, from its definition in long double: the bilinear shift
// by `shift` cells, then three extended-box passes (Gwosdek) of variance sigma^2 / 3 each, on the
// infinite line; M[j][q] = weight of source cell q in output cell j.
std::vector<long double> axis_operator(std::size_t n, double shift, double sigma) {
    std::vector<long double> kernel{1.0L};
    if (sigma > 0) {
        const long double s2 = static_cast<long double>(sigma) * sigma / 3.0L;
        const long double r = std::floor(0.5L * std::sqrt(12.0L * s2 + 1.0L) - 0.5L);
        const long double alpha = (2 * r + 1) * (3 * s2 - r * (r + 1)) / (6 * ((r + 1) * (r + 1) - s2));
        const long double w = 2 * r + 1 + 2 * alpha;
        const auto ri = static_cast<std::size_t>(r);
        std::vector<long double> box(2 * ri + 3, 1.0L / w);
        box.front() = box.back() = alpha / w;
        for (int p = 0; p < 3; ++p) {
            std::vector<long double> next(kernel.size() + box.size() - 1, 0.0L);
            for (std::size_t a = 0; a < kernel.size(); ++a)
                for (std::size_t b = 0; b < box.size(); ++b) next[a + b] += kernel[a] * box[b];
            kernel.swap(next);
        }
        if (ri <= 20) {  // explicit taps: the ends below 1e-4 of the peak are left out
            const long double peak = *std::max_element(kernel.begin(), kernel.end());
            std::size_t cut = 0;
            while (2 * cut + 1 < kernel.size() && kernel[cut] < 1e-4L * peak) ++cut;
            kernel = std::vector<long double>(kernel.begin() + static_cast<std::ptrdiff_t>(cut),
                                              kernel.end() - static_cast<std::ptrdiff_t>(cut));
        }
    }
    const long double whole = std::floor(static_cast<long double>(shift)), frac = shift - whole;
    const long R = static_cast<long>(kernel.size() / 2);
    std::vector<long double> m(n * n, 0.0L);
    for (std::size_t j = 0; j < n; ++j)
        for (std::size_t u = 0; u < kernel.size(); ++u)
            for (int e = 0; e < 2; ++e) {
                // output j takes source j - v with v = whole + e + (u - R)
                const long v = static_cast<long>(whole) + e + static_cast<long>(u) - R;
                const long q = static_cast<long>(j) - v;
                if (q < 0 || q >= static_cast<long>(n)) continue;
                m[j * n + static_cast<std::size_t>(q)] += kernel[u] * (e ? frac : 1.0L - frac);
            }
    return m;
}

void test_prediction_against_operator() {
    const std::size_t h = 26, w = 31;
    const SmallMap m = small_map(h, w, 5, false, 21);  // dx 0.1, dy 0.12
    std::mt19937 rng(13);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // sigma in metres: composed kernels (up to 127 taps) and wide running sums
    for (double sigma : {0.0, 0.03, 0.15, 0.45, 0.9, 1.6, 3.2}) {
        for (int trial = 0; trial < 3; ++trial) {
            GridFilterSettings settings;
            settings.uniform_floor = 0;
            settings.position_floor = sigma;
            GridFilter filter(m.map, settings);
            std::vector<float> belief(h * w);
            for (float& v : belief) v = static_cast<float>(unit(rng) < 0.2 ? unit(rng) : 1e-3 * unit(rng));
            filter.set_belief(belief.data(), false, 0.0);
            const double dx = (unit(rng) - 0.5) * 2.4, dy = (unit(rng) - 0.5) * 2.4;
            filter.predict_map(dx, dy);
            const std::vector<float> got = normalized_belief(filter);
            const auto my = axis_operator(h, dy / 0.12, sigma / 0.12), mx = axis_operator(w, dx / 0.1, sigma / 0.1);
            std::vector<long double> want(h * w, 0.0L);
            long double total = 0;
            for (std::size_t j = 0; j < h; ++j)
                for (std::size_t i = 0; i < w; ++i) {
                    long double v = 0;
                    for (std::size_t q = 0; q < h; ++q) {
                        if (my[j * h + q] == 0) continue;
                        for (std::size_t p = 0; p < w; ++p) v += my[j * h + q] * mx[i * w + p] * belief[q * w + p];
                    }
                    want[j * w + i] = v;
                    total += v;
                }
            double worst = 0, peak = 0;
            for (std::size_t c = 0; c < h * w; ++c) {
                peak = std::max(peak, static_cast<double>(want[c] / total));
                worst = std::max(worst, static_cast<double>(std::fabs(want[c] / total - got[c])));
            }
            if (!(worst < 1e-5 * peak)) std::printf("sigma %g: worst %g of peak %g\n", sigma, worst, peak);
            CHECK(worst < 1e-5 * peak);
        }
    }
}

}  // namespace

int main() {
    test_exp2();
    test_box_pass();
    test_paths_identical();
    test_integer_motion_moves_a_delta();
    test_prediction_against_operator();
    test_credible_radius_and_confidence();
    test_errors_leave_the_belief();
    test_unknown_motion_and_uniform();
    return nightloc_test::check_summary();
}
