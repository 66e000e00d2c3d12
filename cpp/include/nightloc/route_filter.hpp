// Route mode's Bayes filter: a causal belief over the reference frames of a route, predicted by
// the speed window and updated by each query frame's difference row. Pointer-level API.
//
// State: belief[r] = P(the query frame shows reference r), r = 0 .. n_refs-1, plus off_route =
// P(the query frame shows no reference); they sum to 1. Per query frame (RouteFilter::step):
//
//   1. predict: belief'[r] = sum_k kernel[k] * belief[r - k] over the advances k of
//      motion_kernel() (mass moving past either end of the route is dropped, the rest
//      rescaled to the on-route mass); then mix `floor` of the on-route mass uniformly over the
//      route (a lost filter re-acquires it); then the off-route exchange: `leave` of the
//      on-route mass leaves, `rejoin` of the off-route mass comes back uniformly.
//   2. update: z[r] = (row[r] - mean) / std over the row's finite values (population std;
//      non-finite values count as the mean, z = 0); likelihood L[r] =
//      exp(-lambda * min(z[r], clip)) with lambda = sharpness * weight; off-route likelihood =
//      mean_r L[r] (a frame that matches nothing looks like a random place). A row with no
//      spread, no finite value or weight 0 leaves the prediction unchanged.
//   3. answer: best = argmax belief (the lowest index on ties); confidence = sum of belief over
//      best-window .. best+window; off_route.
//
// Everything is double precision with a fixed order of operations (no threads), so the batch
// and frame-by-frame paths give identical results. The numpy oracle in tests/route_oracle.py
// follows the same definitions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace nightloc {

/// Parameters of the route filter (see the file comment for where each enters).
struct RouteFilterParams {
    double vmin = 0.8;       ///< slowest speed, references per query frame (>= 0)
    double vmax = 1.2;       ///< fastest speed (>= vmin, <= 1000)
    double backward = 0.0;   ///< probability per frame of stepping one reference back, [0, 1)
    double floor = 3e-3;     ///< uniform mixing per frame, [0, 1]
    double sharpness = 0.7;  ///< lambda, per standard deviation of the row (>= 0)
    double clip = 0.0;       ///< z above this is no evidence against a place (any value, inf: no clip)
    double leave = 1e-2;     ///< probability per frame of leaving the route, [0, 1]
    double rejoin = 1e-2;    ///< probability per frame of rejoining it (uniformly), [0, 1]
    std::size_t window = 2;  ///< confidence = belief mass within +-window references of the best
};

/// Throws std::invalid_argument naming the first parameter out of range.
void validate(const RouteFilterParams& params);

/// The prediction kernel: P(the reference advances by k) for k = first .. first+weights.size()-1.
/// A speed v uniform in [vmin, vmax] and a sub-frame phase x uniform in [0, 1) advance the
/// reference by floor(x + v); with probability `backward` the reference steps back by one
/// instead. Exact (closed-form integrals); weights sum to 1.
struct MotionKernel {
    std::int64_t first = 0;
    std::vector<double> weights;
};
MotionKernel motion_kernel(double vmin, double vmax, double backward);

/// The answer for one query frame.
struct RouteFilterStep {
    std::int64_t best = -1;   ///< the most probable reference
    double confidence = 0.0;  ///< belief mass within +-window of best, in [0, 1]
    double off_route = 0.0;   ///< probability that the frame shows no reference
};

/// The filter's state and its per-frame step. Not thread-safe (one filter per stream).
class RouteFilter {
public:
    /// Uniform belief over n_refs >= 1 references, off_route 0. Throws std::invalid_argument.
    RouteFilter(std::size_t n_refs, const RouteFilterParams& params);

    /// One query frame: `row` holds n_refs differences (lower = more similar; e.g. one row of the
    /// contrast-enhanced difference matrix); `weight` in [0, 1] scales the evidence (0: the frame
    /// is ignored, the belief is only predicted).
    RouteFilterStep step(const float* row, double weight = 1.0);

    /// One frame from its likelihood (n_refs values, route_likelihood()) and their sum.
    RouteFilterStep update(const double* likelihood, double likelihood_sum);

    /// n_rows consecutive frames: rows (n_rows, n_refs) row-major, weights n_rows values in
    /// [0, 1] or nullptr for all 1; writes best, confidence and off_route (n_rows each). Equal
    /// to n_rows calls of step (continues from the current state); the likelihoods of blocks of
    /// rows are computed on up to `threads` threads, the updates in order on one.
    void run(const float* rows, std::size_t n_rows, const double* weights, std::int64_t* best, double* confidence,
             double* off_route, int threads = 1);

    /// Back to the uniform belief (e.g. after the robot was carried elsewhere).
    void reset();

    /// Replaces the state; belief holds n_refs values >= 0, which with off_route (>= 0) must
    /// have a positive sum (they are normalized). Throws std::invalid_argument.
    void set_state(const double* belief, double off_route);

    const std::vector<double>& belief() const noexcept { return belief_; }
    double off_route() const noexcept { return off_; }
    std::size_t n_refs() const noexcept { return belief_.size(); }
    const RouteFilterParams& params() const noexcept { return params_; }
    const MotionKernel& kernel() const noexcept { return kernel_; }

private:
    RouteFilterParams params_;
    MotionKernel kernel_;
    std::vector<double> belief_;
    std::vector<double> scratch_;
    std::vector<double> likelihood_;
    double off_ = 0.0;
};

/// The filter over a whole (n_queries, n_refs) matrix, query rows in time order, from the
/// uniform belief. weights: n_queries values in [0, 1], or nullptr for all 1. Writes best,
/// confidence and off_route (n_queries each). Equal to n_queries calls of RouteFilter::step.
void route_filter(const float* matrix, std::size_t n_queries, std::size_t n_refs, const RouteFilterParams& params,
                  const double* weights, std::int64_t* best, double* confidence, double* off_route, int threads = 1);

/// The likelihood of one difference row (n values, lower = more similar) as the filter uses it:
/// out[r] = exp(-lambda * (min(z[r], clip) - min_s min(z[s], clip))), z = (row - mean) / std over
/// the finite values (non-finite values: z = 0); all 1 when lambda is 0 or the row has no
/// spread. Returns the sum of out. Depends on nothing but the row (any thread, any order).
double route_likelihood(const float* row, std::size_t n, double lambda, double clip, double* out) noexcept;

/// Evidence weight of a prepared image from its texture: min(1, mad / min_texture) with mad the
/// mean absolute deviation of its pixels from their mean (grey levels); a flat image gives 0.
/// min_texture <= 0 gives 1 for every image.
double texture_weight(const std::uint8_t* image, std::size_t n_pixels, double min_texture) noexcept;

}  // namespace nightloc
