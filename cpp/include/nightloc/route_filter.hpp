// Route mode's Bayes filter: a causal belief over the reference frames of a route, predicted by
// a motion model and updated by each query frame's difference row. Pointer-level API.
//
// State: a belief over where the query frame is on the route, plus off_route = P(the query frame
// shows no reference); they sum to 1. Three motion models (RouteFilterParams::motion; the names
// route_motion_names() lists), each a unit of its own (cpp/src/route_motion_*.cpp):
//
//   * window: belief[r] over the references; the reference advances by floor(x + v) for a speed
//     v uniform in vmin..vmax and a phase x uniform in [0, 1), drawn afresh every frame
//     (motion_kernel()), or steps back one with probability `backward`.
//   * speed: a belief over (speed plane s, position cell c): the route is cut into `speed_cells`
//     cells per reference (cell c shows reference c / speed_cells), and the planes hold the
//     speeds v_s = speed_min + s * speed_step (references per frame). Each frame a plane's mass
//     advances by floor(x + u) cells, u uniform in
//     cells * (v_s - speed_jitter .. v_s + speed_jitter), or steps back one reference with
//     probability `backward`; then the speed moves between neighbouring planes (speed_chain():
//     a random walk of standard deviation speed_change per frame pulled back towards 1 with
//     time constant speed_tau frames; its stationary distribution is the speed prior).
//   * odometry (the constructor's reference distances: the cumulative distance travelled at
//     each reference frame, e.g. metres): a belief over `odometry_cells` cells per reference;
//     each frame the step's `advance` (distance travelled since the previous query frame) moves
//     a cell from its distance along the route to that distance + advance (distances between
//     references interpolated linearly; split linearly between the two nearest cells), then a
//     position noise of standard deviation odometry_noise * |advance| and odometry_jitter
//     references spreads it (odometry_spread()). A frame's evidence weight is multiplied by
//     min(1, |advance| / (odometry_novelty * spacing)) (spacing: the mean distance between
//     references): a robot that has not moved sees nothing new, and the same view again must not
//     count as new evidence. The first frame after a reset has no previous one: no motion, full
//     weight.
//
// Per query frame (RouteFilter::step):
//
//   1. predict: the motion model (mass moving past either end of the route is dropped, the rest
//      rescaled to the on-route mass); then mix `floor` of the on-route mass uniformly over the
//      route (a lost filter re-acquires it); then the off-route exchange: `leave` of the
//      on-route mass leaves, `rejoin` of the off-route mass comes back uniformly (speed model:
//      both spread over the planes by the speed prior).
//   2. update: z[r] = (row[r] - mean) / std over the row's finite values (population std;
//      non-finite values count as the mean, z = 0); likelihood L[r] =
//      exp(-lambda * min(z[r], clip)) with lambda = sharpness * weight, the same for every cell
//      and plane of reference r; off-route likelihood = mean_r L[r] (a frame that matches
//      nothing looks like a random place). A row with no spread, no finite value or weight 0
//      leaves the prediction unchanged.
//   3. answer: the belief over references (summed over planes and cells); best = its argmax
//      (the lowest index on ties); confidence = its sum over best-window .. best+window;
//      off_route; speed = the belief's mean speed (speed model), the mean advance in references
//      (odometry), NaN (window).
//
// Everything is double precision with a fixed order of operations (no threads in the updates),
// so the batch and frame-by-frame paths give identical results on every SIMD path and CPU. The
// numpy oracle in tests/route_oracle.py follows the same definitions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "nightloc/settings.hpp"

