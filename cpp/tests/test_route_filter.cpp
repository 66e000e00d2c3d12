// C++ tests of the route filter (route_filter.hpp), run by ctest: the motion kernel against a
// direct numerical average over speeds and phases, one step against a plain re-computation of
// the model written here, batch = streaming, flat rows, re-acquisition after a kidnap, and the
// argument checks. The numpy oracle (tests/route_oracle.py) checks the whole filter from Python.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"

#include <nightloc/route_filter.hpp>
#include <nightloc/simd.hpp>

namespace {

bool close(double a, double b, double tol) { return std::fabs(a - b) <= tol; }

// P(advance = k) by averaging floor(x + v) over a fine grid of speeds and phases.
std::vector<double> grid_kernel(double vmin, double vmax, std::int64_t first, std::size_t size) {
    const int steps = 2000;
    std::vector<double> out(size, 0.0);
    for (int i = 0; i < steps; ++i) {
        const double v = vmax > vmin ? vmin + (vmax - vmin) * (i + 0.5) / steps : vmin;
        for (int j = 0; j < steps; ++j) {
            const double x = (j + 0.5) / steps;
            const auto k = static_cast<std::int64_t>(std::floor(x + v)) - first;
            if (k >= 0 && static_cast<std::size_t>(k) < size) out[static_cast<std::size_t>(k)] += 1.0;
        }
    }
    for (auto& w : out) w /= static_cast<double>(steps) * steps;
    return out;
}

void test_kernel() {
    const double windows[][2] = {{0.8, 1.2}, {0.5, 1.5}, {1.0, 1.0}, {0.0, 2.5}, {1.3, 1.9}, {2.0, 3.0}};
    for (const auto& w : windows) {
        const nightloc::MotionKernel k = nightloc::motion_kernel(w[0], w[1], 0.0);
        double total = 0.0;
        for (double v : k.weights) total += v;
        CHECK(close(total, 1.0, 1e-12));
        const std::vector<double> expected = grid_kernel(w[0], w[1], k.first, k.weights.size());
        double covered = 0.0;
        for (std::size_t i = 0; i < k.weights.size(); ++i) {
            CHECK(close(k.weights[i], expected[i], 2e-3));
            covered += expected[i];
        }
        CHECK(close(covered, 1.0, 1e-9));  // no advance outside the kernel's range
        CHECK(k.weights.front() > 0.0 && k.weights.back() > 0.0);
    }
    // The default window: P(0) = P(2) = 0.05, P(1) = 0.9.
    const nightloc::MotionKernel k = nightloc::motion_kernel(0.8, 1.2, 0.0);
    CHECK(k.first == 0 && k.weights.size() == 3);
    CHECK(close(k.weights[0], 0.05, 1e-12) && close(k.weights[1], 0.9, 1e-12) && close(k.weights[2], 0.05, 1e-12));
    // Backward slack: a step of -1 with that probability, the rest scaled.
    const nightloc::MotionKernel b = nightloc::motion_kernel(0.8, 1.2, 0.1);
    CHECK(b.first == -1 && b.weights.size() == 4);
    CHECK(close(b.weights[0], 0.1, 1e-15) && close(b.weights[2], 0.81, 1e-12));
    const nightloc::MotionKernel fast = nightloc::motion_kernel(3.0, 3.0, 0.2);
    CHECK(fast.first == -1 && fast.weights.size() == 5 && fast.weights[1] == 0.0 && close(fast.weights[4], 0.8, 1e-15));
}

// One step recomputed directly from the model's definition (no shared code with the filter).
void reference_step(std::vector<double>& b, double& off, const std::vector<float>& row, double weight,
                    const nightloc::RouteFilterParams& p) {
    const std::size_t n = b.size();
    const double nd = static_cast<double>(n);
    const nightloc::MotionKernel k = nightloc::motion_kernel(p.vmin, p.vmax, p.backward);
    std::vector<double> pred(n, 0.0);
    double on = 0.0;
    for (double v : b) on += v;
    for (std::size_t r = 0; r < n; ++r) {
        for (std::size_t i = 0; i < k.weights.size(); ++i) {
            const std::int64_t from = static_cast<std::int64_t>(r) - (k.first + static_cast<std::int64_t>(i));
            if (from >= 0 && from < static_cast<std::int64_t>(n))
                pred[r] += k.weights[i] * b[static_cast<std::size_t>(from)];
        }
    }
    double moved = 0.0;
    for (double v : pred) moved += v;
    for (auto& v : pred) v = v * on / moved;
    for (auto& v : pred) v = (1 - p.floor) * v + p.floor * on / nd;
    for (auto& v : pred) v = (1 - p.leave) * v + off * p.rejoin / nd;
    off = off * (1 - p.rejoin) + on * p.leave;
    double mean = 0.0;
    for (float v : row) mean += v;
    mean /= nd;
    double var = 0.0;
    for (float v : row) var += (v - mean) * (v - mean);
    const double sd = std::sqrt(var / nd);
    std::vector<double> like(n);
    double lmax = 0.0;
    for (std::size_t r = 0; r < n; ++r) {
        like[r] = std::exp(-p.sharpness * weight * std::min((row[r] - mean) / sd, p.clip));
        lmax = std::max(lmax, like[r]);
    }
    double lsum = 0.0;
    for (auto& l : like) {
        l /= lmax;
        lsum += l;
    }
    off *= lsum / nd;
    double total = off;
    for (std::size_t r = 0; r < n; ++r) {
        b[r] = pred[r] * like[r];
        total += b[r];
    }
    for (auto& v : b) v /= total;
    off /= total;
}

void test_step_matches_reference() {
    std::mt19937 rng(7);
    std::normal_distribution<float> noise(0.0f, 1.0f);
    nightloc::RouteFilterParams p;
    p.motion = nightloc::RouteMotion::kWindow;  // reference_step is the window model
    p.backward = 0.02;
    p.clip = 0.5;
    p.leave = 0.01;
    p.rejoin = 0.05;
    const std::size_t n = 57;
    nightloc::RouteFilter filter(n, p);
    std::vector<double> b(n, 1.0 / n);
    double off = 0.0;
    double worst = 0.0;
    for (int q = 0; q < 40; ++q) {
        std::vector<float> row(n);
        for (std::size_t r = 0; r < n; ++r) row[r] = noise(rng) + (r == static_cast<std::size_t>(q) % n ? -3.0f : 0.0f);
        const double weight = q % 5 == 0 ? 0.5 : 1.0;
        const nightloc::RouteFilterStep s = filter.step(row.data(), weight);
        reference_step(b, off, row, weight, p);
        for (std::size_t r = 0; r < n; ++r) worst = std::max(worst, std::fabs(b[r] - filter.belief()[r]));
        worst = std::max(worst, std::fabs(off - filter.off_route()));
        const auto best = static_cast<std::size_t>(std::max_element(b.begin(), b.end()) - b.begin());
        CHECK(s.best == static_cast<std::int64_t>(best));
        double mass = 0.0;
        for (std::size_t r = (best >= 2 ? best - 2 : 0); r <= std::min(n - 1, best + 2); ++r) mass += b[r];
        CHECK(close(s.confidence, mass, 1e-12));
    }
    CHECK(worst < 1e-12);
}

void test_flat_row_only_predicts() {
    nightloc::RouteFilterParams p;
    const std::size_t n = 30;
    nightloc::RouteFilter a(n, p);
    nightloc::RouteFilter b(n, p);
    std::vector<float> row(n);
    for (std::size_t r = 0; r < n; ++r) row[r] = r == 10 ? 0.0f : 5.0f;
    a.step(row.data());
    b.step(row.data());
    // A flat row, a row of NaN, and a weight of 0: belief = prediction of the same belief.
    const std::vector<float> flat(n, 3.0f);
    std::vector<float> nan_row(n, std::nanf(""));
    a.step(flat.data());
    b.step(row.data(), 0.0);
    for (std::size_t r = 0; r < n; ++r) CHECK(a.belief()[r] == b.belief()[r]);
    a.step(nan_row.data());
    b.step(flat.data());
    for (std::size_t r = 0; r < n; ++r) CHECK(a.belief()[r] == b.belief()[r]);
    CHECK(a.off_route() == b.off_route());
}

void test_batch_equals_stream_and_kidnap() {
    // A route of 400 references; queries follow it at speed 1 from 50 for 60 frames, then jump
    // to 300 (kidnap). Rows: noise with a dip at the true reference.
    std::mt19937 rng(3);
    std::normal_distribution<float> noise(0.0f, 1.0f);
    const std::size_t n = 400;
    std::vector<std::size_t> truth;
    for (std::size_t i = 0; i < 60; ++i) truth.push_back(50 + i);
    for (std::size_t i = 0; i < 60; ++i) truth.push_back(300 + i);
    std::vector<float> matrix(truth.size() * n);
    for (std::size_t q = 0; q < truth.size(); ++q) {
        for (std::size_t r = 0; r < n; ++r) matrix[q * n + r] = noise(rng) - (r == truth[q] ? 2.5f : 0.0f);
    }
    nightloc::RouteFilterParams p;
    std::vector<std::int64_t> best(truth.size());
    std::vector<double> confidence(truth.size());
    std::vector<double> off(truth.size());
    nightloc::route_filter(matrix.data(), truth.size(), n, p, nullptr, best.data(), confidence.data(), off.data());
    nightloc::RouteFilter filter(n, p);
    for (std::size_t q = 0; q < truth.size(); ++q) {
        const nightloc::RouteFilterStep s = filter.step(&matrix[q * n]);
        CHECK(s.best == best[q] && s.confidence == confidence[q] && s.off_route == off[q]);
    }
    CHECK(std::abs(best[59] - 109) <= 2);
    // Re-acquired within 30 frames of the kidnap and kept from then on.
    std::size_t first_good = truth.size();
    for (std::size_t q = 60; q < truth.size(); ++q) {
        bool rest = true;
        for (std::size_t k = q; k < truth.size(); ++k)
            rest = rest && std::abs(best[k] - static_cast<std::int64_t>(truth[k])) <= 2;
        if (rest) {
            first_good = q;
            break;
        }
    }
    std::printf("kidnap re-acquired after %zu frames\n", first_good - 60);
    CHECK(first_good - 60 <= 30);
}

void test_errors() {
    nightloc::RouteFilterParams p;
    p.vmin = 1.5;
    p.vmax = 1.0;
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    p.floor = 1.5;
    CHECK_THROWS(nightloc::RouteFilter(10, p), std::invalid_argument);
    p = {};
    p.sharpness = std::nan("");
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    p.clip = -INFINITY;
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    CHECK_THROWS(nightloc::RouteFilter(0, p), std::invalid_argument);
    nightloc::RouteFilter f(5, p);
    const std::vector<float> row(5, 1.0f);
    CHECK_THROWS(f.step(row.data(), 1.5), std::invalid_argument);
    const std::vector<double> zeros(5, 0.0);
    CHECK_THROWS(f.set_state(zeros.data(), 0.0), std::invalid_argument);
}

void test_likelihood_exp_accuracy() {
    // route_likelihood's exp (its own polynomial) against std::exp over the whole range used.
    const std::size_t n = 4000;
    std::vector<float> row(n);
    for (std::size_t r = 0; r < n; ++r) row[r] = static_cast<float>(r) * 0.25f;  // z from -1.73 to 1.73
    std::vector<double> out(n);
    const double lambda = 400.0;  // exponents down to about -1386: underflow to 0 is covered
    const double sum = nightloc::route_likelihood(row.data(), n, lambda, INFINITY, out.data());
    double mean = 0.0;
    for (float v : row) mean += v;
    mean /= static_cast<double>(n);
    double var = 0.0;
    for (float v : row) var += (v - mean) * (v - mean);
    const double sd = std::sqrt(var / static_cast<double>(n));
    double worst = 0.0;
    double total = 0.0;
    for (std::size_t r = 0; r < n; ++r) {
        const double exponent = -lambda * ((row[r] - mean) / sd - (row[0] - mean) / sd);
        const double expected = exponent > -708.0 ? std::exp(exponent) : 0.0;
        total += out[r];
        if (expected > 0.0) worst = std::max(worst, std::fabs(out[r] - expected) / expected);
        if (exponent < -709.0) CHECK(out[r] == 0.0);
    }
    std::printf("likelihood exp: worst relative error %.3g\n", worst);
    CHECK(worst < 1e-12);
    CHECK(close(sum, total, 1e-12));
    CHECK(out[0] == 1.0);
    // NaN entries count as the mean; a row without spread or lambda 0 gives all 1.
    row[7] = std::nanf("");
    nightloc::route_likelihood(row.data(), n, 1.0, INFINITY, out.data());
    CHECK(std::isfinite(out[7]) && out[7] > 0.0);
    const std::vector<float> flat(n, 2.0f);
    CHECK(nightloc::route_likelihood(flat.data(), n, 1.0, 0.0, out.data()) == static_cast<double>(n));
    CHECK(out[5] == 1.0);
}

void test_texture_weight() {
    std::vector<std::uint8_t> flat(100, 128);
    CHECK(nightloc::texture_weight(flat.data(), flat.size(), 1.0) == 0.0);
    CHECK(nightloc::texture_weight(flat.data(), flat.size(), 0.0) == 1.0);
    std::vector<std::uint8_t> image(100);
    for (std::size_t i = 0; i < image.size(); ++i) image[i] = static_cast<std::uint8_t>(i % 2 ? 129 : 128);
    CHECK(close(nightloc::texture_weight(image.data(), image.size(), 1.0), 0.5, 1e-15));  // deviation 0.5
    CHECK(nightloc::texture_weight(image.data(), image.size(), 0.25) == 1.0);
}

// Rows of a query at `positions` (fractional references) along n references: noise with a dip
// at round(position).
std::vector<float> route_rows(const std::vector<double>& positions, std::size_t n, unsigned seed, float dip) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0.0f, 1.0f);
    std::vector<float> matrix(positions.size() * n);
    for (std::size_t q = 0; q < positions.size(); ++q) {
        const auto truth = static_cast<std::int64_t>(std::lround(positions[q]));
        for (std::size_t r = 0; r < n; ++r)
            matrix[q * n + r] = noise(rng) - (static_cast<std::int64_t>(r) == truth ? dip : 0.0f);
    }
    return matrix;
}

