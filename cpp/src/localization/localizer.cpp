// The default localizer over a map file (nightloc/localizer.hpp): what Python's Localizer adds
// around the grid filter, in the same order and arithmetic.
#include "nightloc/localizer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace nightloc {

double wrap_angle(double angle) noexcept {
    // Python's float modulo: the sign of the divisor, +0.0 for an exact multiple
    const double two_pi = 2.0 * M_PI;
    double mod = std::fmod(M_PI - angle, two_pi);
    if (mod != 0.0) {
        if (mod < 0) mod += two_pi;
    } else {
        mod = 0.0;
    }
    return M_PI - mod;
}

Localizer::Localizer(const MapFile& map)
    : map_(map),
      filter_(map.localizer.map, map.localizer.settings),
      query_(map.preparation.height * map.preparation.width) {
    try {
        (void)map_.preparation.settings(map_.preparation.height, map_.preparation.width);  // CLAHE: refused now
    } catch (const MapFileError& error) {
        throw MapFileError(map_.path + ": " + error.what());
    }
    const auto& place_of_ref = map_.localizer.map.place_of_ref;
    std::size_t places = 0;
    for (const std::int32_t p : place_of_ref) places = std::max(places, static_cast<std::size_t>(p) + 1);
    place_start_.assign(places + 1, 0);
    for (const std::int32_t p : place_of_ref) ++place_start_[static_cast<std::size_t>(p) + 1];
    for (std::size_t p = 0; p < places; ++p) place_start_[p + 1] += place_start_[p];
    place_members_.resize(place_of_ref.size());
    std::vector<std::size_t> next(place_start_.begin(), place_start_.end() - 1);
    for (std::size_t i = 0; i < place_of_ref.size(); ++i)
        place_members_[next[static_cast<std::size_t>(place_of_ref[i])]++] = i;
    if (map_.localizer.closest_ref.size() != filter_.height() * filter_.width()) {
        throw std::invalid_argument("the map's closest references do not cover its grid");
    }
}

void Localizer::reset() {
    filter_.reset();
    frames_ = 0;
}

LocalizerEstimate Localizer::update(const FrameView& frame, const Motion& motion) {
    const MapPreparation& p = map_.preparation;
    if (map_.frame_width != 0 && (frame.width != map_.frame_width || frame.height != map_.frame_height)) {
        throw std::invalid_argument("the frame is " + std::to_string(frame.width) + "x" + std::to_string(frame.height) +
                                    " pixels but the map was built from " + std::to_string(map_.frame_width) + "x" +
                                    std::to_string(map_.frame_height) + " frames: frames of another camera");
    }
    if (frame.order == PixelOrder::grey && frame.height == p.height && frame.width == p.width) {
        // a grey frame of the prepared size is taken as prepared (as Python's Localizer.update)
        for (std::size_t r = 0; r < p.height; ++r) {
            std::copy(frame.data + r * frame.row_stride, frame.data + r * frame.row_stride + p.width,
                      query_.begin() + static_cast<std::ptrdiff_t>(r * p.width));
        }
        return update_prepared(query_.data(), motion);
    }
    if (frame.height != prepare_for_height_ || frame.width != prepare_for_width_) {
        prepare_ = p.settings(frame.height, frame.width);
        prepare_for_height_ = frame.height;
        prepare_for_width_ = frame.width;
    }
    // a frame given as BGR is what Python's channel_order "bgr" means; "rgb" swaps the two
    FrameView view = frame;
    if (p.channel_order == "rgb") {
        if (view.order == PixelOrder::bgr)
            view.order = PixelOrder::rgb;
        else if (view.order == PixelOrder::rgb)
            view.order = PixelOrder::bgr;
        else if (view.order == PixelOrder::bgra)
            view.order = PixelOrder::rgba;
        else if (view.order == PixelOrder::rgba)
            view.order = PixelOrder::bgra;
    }
    prepare_frame(view, prepare_, query_.data(), workspace_);
    return update_prepared(query_.data(), motion);
}

std::size_t Localizer::closest_ref(std::size_t cell) const {
    const std::size_t first = static_cast<std::size_t>(map_.localizer.closest_ref[cell]);
    const std::size_t place = static_cast<std::size_t>(map_.localizer.map.place_of_ref[first]);
    const auto& scores = filter_.min_scores();
    std::size_t best = first;
    for (std::size_t k = place_start_[place]; k < place_start_[place + 1]; ++k) {
        const std::size_t i = place_members_[k];
        if (scores[i] < scores[best]) best = i;  // the first lowest, as numpy's argmin
    }
    return best;
}

LocalizerEstimate Localizer::update_prepared(const std::uint8_t* prepared, const Motion& motion) {
    if (frames_ > 0) {
        switch (motion.kind) {
            case Motion::Kind::robot:
                if (!filter_.can_pose()) {
                    throw std::invalid_argument(
                        "robot-frame odometry (forward, left, turn) needs heading bins, and this filter has none: the "
                        "map has no headings (or its images are not 360-degree panoramas); give map-frame "
                        "displacements (dx, dy) instead");
                }
                filter_.predict_robot(motion.a, motion.b, motion.c);
                break;
            case Motion::Kind::map:
                filter_.predict_map(motion.a, motion.b);
                break;
            case Motion::Kind::unknown:
                filter_.predict_unknown();
                break;
        }
    }
    filter_.update_image(prepared, map_.images.data(), map_.count, map_.preparation.height, 1);
    const GridEstimate g = filter_.estimate();
    ++frames_;
    LocalizerEstimate e;
    e.x = g.x;
    e.y = g.y;
    e.confidence = g.confidence;
    e.credible_radius = g.credible_radius;
    e.cov_xx = g.cov_xx;
    e.cov_xy = g.cov_xy;
    e.cov_yy = g.cov_yy;
    e.frames = frames_;
    // the cell nearest to the estimate (Python's round: half to even)
    const auto& t = map_.localizer;
    const auto index = [](double v, std::size_t n) {
        const double r = std::nearbyint(v);
        if (!(r > 0)) return std::size_t{0};
        return r >= static_cast<double>(n - 1) ? n - 1 : static_cast<std::size_t>(r);
    };
    const std::size_t i = index((g.x - t.map.x0) / t.map.dx, filter_.width());
    const std::size_t j = index((g.y - t.map.y0) / t.map.dy, filter_.height());
    e.ref_index = closest_ref(j * filter_.width() + i);
    const auto& scores = filter_.min_scores();
    for (std::size_t k = 1; k < scores.size(); ++k) {
        if (scores[k] < scores[e.best_ref]) e.best_ref = k;
    }
    e.score = scores[e.best_ref];
    if (std::isfinite(g.heading)) {
        e.heading = wrap_angle(g.heading);
    } else if (!map_.headings.empty()) {
        // position-only: the closest reference's heading turned by its best shift
        const double span = t.map.window.columns ? t.map.field_of_view : 2.0 * M_PI;
        const double turn = static_cast<double>(filter_.best_shifts()[e.ref_index]) * span /
                            static_cast<double>(map_.preparation.width);
        e.heading = wrap_angle(map_.headings[e.ref_index] + turn);
    } else {
        e.heading = std::nan("");
    }
    return e;
}

}  // namespace nightloc
