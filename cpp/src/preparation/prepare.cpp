// Frame preparation without OpenCV (see nightloc/prepare.hpp): two passes over the cropped
// full-resolution frame. Pass 1 (global equalization only) converts to grey into the workspace
// and counts the histogram; pass 2 maps each grey row through the equalization table and adds
// it into a 16-bit band of column sums; at the few rows where output cells have an edge, the
// band is folded into exact 64-bit sums per column segment, which give the integral image at
// every cell corner. The means, their rounding and the float32 paths reproduce the Python
// pipeline (python/nightloc/preparation/downsample.py) bit for bit.
#include "nightloc/prepare.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "nightloc/sad.hpp"
#include "preparation/prepare_kernels.hpp"

namespace nightloc {

// --------------------------------------------------------------------------------------------
// workspace

struct PrepareWorkspace::Buffers {
    std::vector<std::uint8_t> grey;        // cropped grey frame (pass 1 -> pass 2)
    std::vector<std::uint8_t> row;         // one grey / equalized row
    std::vector<std::uint16_t> band;       // column sums of the rows since the last fold
    std::vector<std::uint32_t> prefix;     // column prefix sums of the band
    std::vector<std::int64_t> segments;    // integral of all folded rows at each cut column
    std::vector<std::int64_t> corners;     // integral image at (cut row, cut column)
    std::vector<std::size_t> cut_columns;  // ascending, starting at 0
    std::vector<std::ptrdiff_t> row_slot;  // input row -> its row in `corners`, or -1
    std::vector<float> row_weights, sums;  // the float32 path (DownsampleMethod::weights)
    std::vector<std::uint8_t> small;       // downsampled image before normalization