struct Run {
    std::vector<std::int64_t> best;
    std::vector<double> confidence, off, speed;
    bool operator==(const Run& o) const {
        return best == o.best && confidence == o.confidence && off == o.off && speed == o.speed;
    }
};

Run run_filter(const std::vector<float>& matrix, std::size_t n, const nightloc::RouteFilterParams& p,
               const double* distances, const std::vector<double>& advances, int threads) {
    const std::size_t m = matrix.size() / n;
    Run out{std::vector<std::int64_t>(m), std::vector<double>(m), std::vector<double>(m), std::vector<double>(m)};
    nightloc::RouteFilter filter(n, p, distances);
    nightloc::RouteFilterOutputs o;
    o.best = out.best.data();
    o.confidence = out.confidence.data();
    o.off_route = out.off.data();
    o.speed = out.speed.data();
    filter.run(matrix.data(), m, nullptr, advances.empty() ? nullptr : advances.data(), o, threads);
    double total = filter.off_route();
    for (double v : filter.belief()) total += v;
    CHECK(close(total, 1.0, 1e-12));
    return out;
}

void test_speed_and_odometry_models() {
    // A query at 0.5-1.5x the reference's speed (a swing every 50 frames) on 300 references.
    const std::size_t n = 300;
    std::vector<double> positions{2.0}, advances{0.0};
    for (int k = 0; positions.size() < 250; ++k) {
        const double v = 1.0 + 0.5 * std::sin(2.0 * 3.141592653589793 * k / 50.0);
        positions.push_back(positions.back() + v);
        advances.push_back(v);
    }
    const std::vector<float> matrix = route_rows(positions, n, 21, 2.5f);
    nightloc::RouteFilterParams speed;  // the speed model with a loose prior, for a speed that swings
    speed.motion = nightloc::RouteMotion::kSpeed;
    speed.speed_change = 0.1;
    speed.speed_tau = 6.0;
    std::vector<double> distances(n);
    for (std::size_t r = 0; r < n; ++r) distances[r] = 0.5 * static_cast<double>(r);
    std::vector<double> metres(advances);
    for (double& a : metres) a *= 0.5;
    nightloc::RouteFilterParams odometry;
    odometry.motion = nightloc::RouteMotion::kOdometry;
    const Run by_speed = run_filter(matrix, n, speed, nullptr, {}, 1);
    nightloc::RouteFilterParams window;
    window.motion = nightloc::RouteMotion::kWindow;
    const Run by_window = run_filter(matrix, n, window, nullptr, {}, 1);
    const Run by_odometry = run_filter(matrix, n, odometry, distances.data(), metres, 1);
    std::size_t speed_ok = 0, odometry_ok = 0, window_ok = 0;
    for (std::size_t q = 20; q < positions.size(); ++q) {
        const auto truth = static_cast<std::int64_t>(std::lround(positions[q]));
        speed_ok += std::abs(by_speed.best[q] - truth) <= 2 ? 1 : 0;
        window_ok += std::abs(by_window.best[q] - truth) <= 2 ? 1 : 0;
        odometry_ok += std::abs(by_odometry.best[q] - truth) <= 2 ? 1 : 0;
        CHECK(close(by_odometry.speed[q], advances[q], 0.05));  // the mean advance, references per frame
    }
    std::printf("speed 0.5-1.5x: window model %zu, speed model %zu, odometry model %zu of %zu frames within 2\n",
                window_ok, speed_ok, odometry_ok, positions.size() - 20);
    CHECK(odometry_ok == positions.size() - 20);
    CHECK(speed_ok * 100 >= (positions.size() - 20) * 98 && speed_ok > window_ok);
    // Threads, steps one by one and every SIMD path this CPU has: the same bits.
    CHECK(run_filter(matrix, n, speed, nullptr, {}, 3) == by_speed);
    CHECK(run_filter(matrix, n, odometry, distances.data(), metres, 3) == by_odometry);
    nightloc::RouteFilter stepped(n, speed);
    for (std::size_t q = 0; q < positions.size(); ++q) {
        const nightloc::RouteFilterStep s = stepped.step(&matrix[q * n]);
        CHECK(s.best == by_speed.best[q] && s.confidence == by_speed.confidence[q] && s.speed == by_speed.speed[q]);
    }
    for (nightloc::SimdBackend path : nightloc::supported_simd_backends()) {
        nightloc::set_simd_backend(path);
        CHECK(run_filter(matrix, n, speed, nullptr, {}, 1) == by_speed);
        CHECK(run_filter(matrix, n, odometry, distances.data(), metres, 1) == by_odometry);
    }
    nightloc::reset_simd_backend();
    // The odometry model holds a stop and follows a reverse: 40 frames forward from 60, 10
    // stopped, 10 backwards.
    std::vector<double> still(60, 1.0), still_positions(60, 60.0);
    still[0] = 0.0;
    for (std::size_t q = 1; q < 60; ++q) {
        still[q] = q < 40 ? 1.0 : q < 50 ? 0.0 : -1.0;
        still_positions[q] = still_positions[q - 1] + still[q];
    }
    const std::vector<float> stop_rows = route_rows(still_positions, n, 5, 1.5f);
    std::vector<double> still_metres(still);
    for (double& v : still_metres) v *= 0.5;
    const Run stop = run_filter(stop_rows, n, odometry, distances.data(), still_metres, 1);
    for (std::size_t q = 30; q < 60; ++q) CHECK(std::abs(stop.best[q] - std::lround(still_positions[q])) <= 2);
    CHECK(stop.speed[45] == 0.0 && stop.speed[55] < -0.9 && stop.speed[20] > 0.9);
}