namespace nightloc {

/// The motion model of the route filter (see the file comment).
enum class RouteMotion : std::int32_t {
    kWindow = 0,    ///< a speed window drawn afresh every frame
    kSpeed = 1,     ///< a belief over position x speed
    kOdometry = 2,  ///< moved by the distance travelled (needs the references' distances)
};

/// The motion models' names ("window", "speed", "odometry"), in RouteMotion order: the one
/// name table, read by the bindings, the Python parameters and the command line.
std::vector<std::string> route_motion_names();
/// The name of `motion`; throws std::invalid_argument for a value that names no model.
const char* route_motion_name(RouteMotion motion);
/// The model called `name`; throws std::invalid_argument naming the choices.
RouteMotion route_motion_from_name(const std::string& name);
/// Whether `motion` names a model.
bool route_motion_known(RouteMotion motion) noexcept;
/// The name of the model of value `index`, nullptr past the last (the name table as
/// RouteFilterParams::motion's choices).
const char* route_motion_choice(std::size_t index) noexcept;
/// Whether `motion` moves by the distance travelled (the reference distances and each frame's
/// advance are its input); throws std::invalid_argument for a value that names no model.
bool route_motion_needs_distances(RouteMotion motion);

/// The steady speeds a motion model follows, references per query frame (lowest .. highest;
/// -inf .. inf for a model that moves by the distance travelled), and the RouteFilterParams
/// fields that set them: the central kRouteMotionSpeedMass of the model's speed distribution.
/// The window model: of its speed, uniform in vmin .. vmax. The speed model: the planes that
/// hold that share of its speed prior (the speed chain's stationary distribution; the other
/// planes are reached only against the pull towards 1).
inline constexpr double kRouteMotionSpeedMass = 0.8;
struct RouteMotionSpeeds {
    double lowest = 0.0;
    double highest = 0.0;
    std::vector<std::string> fields;
};

namespace route_detail {
class RouteMotionModel;
}

/// Parameters of the route filter (see the file comment for where each enters; python:
/// nightloc.RouteParams' filter_* fields, vmin and vmax, take their defaults from here). Every field
/// has its row in setting_fields<RouteFilterParams>() (cpp/src/route/route_filter.cpp).
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
    RouteMotion motion = RouteMotion::kSpeed;  ///< the motion model
    double speed_min = 0.5;                    ///< slowest speed plane, references per frame, [-1000, 1000]
    double speed_max = 1.5;                    ///< fastest speed plane, [speed_min, 1000]
    double speed_step = 0.1;                   ///< spacing of the speed planes (> 0; at most 1000 planes)
    double speed_jitter = 0.2;                 ///< half-width of each plane's speed window, references per frame (>= 0)
    double speed_change = 0.07;                ///< standard deviation of the speed's change per frame (>= 0)
    double speed_tau = 4.0;                    ///< frames for a speed to relax towards 1 (> 0; inf: no pull)
    std::size_t speed_cells = 2;               ///< position cells per reference of the speed model, 1 .. 64
    double odometry_noise = 0.05;              ///< relative standard deviation of an odometry advance, [0, 10]
    double odometry_jitter = 0.1;              ///< extra position noise per frame, references, [0, 100]
    double odometry_novelty = 1.0;   ///< references of travel for a frame's full evidence, [0, 1000] (0: always full)
    std::size_t odometry_cells = 4;  ///< position cells per reference of the odometry model, 1 .. 64
};

/// The parameters' table (nightloc/settings.hpp), in declaration order.
template <>
const std::vector<SettingField<RouteFilterParams>>& setting_fields<RouteFilterParams>();

/// Throws SettingError naming the first parameter out of range (the table's ranges, then vmax >=
/// vmin, speed_max >= speed_min, at most 1000 speed planes, speed_jitter x speed_cells <= 2000,
/// speed_change <= 50 speed_step).
void validate(const RouteFilterParams& params);

/// The speeds params.motion follows under `params` (the registry's entry for that model).
RouteMotionSpeeds route_motion_speeds(const RouteFilterParams& params);

/// The prediction kernel: P(the reference advances by k) for k = first .. first+weights.size()-1.
/// A speed v uniform in [vmin, vmax] and a sub-frame phase x uniform in [0, 1) advance the
/// reference by floor(x + v); with probability `backward` the reference steps back by one
/// instead. Exact (closed-form integrals); weights sum to 1.
struct MotionKernel {
    std::int64_t first = 0;
    std::vector<double> weights;
};
MotionKernel motion_kernel(double vmin, double vmax, double backward);

/// The speed model's planes: speeds v_s (references per frame) and the chain between them. One
/// pass moves mass from plane s up with probability up[s] and down with down[s]; `passes`
/// passes per frame (each with a variance of at most half a plane step squared) give the
/// random walk's variance speed_change^2 and its pull towards 1: the mean change of a pass is
/// -(v_s - 1) / (speed_tau * passes), limited to what that variance allows. prior[s] is the
/// chain's stationary distribution (sums to 1; uniform when the speed never changes).
struct SpeedChain {
    std::vector<double> speeds;
    std::vector<double> up;
    std::vector<double> down;
    std::vector<double> prior;
    std::size_t passes = 0;
};
SpeedChain speed_chain(const RouteFilterParams& params);

/// The odometry model's position noise for one frame as taps over cells: the `passes`-fold
/// convolution of [q, 1 - 2q, q] (q <= 1/4) whose variance is cells^2 * ((noise * advance /
/// spacing)^2 + jitter^2) cells^2 (`spacing`: distance per reference), capped at 256 passes;
/// taps[i] is the weight of a shift by i - (taps.size() - 1) / 2 cells.
std::vector<double> odometry_spread(double advance, double spacing, const RouteFilterParams& params);

/// The answer for one query frame.
struct RouteFilterStep {
    std::int64_t best = -1;                                   ///< the most probable reference
    double confidence = 0.0;                                  ///< belief mass within +-window of best, in [0, 1]
    double off_route = 0.0;                                   ///< probability that the frame shows no reference
    double speed = std::numeric_limits<double>::quiet_NaN();  ///< references per frame (NaN: window model)
};