    std::size_t bytes() const noexcept {
        return grey.capacity() + row.capacity() + band.capacity() * 2 + segments.capacity() * 8 +
               corners.capacity() * 8 + cut_columns.capacity() * sizeof(std::size_t) +
               row_slot.capacity() * sizeof(std::ptrdiff_t) + prefix.capacity() * 4 +
               (row_weights.capacity() + sums.capacity()) * 4 + small.capacity();
    }
};

PrepareWorkspace::PrepareWorkspace() : buffers_(new Buffers) {}
PrepareWorkspace::~PrepareWorkspace() { delete buffers_; }
PrepareWorkspace::PrepareWorkspace(PrepareWorkspace&& other) noexcept : buffers_(other.buffers_) {
    other.buffers_ = new (std::nothrow) Buffers;
}
PrepareWorkspace& PrepareWorkspace::operator=(PrepareWorkspace&& other) noexcept {
    if (this != &other) std::swap(buffers_, other.buffers_);
    return *this;
}
std::size_t PrepareWorkspace::capacity_bytes() const noexcept { return buffers_ ? buffers_->bytes() : 0; }
void PrepareWorkspace::release() noexcept {
    if (buffers_) *buffers_ = Buffers{};
}

std::size_t pixel_bytes(PixelOrder order) noexcept {
    switch (order) {
        case PixelOrder::grey:
            return 1;
        case PixelOrder::bgr:
        case PixelOrder::rgb:
            return 3;
        case PixelOrder::bgra:
        case PixelOrder::rgba:
            return 4;
    }
    return 0;
}

// --------------------------------------------------------------------------------------------
// downsample plans

namespace {

/// Inputs below this many pixels take cv2.resize's paths in the Python pipeline.
constexpr std::size_t kIntegralMinPixels = 65536;

// Round half to even (the default rounding mode), as numpy.rint and OpenCV's cvRound.
inline double round_even(double v) { return std::nearbyint(v); }
inline float round_even(float v) { return std::nearbyintf(v); }

inline std::uint8_t saturate_u8(double v) {
    if (!(v > 0.0)) return 0;  // also -0 and NaN (cannot happen)
    if (v >= 255.0) return 255;
    return static_cast<std::uint8_t>(v);
}

// One output cell edge along an axis of the integral method: the integral image is read at
// `lo` and `lo + 1` and interpolated with weight `frac` (numpy: floor, min(., n - 1)).
struct Edge {
    std::size_t lo;
    double frac;
};

std::vector<Edge> integral_edges(std::size_t n_in, std::size_t n_out) {
    std::vector<Edge> edges(n_out + 1);
    const double step = static_cast<double>(n_in) / static_cast<double>(n_out);
    for (std::size_t k = 0; k <= n_out; ++k) {
        const double position = static_cast<double>(k) * step;
        const auto lo = std::min(static_cast<std::size_t>(std::floor(position)), n_in - 1);
        edges[k] = {lo, position - static_cast<double>(lo)};
    }
    return edges;
}

// cv::resize's table for INTER_AREA's general path (computeResizeAreaTab): for output index d,
// input index s contributes with weight alpha (float32), in this order.
struct AreaTap {
    std::size_t out, in;
    float alpha;
};

std::vector<AreaTap> area_taps(std::size_t n_in, std::size_t n_out) {
    // cv::resize: inv_scale = dsize / ssize, scale = 1 / inv_scale
    const double scale = 1.0 / (static_cast<double>(n_out) / static_cast<double>(n_in));
    const auto last = static_cast<std::ptrdiff_t>(n_in) - 1;
    std::vector<AreaTap> taps;
    taps.reserve(2 * n_in);
    for (std::size_t d = 0; d < n_out; ++d) {
        const double start = static_cast<double>(d) * scale;
        const double stop = start + scale;
        const double cell = std::min(scale, static_cast<double>(n_in) - start);
        auto first = static_cast<std::ptrdiff_t>(std::ceil(start));
        auto end = static_cast<std::ptrdiff_t>(std::floor(stop));
        end = std::min(end, last);
        first = std::min(first, end);
        if (static_cast<double>(first) - start > 1e-3) {
            taps.push_back({d, static_cast<std::size_t>(first - 1),
                            static_cast<float>((static_cast<double>(first) - start) / cell)});
        }
        for (std::ptrdiff_t s = first; s < end; ++s) {
            taps.push_back({d, static_cast<std::size_t>(s), static_cast<float>(1.0 / cell)});
        }
        if (stop - static_cast<double>(end) > 1e-3) {
            taps.push_back({d, static_cast<std::size_t>(end),
                            static_cast<float>(std::min(std::min(stop - static_cast<double>(end), 1.0), cell) / cell)});
        }
    }
    return taps;
}

// --------------------------------------------------------------------------------------------
// pass 2 consumers: each takes the grey rows in order and writes the small image

// Integral and blocks methods: the integral image at the cut rows x cut columns, from band sums.
// Only rows and columns with a non-zero weight are cut (numpy multiplies the others by 0.0: any
// finite value gives the same result).
class CutSums {
public:
    CutSums(PrepareWorkspace::Buffers& b, const detail::PrepareKernels& k, DownsampleMethod method, std::size_t in_h,
            std::size_t in_w, std::size_t out_h, std::size_t out_w)
        : b_(b), k_(k), method_(method), in_h_(in_h), in_w_(in_w), out_h_(out_h), out_w_(out_w) {
        std::vector<std::size_t> rows, cols{0};
        if (method == DownsampleMethod::integral) {
            row_edges_ = integral_edges(in_h, out_h);
            col_edges_ = integral_edges(in_w, out_w);
            for (const Edge& e : row_edges_) {
                if (1.0 - e.frac != 0.0) rows.push_back(e.lo);
                if (e.frac != 0.0) rows.push_back(e.lo + 1);
            }
            for (const Edge& e : col_edges_) cols.insert(cols.end(), {e.lo, e.lo + 1});
        } else {
            for (std::size_t i = 0; i <= out_h; ++i) rows.push_back(i * (in_h / out_h));
            for (std::size_t i = 0; i <= out_w; ++i) cols.push_back(i * (in_w / out_w));
        }
        std::sort(rows.begin(), rows.end());
        rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
        std::sort(cols.begin(), cols.end());
        cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
        b_.cut_columns = cols;
        b_.row_slot.assign(in_h + 1, -1);
        for (std::size_t i = 0; i < rows.size(); ++i) b_.row_slot[rows[i]] = static_cast<std::ptrdiff_t>(i);
        n_cols_ = cols.size();
        b_.corners.assign(rows.size() * n_cols_, 0);
        b_.segments.assign(n_cols_, 0);
        b_.band.assign(in_w, 0);
        b_.prefix.resize(in_w + 1);
        // a band's column prefix sums stay below 2^32: at most 256 rows (16-bit band), fewer for
        // frames wider than 65 793 columns
        band_limit_ = std::max<std::size_t>(1, std::min<std::size_t>(256, 0xffffffffull / (255 * in_w)));
        if (b_.row_slot[0] >= 0) record(0);
    }