void test_speed_chain_and_spread() {
    nightloc::RouteFilterParams p;
    p.speed_change = 0.09;
    p.speed_step = 0.05;  // 3.24 planes^2 per frame: 7 passes
    const nightloc::SpeedChain chain = nightloc::speed_chain(p);
    CHECK(chain.speeds.size() == 21 && chain.passes == 7);
    // The prior is stationary: one pass leaves it as it is.
    double worst = 0.0;
    for (std::size_t s = 0; s < chain.speeds.size(); ++s) {
        double next = (1.0 - chain.up[s] - chain.down[s]) * chain.prior[s];
        if (s > 0) next += chain.up[s - 1] * chain.prior[s - 1];
        if (s + 1 < chain.speeds.size()) next += chain.down[s + 1] * chain.prior[s + 1];
        worst = std::max(worst, std::fabs(next - chain.prior[s]));
    }
    CHECK(worst < 1e-15);
    // The spread's variance: cells^2 ((noise * advance / spacing)^2 + jitter^2), symmetric taps.
    nightloc::RouteFilterParams q;
    q.odometry_cells = 4;
    q.odometry_noise = 0.1;
    q.odometry_jitter = 0.2;
    const std::vector<double> taps = nightloc::odometry_spread(3.0, 0.5, q);
    const double half = static_cast<double>(taps.size() / 2);
    double total = 0.0, variance = 0.0;
    for (std::size_t i = 0; i < taps.size(); ++i) {
        total += taps[i];
        variance += taps[i] * (static_cast<double>(i) - half) * (static_cast<double>(i) - half);
        CHECK(close(taps[i], taps[taps.size() - 1 - i], 1e-15));
    }
    CHECK(close(total, 1.0, 1e-12) && close(variance, 16.0 * (0.36 + 0.04), 1e-9));
}

