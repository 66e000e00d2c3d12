// C++ tests of the route filter (route_filter.hpp), run by ctest: the motion kernel against a
// direct numerical average over speeds and phases, one step against a plain re-computation of
// the model written here, batch = streaming, flat rows, re-acquisition after a kidnap, and the
// argument checks. The numpy oracle (tests/route_oracle.py) checks the whole filter from Python.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <stdexcept>
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

}  // namespace

int main() {
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