    // Adds grey row y (through `lut` unless null).
    void add(std::size_t y, const std::uint8_t* row, const std::uint8_t* lut) {
        if (lut) {
            k_.accumulate_lut_row(row, in_w_, lut, b_.band.data());
        } else {
            k_.accumulate_row(row, in_w_, b_.band.data());
        }
        ++band_rows_;
        if (b_.row_slot[y + 1] >= 0) {
            fold();
            record(y + 1);
        } else if (band_rows_ == band_limit_) {
            fold();
        }
    }

    void finish(std::uint8_t* small) const {
        if (method_ == DownsampleMethod::integral) {
            finish_integral(small);
        } else {
            finish_blocks(small);
        }
    }

private:
    // The band's column prefix sums at every cut column join the running integral (`segments`
    // holds, per cut column c, the sum of all folded rows over columns < c); the band restarts.
    void fold() {
        std::uint32_t* prefix = b_.prefix.data();
        k_.prefix_row(b_.band.data(), in_w_, prefix);
        for (std::size_t k = 0; k < n_cols_; ++k) b_.segments[k] += prefix[b_.cut_columns[k]];
        std::fill(b_.band.begin(), b_.band.end(), std::uint16_t{0});
        band_rows_ = 0;
    }

    // The integral image at row r (sum of rows < r) and every cut column.
    void record(std::size_t r) {
        std::copy(b_.segments.begin(), b_.segments.end(),
                  b_.corners.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(b_.row_slot[r]) * n_cols_));
    }

    std::size_t column_slot(std::size_t c) const {
        return static_cast<std::size_t>(std::lower_bound(b_.cut_columns.begin(), b_.cut_columns.end(), c) -
                                        b_.cut_columns.begin());
    }

    // A corner of the integral image; 0 for a row that was not cut (its weight is zero).
    double corner(std::size_t r, std::size_t col_slot) const {
        const std::ptrdiff_t slot = b_.row_slot[r];
        return slot < 0 ? 0.0 : static_cast<double>(b_.corners[static_cast<std::size_t>(slot) * n_cols_ + col_slot]);
    }

    // preparation.py's _AreaSampler.means, in numpy's order of operations:
    //   rows  = I[y0] * (1 - fy) + I[y0 + 1] * fy            (per cut column)
    //   edges = rows[x0] * (1 - fx) + rows[x0 + 1] * fx
    //   box   = ((e[a+1, b+1] - e[a, b+1]) - e[a+1, b]) + e[a, b];  mean = box * factor
    // then numpy.rint and clip to 0..255.
    void finish_integral(std::uint8_t* small) const {
        const std::size_t ny = out_h_ + 1, nx = out_w_ + 1;
        std::vector<std::size_t> lo_slot(nx), hi_slot(nx);
        for (std::size_t b = 0; b < nx; ++b) {
            lo_slot[b] = column_slot(col_edges_[b].lo);
            hi_slot[b] = column_slot(col_edges_[b].lo + 1);
        }
        std::vector<double> edges(ny * nx);
        for (std::size_t a = 0; a < ny; ++a) {
            const Edge& ey = row_edges_[a];
            const double wy1 = ey.frac, wy0 = 1.0 - ey.frac;
            for (std::size_t b = 0; b < nx; ++b) {
                const Edge& ex = col_edges_[b];
                const double lo = corner(ey.lo, lo_slot[b]) * wy0 + corner(ey.lo + 1, lo_slot[b]) * wy1;
                const double hi = corner(ey.lo, hi_slot[b]) * wy0 + corner(ey.lo + 1, hi_slot[b]) * wy1;
                edges[a * nx + b] = lo * (1.0 - ex.frac) + hi * ex.frac;
            }
        }
        const double factor = static_cast<double>(out_h_ * out_w_) / static_cast<double>(in_h_ * in_w_);
        for (std::size_t a = 0; a < out_h_; ++a) {
            for (std::size_t b = 0; b < out_w_; ++b) {
                const double box =
                    edges[(a + 1) * nx + b + 1] - edges[a * nx + b + 1] - edges[(a + 1) * nx + b] + edges[a * nx + b];
                small[a * out_w_ + b] = saturate_u8(round_even(box * factor));
            }
        }
    }