void test_motion_errors() {
    nightloc::RouteFilterParams p;
    p.speed_step = 0.0;
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    p.speed_tau = 0.0;
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    p.odometry_cells = 0;
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    p.motion = static_cast<nightloc::RouteMotion>(7);
    CHECK_THROWS(nightloc::validate(p), std::invalid_argument);
    p = {};
    const std::vector<double> distances{0.0, 1.0, 2.0};
    // Reference distances are the odometry model's input, and only its.
    CHECK_THROWS(nightloc::RouteFilter(3, p, distances.data()), std::invalid_argument);
    p.motion = nightloc::RouteMotion::kOdometry;
    CHECK_THROWS(nightloc::RouteFilter(3, p), std::invalid_argument);
    const std::vector<double> falling{0.0, 2.0, 1.0};
    CHECK_THROWS(nightloc::RouteFilter(3, p, falling.data()), std::invalid_argument);
    const std::vector<double> flat{1.0, 1.0, 1.0};
    CHECK_THROWS(nightloc::RouteFilter(3, p, flat.data()), std::invalid_argument);
    nightloc::RouteFilter f(3, p, distances.data());
    const std::vector<float> row{1.0f, 2.0f, 3.0f};
    CHECK_THROWS(f.step(row.data(), 1.0, std::nan("")), std::invalid_argument);
    CHECK(std::string(f.motion_name()) == "odometry" && f.motion() == nightloc::RouteMotion::kOdometry);
    nightloc::RouteFilter copy(f);  // a copy carries its own model and state
    CHECK(copy.motion() == nightloc::RouteMotion::kOdometry && copy.belief() == f.belief());
}