/// Where RouteFilter::run writes: n_rows values each; `speed` may be nullptr.
struct RouteFilterOutputs {
    std::int64_t* best = nullptr;
    double* confidence = nullptr;
    double* off_route = nullptr;
    double* speed = nullptr;
};

/// The filter's state and its per-frame step. Not thread-safe (one filter per stream).
class RouteFilter {
public:
    /// Uniform belief over n_refs >= 1 references (speed model: planes by the speed prior),
    /// off_route 0, moved by the model params.motion names. `reference_distances`: the odometry
    /// model's n_refs cumulative distances along the route (finite, non-decreasing, the last
    /// above the first); nullptr for the other models. Throws std::invalid_argument.
    RouteFilter(std::size_t n_refs, const RouteFilterParams& params, const double* reference_distances = nullptr);
    RouteFilter(const RouteFilter& other);
    RouteFilter& operator=(const RouteFilter& other);
    RouteFilter(RouteFilter&& other) noexcept;
    RouteFilter& operator=(RouteFilter&& other) noexcept;
    ~RouteFilter();

    /// One query frame: `row` holds n_refs differences (lower = more similar; e.g. one row of the
    /// contrast-enhanced difference matrix); `weight` in [0, 1] scales the evidence (0: the frame
    /// is ignored, the belief is only predicted); `advance`: the odometry model's distance
    /// travelled since the previous frame (finite; negative: backwards), ignored by the others.
    RouteFilterStep step(const float* row, double weight = 1.0, double advance = 0.0);

    /// One frame from its likelihood (n_refs values, route_likelihood()) and their sum (the
    /// odometry model: computed with the weight frame_weight() gives).
    RouteFilterStep update(const double* likelihood, double likelihood_sum, double advance = 0.0);

    /// The weight a frame's evidence gets: `weight`, times the odometry model's novelty factor
    /// for `advance` (see the file comment).
    double frame_weight(double weight, double advance) const noexcept;

    /// n_rows consecutive frames: rows (n_rows, n_refs) row-major, weights n_rows values in
    /// [0, 1] or nullptr for all 1, advances n_rows values or nullptr for all 0 (odometry
    /// model); writes the outputs (n_rows each). Equal to n_rows calls of step (continues from
    /// the current state); the likelihoods of blocks of rows are computed on up to `threads`
    /// threads, the updates in order on one.
    void run(const float* rows, std::size_t n_rows, const double* weights, const double* advances,
             const RouteFilterOutputs& out, int threads = 1);
    void run(const float* rows, std::size_t n_rows, const double* weights, std::int64_t* best, double* confidence,
             double* off_route, int threads = 1);

    /// Back to the uniform belief (e.g. after the robot was carried elsewhere).
    void reset();

    /// Replaces the state; belief holds n_refs values >= 0, which with off_route (>= 0) must
    /// have a positive sum (they are normalized; the speed model spreads each reference's mass
    /// over its cells evenly and over the planes by the speed prior). Throws
    /// std::invalid_argument.
    void set_state(const double* belief, double off_route);

    /// The belief over the references (sums to 1 - off_route).
    const std::vector<double>& belief() const noexcept { return single_cell() ? belief_ : marginal_; }
    double off_route() const noexcept { return off_; }
    std::size_t n_refs() const noexcept { return n_refs_; }
    const RouteFilterParams& params() const noexcept { return params_; }
    const MotionKernel& kernel() const noexcept { return kernel_; }
    /// Threads for the speed and odometry models' work per frame (planes, blocks of
    /// references) in step(); run() uses its own argument. The results do not depend on it.
    void set_threads(int threads) noexcept { threads_ = threads > 1 ? threads : 1; }

    /// The motion model that runs.
    RouteMotion motion() const noexcept;
    /// "window", "speed" or "odometry".
    const char* motion_name() const noexcept;
    /// The speed model's planes (empty for the other models).
    const SpeedChain& chain() const noexcept;
    /// The belief over (plane, cell), plane-major (the window model: one plane of one cell per
    /// reference).
    const std::vector<double>& plane_belief() const noexcept { return belief_; }

private:
    RouteFilterStep answer(const double* marginal, double speed);
    bool single_cell() const noexcept;  // one plane of one cell per reference: the belief is the marginal
    double novelty(double advance) const noexcept;
    int plane_threads() const noexcept;

    RouteFilterParams params_;
    MotionKernel kernel_;
    std::size_t n_refs_ = 0;
    std::unique_ptr<route_detail::RouteMotionModel> model_;
    bool fresh_ = true;               // no frame since the last reset
    std::vector<double> belief_;      // planes x n_refs x cells, plane-major
    std::vector<double> scratch_;     // the prediction
    std::vector<double> marginal_;    // the belief over the references (unused with single_cell())
    std::vector<double> plane_mass_;  // per plane
    std::vector<double> cell_likelihood_;
    std::vector<double> likelihood_;
    double off_ = 0.0;
    int threads_ = 1;
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