    // cv2.resize INTER_AREA with integer factors: exact block sums; 2 x 2 rounds half up with
    // integers, other factors multiply by the float32 reciprocal of the area and round to even.
    void finish_blocks(std::uint8_t* small) const {
        const std::size_t fy = in_h_ / out_h_, fx = in_w_ / out_w_;
        const bool two_by_two = fy == 2 && fx == 2;
        const float inverse_area = 1.f / static_cast<float>(fy * fx);
        for (std::size_t a = 0; a < out_h_; ++a) {
            for (std::size_t b = 0; b < out_w_; ++b) {
                const std::size_t r0 = a * fy, r1 = r0 + fy, c0 = column_slot(b * fx), c1 = column_slot((b + 1) * fx);
                const std::int64_t sum = b_.corners[static_cast<std::size_t>(b_.row_slot[r1]) * n_cols_ + c1] -
                                         b_.corners[static_cast<std::size_t>(b_.row_slot[r0]) * n_cols_ + c1] -
                                         b_.corners[static_cast<std::size_t>(b_.row_slot[r1]) * n_cols_ + c0] +
                                         b_.corners[static_cast<std::size_t>(b_.row_slot[r0]) * n_cols_ + c0];
                if (two_by_two) {
                    small[a * out_w_ + b] = static_cast<std::uint8_t>((sum + 2) >> 2);
                } else {
                    small[a * out_w_ + b] = saturate_u8(round_even(static_cast<float>(sum) * inverse_area));
                }
            }
        }
    }

    PrepareWorkspace::Buffers& b_;
    const detail::PrepareKernels& k_;
    DownsampleMethod method_;
    std::size_t in_h_, in_w_, out_h_, out_w_;
    std::size_t n_cols_ = 0;
    std::size_t band_rows_ = 0;
    std::size_t band_limit_ = 256;
    std::vector<Edge> row_edges_, col_edges_;
};

// cv2.resize INTER_AREA's general path (resizeArea_<uchar, float>): per input row, float32
// weighted sums into the output columns; per output row, the float32 sum of beta * row sums;
// the output saturate_cast<uchar> (round half to even).
class WeightedSums {
public:
    WeightedSums(PrepareWorkspace::Buffers& b, std::size_t in_h, std::size_t in_w, std::size_t out_h, std::size_t out_w)
        : b_(b), in_w_(in_w), out_w_(out_w), xtab_(area_taps(in_w, out_w)), ytab_(area_taps(in_h, out_h)) {
        b_.row_weights.assign(out_w, 0.f);
        b_.sums.assign(out_w, 0.f);
        if (!ytab_.empty()) current_out_ = ytab_.front().out;
    }

    void add(std::size_t y, const std::uint8_t* row, const std::uint8_t* lut, std::uint8_t* scratch,
             std::uint8_t* small) {
        while (next_ < ytab_.size() && ytab_[next_].in < y) ++next_;  // rows without a tap
        if (next_ >= ytab_.size() || ytab_[next_].in != y) return;
        const std::uint8_t* values = row;
        if (lut) {
            for (std::size_t x = 0; x < in_w_; ++x) scratch[x] = lut[row[x]];
            values = scratch;
        }
        float* buf = b_.row_weights.data();
        std::fill(buf, buf + out_w_, 0.f);
        for (const AreaTap& t : xtab_) buf[t.out] += static_cast<float>(values[t.in]) * t.alpha;
        float* sum = b_.sums.data();
        for (; next_ < ytab_.size() && ytab_[next_].in == y; ++next_) {
            const AreaTap& t = ytab_[next_];
            if (t.out != current_out_) {
                std::uint8_t* out = small + current_out_ * out_w_;
                for (std::size_t x = 0; x < out_w_; ++x) {
                    out[x] = saturate_u8(static_cast<double>(round_even(sum[x])));
                    sum[x] = t.alpha * buf[x];
                }
                current_out_ = t.out;
            } else {
                for (std::size_t x = 0; x < out_w_; ++x) sum[x] += t.alpha * buf[x];
            }
        }
    }