void test_motion_names() {
    // The one name table: every name round-trips through its enum value, in enum order.
    const std::vector<std::string> names = nightloc::route_motion_names();
    CHECK(names == (std::vector<std::string>{"window", "speed", "odometry"}));
    for (std::size_t i = 0; i < names.size(); ++i) {
        const nightloc::RouteMotion motion = nightloc::route_motion_from_name(names[i]);
        CHECK(static_cast<std::size_t>(motion) == i && names[i] == nightloc::route_motion_name(motion));
        CHECK(nightloc::route_motion_known(motion));
    }
    CHECK(!nightloc::route_motion_known(static_cast<nightloc::RouteMotion>(3)));
    bool named_choices = false;
    try {
        nightloc::route_motion_from_name("teleport");
    } catch (const std::invalid_argument& error) {
        named_choices = true;  // every name of the table, quoted
        for (const std::string& name : names)
            named_choices = named_choices && std::string(error.what()).find("'" + name + "'") != std::string::npos;
    }
    CHECK(named_choices);
    CHECK_THROWS(nightloc::route_motion_name(static_cast<nightloc::RouteMotion>(-1)), std::invalid_argument);
    // Each model's steady speeds come from its own fields; odometry follows any speed.
    nightloc::RouteFilterParams p;
    p.vmin = 0.7;
    p.vmax = 1.3;
    p.motion = nightloc::RouteMotion::kWindow;
    nightloc::RouteMotionSpeeds speeds = nightloc::route_motion_speeds(p);
    // the central 80 % of a speed uniform in 0.7 .. 1.3
    CHECK(std::fabs(speeds.lowest - 0.76) < 1e-12 && std::fabs(speeds.highest - 1.24) < 1e-12 &&
          speeds.fields == (std::vector<std::string>{"vmin", "vmax"}));
    // The speed model: the planes of the central 80 % of its prior (the defaults: 0.9 .. 1.1; the
    // planes 0.5 .. 0.7 and 1.3 .. 1.5 get none of the stationary mass, 0.8 and 1.2 6 % each).
    p = nightloc::RouteFilterParams();
    p.motion = nightloc::RouteMotion::kSpeed;
    speeds = nightloc::route_motion_speeds(p);
    const nightloc::SpeedChain chain = nightloc::speed_chain(p);
    double inside = 0.0;
    for (std::size_t s = 0; s < chain.speeds.size(); ++s)
        if (chain.speeds[s] >= speeds.lowest - 1e-9 && chain.speeds[s] <= speeds.highest + 1e-9)
            inside += chain.prior[s];
    CHECK(std::fabs(speeds.lowest - 0.9) < 1e-9 && std::fabs(speeds.highest - 1.1) < 1e-9 && inside >= 0.8);
    CHECK(speeds.fields.size() == 4 && speeds.fields[0] == "speed_min");
    p.speed_tau = std::numeric_limits<double>::infinity();  // no pull: a uniform prior over 11 planes
    speeds = nightloc::route_motion_speeds(p);
    CHECK(std::fabs(speeds.lowest - 0.6) < 1e-9 && std::fabs(speeds.highest - 1.4) < 1e-9);
    p.motion = nightloc::RouteMotion::kOdometry;
    speeds = nightloc::route_motion_speeds(p);
    CHECK(std::isinf(speeds.lowest) && speeds.lowest < 0 && std::isinf(speeds.highest) && speeds.fields.empty());
    p.motion = static_cast<nightloc::RouteMotion>(7);
    CHECK_THROWS(nightloc::route_motion_speeds(p), std::invalid_argument);
}

}  // namespace

