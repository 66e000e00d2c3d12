// C++ tests of route mode (seqslam.hpp), run by ctest. The optimized, lane-wise kernels are
// checked bit for bit against direct per-element loops written here from OpenSeqSLAM's Matlab
// (one window / one trajectory at a time), and against known geometric answers.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "check.hpp"

#include <nightloc/seqslam.hpp>

namespace {

using Matrix = std::vector<float>;  // (rows, cols) row-major
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b)); }
bool same_value(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

Matrix random_matrix(std::mt19937& rng, std::size_t rows, std::size_t cols) {
    std::uniform_real_distribution<float> dist(0.0f, 40.0f);
    Matrix m(rows * cols);
    for (auto& v : m) v = dist(rng);
    return m;
}

// Direct enhancement of one element: Octave's mean and std of D(lo:hi, q), one window at a time.
float oracle_zscore(const Matrix& d, std::size_t cols, std::size_t q, std::size_t i, std::size_t radius) {
    const std::size_t lo = i >= radius ? i - radius : 0;
    const std::size_t hi = std::min(cols - 1, i + radius);
    const float n = static_cast<float>(hi - lo + 1);
    float total = 0.0f;
    for (std::size_t j = lo; j <= hi; ++j) total = total + d[q * cols + j];
    const float mean = total / n;
    float squares = 0.0f;
    for (std::size_t j = lo; j <= hi; ++j) {
        const float dev = d[q * cols + j] - mean;
        const volatile float sq = dev * dev;  // rounded on its own: never fused with the sum
        squares = squares + sq;
    }
    const float var = squares / (n - 1.0f);
    const float sd = std::sqrt(var);
    const float diff = d[q * cols + i] - mean;
    return diff / sd;
}

void test_enhancement() {
    std::mt19937 rng(7);
    const std::size_t shapes[][2] = {{1, 2}, {3, 5}, {4, 11}, {9, 12}, {17, 40}, {33, 257}};
    for (const auto& shape : shapes) {
        const std::size_t rows = shape[0], cols = shape[1];
        for (std::size_t radius : {1u, 3u, 5u, 8u}) {
            Matrix d = random_matrix(rng, rows, cols);
            if (cols > 6) {
                for (std::size_t j = 0; j < 6; ++j) d[j] = 3.0f;  // a flat window: 0/0 -> NaN
            }
            Matrix expected(rows * cols);
            float minimum = kNaN;
            for (std::size_t q = 0; q < rows; ++q) {
                for (std::size_t i = 0; i < cols; ++i) {
                    expected[q * cols + i] = oracle_zscore(d, cols, q, i, radius);
                    const float z = expected[q * cols + i];
                    if (!std::isnan(z) && (std::isnan(minimum) || z < minimum)) minimum = z;
                }
            }
            for (int threads : {1, 3}) {
                Matrix out(rows * cols);
                const float added = nightloc::enhance_contrast(d.data(), out.data(), rows, cols, radius,
                                                               nightloc::EnhanceOffset::kNone, threads);
                CHECK(added == 0.0f);
                bool ok = true;
                for (std::size_t k = 0; k < out.size(); ++k) ok = ok && same_bits(out[k], expected[k]);
                CHECK(ok);

                Matrix in_place = d;
                const float shift = nightloc::enhance_contrast(in_place.data(), in_place.data(), rows, cols, radius,
                                                               nightloc::EnhanceOffset::kGlobalMinimum, threads);
                CHECK(same_bits(shift, -minimum));
                ok = true;
                for (std::size_t k = 0; k < out.size(); ++k) ok = ok && same_bits(in_place[k], expected[k] - minimum);
                CHECK(ok);

                const float bound = nightloc::zscore_bound(radius);
                nightloc::enhance_contrast(d.data(), out.data(), rows, cols, radius,
                                           nightloc::EnhanceOffset::kZscoreBound, threads);
                ok = true;
                for (std::size_t k = 0; k < out.size(); ++k) {
                    ok = ok && same_bits(out[k], expected[k] + bound);
                    // The bound really bounds: every defined value is >= 0.
                    ok = ok && (std::isnan(out[k]) || out[k] >= -1e-5f);
                }
                CHECK(ok);
            }
        }
    }
    const double n = 11.0;
    CHECK(nightloc::zscore_bound(5) == static_cast<float>(10.0 / std::sqrt(n)));
    float x[4] = {1, 2, 3, 4};
    CHECK_THROWS(nightloc::enhance_contrast(x, x, 2, 2, 0, nightloc::EnhanceOffset::kNone), std::invalid_argument);
    CHECK_THROWS(nightloc::enhance_contrast(x, x, 4, 1, 2, nightloc::EnhanceOffset::kNone), std::invalid_argument);
}

void test_plan() {
    nightloc::TrajectoryParams params;  // OpenSeqSLAM defaults
    nightloc::TrajectoryPlan plan = nightloc::make_trajectory_plan(params);
    CHECK(plan.ds == 10 && plan.frames == 11);
    CHECK(plan.speeds.size() == 5);
    CHECK(plan.speeds.front() == 0.8 && plan.speeds.back() == 1.2);
    // Matlab: floor((0:10) .* 1.2) ends with 12; floor(5 * 0.9) = 4.
    CHECK(plan.offsets[4 * 11 + 10] == 12);
    CHECK(plan.offsets[1 * 11 + 5] == 4);
    CHECK(plan.columns.front() == -5 && plan.columns.back() == 5);
    CHECK(plan.first_query(100) == 5 && plan.last_query(100) == 95);

    params.ds = 7;  // forced even
    plan = nightloc::make_trajectory_plan(params);
    CHECK(plan.ds == 8 && plan.frames == 9);
    CHECK(plan.speeds.size() == 4);  // 6.4, 7.4, 8.4, 9.4 (<= 9.6)

    params.mode = nightloc::TrajectoryMode::kCausal;
    params.ds = 7;
    plan = nightloc::make_trajectory_plan(params);
    CHECK(plan.ds == 7 && plan.frames == 7);
    CHECK(plan.columns.front() == -6 && plan.columns.back() == 0);
    CHECK(plan.offsets[6] == 0);  // the query's own frame sits on the anchor
    CHECK(plan.first_query(20) == 6 && plan.last_query(20) == 20);

    params.vmin = 1.3;
    CHECK_THROWS(nightloc::make_trajectory_plan(params), std::invalid_argument);
    params.vmin = 0.8;
    params.ds = 1;
    CHECK_THROWS(nightloc::make_trajectory_plan(params), std::invalid_argument);
    // A plan of billions of offsets (vmax = 1000 with ds = 100000) is refused, not allocated.
    params.ds = 100000;
    params.vmin = 0.001;
    params.vmax = 1000.0;
    CHECK_THROWS(nightloc::make_trajectory_plan(params), std::invalid_argument);
    params.vmin = params.vmax = 1.0;  // one speed over 100000 frames is fine
    CHECK(nightloc::make_trajectory_plan(params).offsets.size() == 100000);
}

// One trajectory sum at a time, straight from the definition (rows outside the matrix: +inf).
void oracle_search(const Matrix& dd, std::size_t rows, std::size_t cols, const nightloc::TrajectoryPlan& plan,
                   std::vector<std::int64_t>& ref, std::vector<double>& score) {
    const bool centred = plan.mode == nightloc::TrajectoryMode::kCentred;
    const std::size_t anchors = centred ? cols + 1 : cols;
    ref.assign(rows, -1);
    score.assign(rows, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t q = plan.first_query(rows); q < plan.last_query(rows); ++q) {
        std::vector<float> best(anchors, kNaN);
        for (std::size_t a = 0; a < anchors; ++a) {
            for (std::size_t v = 0; v < plan.speeds.size(); ++v) {
                float total = 0.0f;
                for (std::size_t k = 0; k < plan.frames; ++k) {
                    const std::int64_t row = static_cast<std::int64_t>(a) + plan.offsets[v * plan.frames + k];
                    const std::int64_t col = static_cast<std::int64_t>(q) + plan.columns[k];
                    const float value = (row < 0 || row >= static_cast<std::int64_t>(cols))
                                            ? kInf
                                            : dd[static_cast<std::size_t>(col) * cols + static_cast<std::size_t>(row)];
                    total = total + value;
                }
                if (std::isnan(best[a]) || total < best[a]) best[a] = total;
            }
        }
        std::size_t arg = 0;
        for (std::size_t a = 0; a < anchors; ++a) {
            if (!std::isnan(best[a]) && (std::isnan(best[arg]) || best[a] < best[arg])) arg = a;
        }
        float second = kNaN;
        for (std::size_t a = 0; a < anchors; ++a) {
            const bool inside = a + static_cast<std::size_t>(plan.uniqueness_radius) >= arg &&
                                a <= arg + static_cast<std::size_t>(plan.uniqueness_radius);
            if (!inside && !std::isnan(best[a]) && (std::isnan(second) || best[a] < second)) second = best[a];
        }
        const std::size_t matched = centred ? arg + static_cast<std::size_t>(plan.ds / 2) : arg;
        ref[q] = static_cast<std::int64_t>(std::min(matched, cols - 1));
        score[q] = static_cast<double>(best[arg]) / static_cast<double>(second);
    }
}

void test_search_against_oracle() {
    std::mt19937 rng(11);
    for (auto mode : {nightloc::TrajectoryMode::kCentred, nightloc::TrajectoryMode::kCausal}) {
        for (int ds : {2, 5, 10}) {
            for (std::size_t cols : {14u, 31u, 64u}) {
                const std::size_t rows = 40;
                Matrix dd = random_matrix(rng, rows, cols);
                dd[3 * cols + 7] = kNaN;  // NaN is ignored by the minima
                dd[5 * cols + 2] = dd[5 * cols + 3];
                nightloc::TrajectoryParams params;
                params.ds = ds;
                params.vmin = ds == 5 ? 0.5 : 0.8;
                params.vmax = ds == 5 ? 1.5 : 1.2;
                params.uniqueness_radius = 3;
                params.mode = mode;
                const nightloc::TrajectoryPlan plan = nightloc::make_trajectory_plan(params);
                std::vector<std::int64_t> expected_ref;
                std::vector<double> expected_score;
                oracle_search(dd, rows, cols, plan, expected_ref, expected_score);
                for (int threads : {1, 2, 4}) {
                    std::vector<std::int64_t> got_ref(rows, 99);
                    std::vector<double> got_score(rows, 99.0);
                    nightloc::trajectory_search(dd.data(), rows, cols, plan, got_ref.data(), got_score.data(), 0, rows,
                                                threads);
                    bool ok = true;
                    for (std::size_t q = 0; q < rows; ++q) {
                        ok = ok && got_ref[q] == expected_ref[q] && same_value(got_score[q], expected_score[q]);
                    }
                    CHECK(ok);
                }
                // A sub-range leaves the other queries untouched.
                std::vector<std::int64_t> part_ref(rows, 99);
                std::vector<double> part_score(rows, 99.0);
                nightloc::trajectory_search(dd.data(), rows, cols, plan, part_ref.data(), part_score.data(), 10, 20, 2);
                CHECK(part_ref[9] == 99 && part_ref[20] == 99 && part_ref[15] == expected_ref[15]);
            }
        }
    }
}

// Known answer: a query traverse driven at speed 1.1 references per frame through a route with
// a distinct place every frame: the minimum of |r - 1.1 q| is the true place.
void test_search_geometry() {
    const std::size_t rows = 60, cols = 90;
    Matrix dd(rows * cols);
    for (std::size_t q = 0; q < rows; ++q)
        for (std::size_t r = 0; r < cols; ++r)
            dd[q * cols + r] = std::fabs(static_cast<float>(r) - 1.1f * static_cast<float>(q) - 3.0f) + 1.0f;
    for (auto mode : {nightloc::TrajectoryMode::kCentred, nightloc::TrajectoryMode::kCausal}) {
        nightloc::TrajectoryParams params;
        params.mode = mode;
        const nightloc::TrajectoryPlan plan = nightloc::make_trajectory_plan(params);
        std::vector<std::int64_t> ref(rows);
        std::vector<double> score(rows);
        nightloc::trajectory_search(dd.data(), rows, cols, plan, ref.data(), score.data(), 0, rows, 2);
        bool ok = true;
        for (std::size_t q = plan.first_query(rows); q < plan.last_query(rows); ++q) {
            const double truth = 1.1 * static_cast<double>(q) + 3.0;
            if (truth > static_cast<double>(cols) - 8.0) continue;  // the route ends
            ok = ok && std::fabs(static_cast<double>(ref[q]) - truth) <= 1.0 && score[q] < 0.7;
        }
        CHECK(ok);
        CHECK(ref[0] == (mode == nightloc::TrajectoryMode::kCausal ? -1 : -1));
        CHECK(std::isnan(score[plan.first_query(rows) - 1]));
    }
    // Too few references for the uniqueness window.
    nightloc::TrajectoryParams params;
    params.mode = nightloc::TrajectoryMode::kCausal;
    const nightloc::TrajectoryPlan plan = nightloc::make_trajectory_plan(params);
    std::vector<std::int64_t> ref(rows);
    std::vector<double> score(rows);
    CHECK_THROWS(
        nightloc::trajectory_search(dd.data(), rows * cols / 11, 11, plan, ref.data(), score.data(), 0, rows, 1),
        std::invalid_argument);
}

}  // namespace

int main() {
    test_enhancement();
    test_plan();
    test_search_against_oracle();
    test_search_geometry();
    return nightloc_test::check_summary();
}