    void finish(std::uint8_t* small) const {
        const float* sum = b_.sums.data();
        std::uint8_t* out = small + current_out_ * out_w_;
        for (std::size_t x = 0; x < out_w_; ++x) out[x] = saturate_u8(static_cast<double>(round_even(sum[x])));
    }

private:
    PrepareWorkspace::Buffers& b_;
    std::size_t in_w_, out_w_;
    std::vector<AreaTap> xtab_, ytab_;
    std::size_t next_ = 0;
    std::size_t current_out_ = 0;
};

// cv2.equalizeHist's table from a histogram of `total` pixels.
void equalization_table(const std::uint32_t* counts, std::size_t total, std::uint8_t* lut) {
    std::size_t darkest = 0;
    while (counts[darkest] == 0) ++darkest;  // total > 0: some level is present
    if (counts[darkest] == total) {          // one level: the frame keeps it
        std::fill(lut, lut + 256, static_cast<std::uint8_t>(darkest));
        return;
    }
    const float scale = 255.f / static_cast<float>(static_cast<std::int64_t>(total - counts[darkest]));
    std::fill(lut, lut + darkest + 1, std::uint8_t{0});
    std::int64_t above = 0;
    for (std::size_t v = darkest + 1; v < 256; ++v) {
        above += counts[v];
        lut[v] = saturate_u8(static_cast<double>(round_even(static_cast<float>(above) * scale)));
    }
}

void check_settings(const FrameView& frame, const PrepareSettings& s) {
    validate(s);
    if (s.equalize == Equalization::clahe) {
        throw std::invalid_argument("the core equalizes 'global' or 'none', not 'clahe' (CLAHE runs in OpenCV)");
    }
    if (frame.data == nullptr) throw std::invalid_argument("frame data is null");
    if (frame.height == 0 || frame.width == 0) throw std::invalid_argument("frame is empty (zero rows or columns)");
    const std::size_t channels = pixel_bytes(frame.order);
    if (channels == 0) throw std::invalid_argument("unknown pixel order");
    if (frame.width > std::numeric_limits<std::size_t>::max() / channels || frame.row_stride < frame.width * channels) {
        throw std::invalid_argument("frame row stride (" + std::to_string(frame.row_stride) +
                                    " bytes) is shorter than a row of " + std::to_string(frame.width) + " pixels");
    }
    if (s.crop_top >= frame.height || s.crop_bottom >= frame.height - s.crop_top || s.crop_left >= frame.width ||
        s.crop_right >= frame.width - s.crop_left) {
        throw std::invalid_argument("crop (top " + std::to_string(s.crop_top) + ", bottom " +
                                    std::to_string(s.crop_bottom) + ", left " + std::to_string(s.crop_left) +
                                    ", right " + std::to_string(s.crop_right) + ") removes the whole " +
                                    std::to_string(frame.height) + " x " + std::to_string(frame.width) + " frame");
    }
    const std::size_t h = frame.height - s.crop_top - s.crop_bottom, w = frame.width - s.crop_left - s.crop_right;
    if (w > kMaxFrameWidth) {
        throw std::invalid_argument("frame of " + std::to_string(w) + " columns is too wide (at most 2^24)");
    }
    if (h > kMaxFramePixels / w) {
        throw std::invalid_argument("frame of " + std::to_string(h) + " x " + std::to_string(w) +
                                    " pixels is too large (at most 2^31 pixels)");
    }
    if (s.height > h || s.width > w) {
        throw std::invalid_argument("output " + std::to_string(s.width) + " x " + std::to_string(s.height) +
                                    " is larger than the cropped " + std::to_string(w) + " x " + std::to_string(h) +
                                    " frame; prepare_frame only downsamples");
    }
}

}  // namespace

const char* equalization_name(std::size_t index) noexcept {
    static const char* const kNames[] = {"none", "global", "clahe"};  // Equalization's values
    return index < sizeof kNames / sizeof kNames[0] ? kNames[index] : nullptr;
}