int main() {
    test_speed_and_odometry_models();
    test_speed_chain_and_spread();
    test_motion_errors();
    test_motion_names();
    test_kernel();
    test_step_matches_reference();
    test_flat_row_only_predicts();
    test_batch_equals_stream_and_kidnap();
    test_errors();
    test_likelihood_exp_accuracy();
    test_texture_weight();
    // The threaded batch (blocks of likelihoods on threads) equals the single-threaded one.
    {
        std::mt19937 rng(11);
        std::normal_distribution<float> noise(0.0f, 1.0f);
        const std::size_t n = 300, m = 150;
        std::vector<float> matrix(m * n);
        for (auto& v : matrix) v = noise(rng);
        std::vector<double> weights(m);
        for (std::size_t q = 0; q < m; ++q) weights[q] = static_cast<double>(q % 7) / 6.0;
        nightloc::RouteFilterParams p;
        std::vector<std::int64_t> b1(m), b4(m);
        std::vector<double> c1(m), c4(m), o1(m), o4(m);
        nightloc::route_filter(matrix.data(), m, n, p, weights.data(), b1.data(), c1.data(), o1.data(), 1);
        nightloc::route_filter(matrix.data(), m, n, p, weights.data(), b4.data(), c4.data(), o4.data(), 4);
        CHECK(b1 == b4 && c1 == c4 && o1 == o4);
        // Every SIMD path this CPU has (the likelihood loop's AVX2 / AVX-512 builds): same bits.
        for (nightloc::SimdBackend path : nightloc::supported_simd_backends()) {
            nightloc::set_simd_backend(path);
            std::vector<std::int64_t> bp(m);
            std::vector<double> cp(m), op(m);
            nightloc::route_filter(matrix.data(), m, n, p, weights.data(), bp.data(), cp.data(), op.data(), 1);
            CHECK(bp == b1 && cp == c1 && op == o1);
        }
        nightloc::reset_simd_backend();
    }
    return nightloc_test::check_summary();
}