namespace {

std::vector<SettingField<PrepareSettings>> make_fields() {
    using S = PrepareSettings;
    using K = SettingKind;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
    constexpr SettingRange kPixels{0, kInf, false, false, false, kNone, ""};
    constexpr SettingRange kSize{1, kInf, false, false, false, kNone, ""};
    return {
        setting<&S::crop_top>({"crop_top", K::count, "pixels", "rows removed at the top", kPixels}),
        setting<&S::crop_bottom>({"crop_bottom", K::count, "pixels", "rows removed at the bottom", kPixels}),
        setting<&S::crop_left>({"crop_left", K::count, "pixels", "columns removed at the left", kPixels}),
        setting<&S::crop_right>({"crop_right", K::count, "pixels", "columns removed at the right", kPixels}),
        setting<&S::equalize>({"equalize", K::choice, "",
                               "histogram equalization of the cropped grey frame (clahe: OpenCV's, not in the core)",
                               SettingRange{}, &equalization_name}),
        setting<&S::width>({"width", K::count, "pixels", "columns of the prepared image (Rx)", kSize}),
        setting<&S::height>({"height", K::count, "pixels", "rows of the prepared image (Ry)", kSize}),
        setting<&S::patch_normalize>(
            {"patch_normalize", K::flag, "", "patch normalization (eq. 1) after downsampling"}),
        setting<&S::radius>({"radius", K::integer, "pixels", "patch-normalization window radius P",
                             SettingRange{0, kMaxPatchRadius, false, false, false, kNone, ""}}),
        setting<&S::wrap>({"wrap", K::flag, "", "the window wraps horizontally (360-degree panoramas)"}),
        setting<&S::scale>({"scale", K::real, "",
                            "quantization gain of patch normalization (grey levels per "
                            "standard deviation)",
                            SettingRange{0, kInf, true, false, false, kNone, ""}}),
    };
}

}  // namespace

template <>
const std::vector<SettingField<PrepareSettings>>& setting_fields<PrepareSettings>() {
    static const std::vector<SettingField<PrepareSettings>> fields = make_fields();
    return fields;
}

// Every field of PrepareSettings has its row (LP64: four crops, equalize padded, width, height,
// patch_normalize packed with radius, wrap padded, scale).
static_assert(sizeof(std::size_t) != 8 || sizeof(PrepareSettings) == 80,
              "a field of PrepareSettings was added or removed: change its row in make_fields() and this size");

void validate(const PrepareSettings& s) {
    check_ranges(s);
    if (s.width > kMaxImagePixels / s.height) {
        throw SettingError("width", "x height = " + std::to_string(s.width) + "x" + std::to_string(s.height) +
                                        " is too large: prepared images hold at most " +
                                        std::to_string(kMaxImagePixels) + " pixels (the paper uses 48x24)");
    }
}

DownsampleMethod downsample_method(std::size_t in_height, std::size_t in_width, std::size_t out_height,
                                   std::size_t out_width) noexcept {
    if (in_height == 0 || in_width == 0 || out_height == 0 || out_width == 0) return DownsampleMethod::unsupported;
    if (in_height < out_height || in_width < out_width) return DownsampleMethod::unsupported;
    if (in_height == out_height && in_width == out_width) return DownsampleMethod::copy;
    if (in_height % out_height == 0 && in_width % out_width == 0) {
        // cv2.resize takes its fast path when 1 / (out / in) is the integer factor exactly
        auto exact = [](std::size_t n_in, std::size_t n_out) {
            const double scale = 1.0 / (static_cast<double>(n_out) / static_cast<double>(n_in));
            return scale == static_cast<double>(n_in / n_out);
        };
        return exact(in_height, out_height) && exact(in_width, out_width) ? DownsampleMethod::blocks
                                                                          : DownsampleMethod::weights;
    }
    if (in_height * in_width < kIntegralMinPixels) return DownsampleMethod::weights;
    return DownsampleMethod::integral;
}

// long: one frame's two passes (grey and histogram, then the downsample by one of four methods)
// share the crop, the equalization table and the row converter
void prepare_frame(const FrameView& frame, const PrepareSettings& s, std::uint8_t* out, PrepareWorkspace& workspace) {
    check_settings(frame, s);
    if (out == nullptr) throw std::invalid_argument("output pointer is null");
    if (workspace.buffers_ == nullptr) workspace.buffers_ = new PrepareWorkspace::Buffers;
    PrepareWorkspace::Buffers& b = *workspace.buffers_;
    const detail::PrepareKernels& k = detail::prepare_kernels(active_simd_backend());

    const std::size_t channels = pixel_bytes(frame.order);
    const std::size_t h = frame.height - s.crop_top - s.crop_bottom;
    const std::size_t w = frame.width - s.crop_left - s.crop_right;
    const std::uint8_t* origin = frame.data + s.crop_top * frame.row_stride + s.crop_left * channels;
    const bool colour = frame.order != PixelOrder::grey;

    // Pass 1: grey frame (colour input) and its histogram.
    std::uint8_t lut_storage[256];
    const std::uint8_t* lut = nullptr;
    const std::uint8_t* grey_rows = origin;  // row y at grey_rows + y * grey_stride
    std::size_t grey_stride = frame.row_stride;
    if (s.equalize == Equalization::global) {
        std::uint32_t counts[detail::kHistogramCopies * 256] = {};
        if (colour) {
            b.grey.resize(h * w);
            for (std::size_t y = 0; y < h; ++y) {
                std::uint8_t* g = b.grey.data() + y * w;
                k.grey_row(origin + y * frame.row_stride, w, frame.order, g);
                k.histogram_row(g, w, counts);
            }
            grey_rows = b.grey.data();
            grey_stride = w;
        } else {
            for (std::size_t y = 0; y < h; ++y) k.histogram_row(origin + y * frame.row_stride, w, counts);
        }
        for (std::size_t c = 1; c < detail::kHistogramCopies; ++c) {
            for (std::size_t v = 0; v < 256; ++v) counts[v] += counts[c * 256 + v];
        }
        equalization_table(counts, h * w, lut_storage);
        lut = lut_storage;
    }
    const bool convert_rows = colour && lut == nullptr;  // no grey frame was made in pass 1
    b.row.resize(w);  // the converted row, or (with a table) the equalized row of the weights method

    // Pass 2: downsample.
    const DownsampleMethod method = downsample_method(h, w, s.height, s.width);
    b.small.resize(s.height * s.width);
    std::uint8_t* small = b.small.data();
    auto grey_row = [&](std::size_t y) -> const std::uint8_t* {
        if (!convert_rows) return grey_rows + y * grey_stride;
        k.grey_row(origin + y * frame.row_stride, w, frame.order, b.row.data());
        return b.row.data();
    };
    switch (method) {
        case DownsampleMethod::copy:
            for (std::size_t y = 0; y < h; ++y) {
                const std::uint8_t* g = grey_row(y);
                std::uint8_t* o = small + y * w;
                if (lut) {
                    for (std::size_t x = 0; x < w; ++x) o[x] = lut[g[x]];
                } else {
                    std::copy(g, g + w, o);
                }
            }
            break;
        case DownsampleMethod::integral:
        case DownsampleMethod::blocks: {
            CutSums sums(b, k, method, h, w, s.height, s.width);
            for (std::size_t y = 0; y < h; ++y) sums.add(y, grey_row(y), lut);
            sums.finish(small);
            break;
        }
        case DownsampleMethod::weights: {
            WeightedSums sums(b, h, w, s.height, s.width);
            for (std::size_t y = 0; y < h; ++y) sums.add(y, grey_row(y), lut, b.row.data(), small);
            sums.finish(small);
            break;
        }
        case DownsampleMethod::unsupported:
            throw std::invalid_argument("prepare_frame only downsamples");  // checked above
    }

    if (s.patch_normalize) {
        patch_normalize(small, out, 1, s.height, s.width, s.radius, s.wrap, s.scale);
    } else {
        std::copy(small, small + s.height * s.width, out);
    }
}

void prepare_frame(const FrameView& frame, const PrepareSettings& settings, std::uint8_t* out) {
    PrepareWorkspace workspace;
    prepare_frame(frame, settings, out, workspace);
}

std::vector<std::uint8_t> prepare_frame(const FrameView& frame, const PrepareSettings& settings) {
    std::vector<std::uint8_t> out(settings.height * settings.width);
    PrepareWorkspace workspace;
    prepare_frame(frame, settings, out.data(), workspace);
    return out;
}

}  // namespace nightloc
