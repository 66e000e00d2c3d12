// Camera-frame preparation (the paper's section III-A, docs/design.md step 2) without OpenCV:
// crop -> grey -> global histogram equalization (or none) -> area downsample -> patch
// normalization, in two passes over the full-resolution frame (grey + histogram, then the
// equalization table + area sums), for robot firmware that links nightloc::core.
//
//   nightloc::PrepareSettings settings;          // 48 x 24, equalized, patch-normalized (Table II)
//   nightloc::PrepareWorkspace workspace;        // reused buffers: no allocation per frame
//   std::uint8_t prepared[24 * 48];
//   nightloc::prepare_frame({bgr, 480, 640, 640 * 3, nightloc::PixelOrder::bgr}, settings, prepared, workspace);
//
// The result is bit-identical to nightloc's Python pipeline (python/nightloc/preparation/preparer.py:
// cv2.cvtColor, cv2.equalizeHist, its area downsample and nightloc.patch_normalize) for 8-bit
// frames; the arithmetic of each step is documented below. CLAHE, 16-bit frames and upsampling
// (a frame smaller than the output) are not implemented here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "nightloc/normalize.hpp"
#include "nightloc/settings.hpp"

namespace nightloc {

/// Channel layout of an 8-bit frame; pixels are packed (1, 3 or 4 bytes each).
enum class PixelOrder : int { grey = 0, bgr = 1, rgb = 2, bgra = 3, rgba = 4 };

/// Bytes per pixel of a layout (1, 3 or 4).
std::size_t pixel_bytes(PixelOrder order) noexcept;

/// Histogram equalization before downsampling (the names: equalization_name).
enum class Equalization : int {
    none = 0,    ///< grey levels unchanged
    global = 1,  ///< cv2.equalizeHist of the cropped grey frame
    clahe = 2,   ///< OpenCV's CLAHE: a valid setting that prepare_frame does not implement (it throws)
};

/// The name of Equalization value `index` ("none", "global", "clahe"), nullptr past the last: the
/// names' one table (PrepareSettings::equalize's choices, Python's PreparationParams.equalize).
const char* equalization_name(std::size_t index) noexcept;

/// A borrowed 8-bit frame: `height` rows of `width` packed pixels, row r at data + r * row_stride.
struct FrameView {
    const std::uint8_t* data = nullptr;
    std::size_t height = 0;
    std::size_t width = 0;
    std::size_t row_stride = 0;  ///< bytes from one row to the next (>= width * pixel_bytes(order))
    PixelOrder order = PixelOrder::grey;
};

/// What prepare_frame does; the defaults are the paper's (Table II), and nightloc.PreparationParams
/// takes its defaults from here. Every field has its row in setting_fields<PrepareSettings>()
/// (cpp/src/preparation/prepare.cpp); validate() checks the ranges.
struct PrepareSettings {
    std::size_t crop_top = 0, crop_bottom = 0, crop_left = 0, crop_right = 0;  ///< pixels removed
    Equalization equalize = Equalization::global;
    std::size_t width = 48;             ///< output columns (Rx)
    std::size_t height = 24;            ///< output rows (Ry)
    bool patch_normalize = true;        ///< patch normalization (eq. 1) after downsampling
    int radius = 4;                     ///< patch radius P (a (2P+1)^2 window)
    bool wrap = true;                   ///< window wraps horizontally (360-degree panoramas)
    double scale = kDefaultPatchScale;  ///< quantization gain of patch_normalize
};

/// The settings' table (nightloc/settings.hpp), in declaration order.
template <>
const std::vector<SettingField<PrepareSettings>>& setting_fields<PrepareSettings>();

/// Throws SettingError naming the first setting out of its range, and the range (the table's:
/// an output size of zero, radius outside [0, kMaxPatchRadius], a scale that is not positive and
/// finite, an unknown equalization), or an output of more than kMaxImagePixels pixels (what the
/// matcher takes).
void validate(const PrepareSettings& settings);

/// Largest frame prepare_frame accepts, in pixels after cropping (2^31).
inline constexpr std::size_t kMaxFramePixels = std::size_t{1} << 31;
/// Widest frame prepare_frame accepts, in columns after cropping (2^24).
inline constexpr std::size_t kMaxFrameWidth = std::size_t{1} << 24;

/// How the area downsample of an in_height x in_width grey image to out_height x out_width is
/// computed (the same choice as nightloc.preparation.downsample.area_downsample):
enum class DownsampleMethod : int {
    copy = 0,         ///< same size: the image itself
    integral = 1,     ///< >= 65 536 input pixels, a non-integer factor: exact area sums from an
                      ///< integral image at fractional cell edges, float64 means, round half to even
    blocks = 2,       ///< integer factors fy x fx whose double reciprocals round-trip, 1 / (out / in)
                      ///< == in / out (cv2.resize INTER_AREA's fast path): exact block sums s,
                      ///< out = round_half_even(float32(s) * (1.f / (fx * fy))); 2 x 2 blocks:
                      ///< (s + 2) >> 2
    weights = 3,      ///< < 65 536 input pixels with a non-integer factor, or integer factors that
                      ///< do not round-trip (cv2.resize INTER_AREA's general path): float32
                      ///< per-pixel weights, float32 row sums, float32 sums of weighted rows
    unsupported = 4,  ///< the output is larger than the input along an axis (upsampling)
};

/// The method used for a downsample (see DownsampleMethod); `unsupported` for zero sizes.
DownsampleMethod downsample_method(std::size_t in_height, std::size_t in_width, std::size_t out_height,
                                   std::size_t out_width) noexcept;

/// Reusable buffers of prepare_frame (a grey copy of the frame, band sums, tables). One
/// workspace serves one thread at a time; it keeps its largest buffers between calls.
class PrepareWorkspace {
public:
    PrepareWorkspace();
    ~PrepareWorkspace();
    PrepareWorkspace(const PrepareWorkspace&) = delete;
    PrepareWorkspace& operator=(const PrepareWorkspace&) = delete;
    PrepareWorkspace(PrepareWorkspace&&) noexcept;
    PrepareWorkspace& operator=(PrepareWorkspace&&) noexcept;

    /// Bytes held by the buffers now.
    std::size_t capacity_bytes() const noexcept;
    /// Frees the buffers (the next call allocates again).
    void release() noexcept;

    struct Buffers;

private:
    Buffers* buffers_;
    friend void prepare_frame(const FrameView&, const PrepareSettings&, std::uint8_t*, PrepareWorkspace&);
};

/// Prepares one frame into `out` (settings.height x settings.width bytes, row-major):
///  1. crop: the rows and columns given by the crop_* settings are removed;
///  2. grey: a grey frame is used as is; BGR(A)/RGB(A) become
///     (3735 B + 19235 G + 9798 R + 16384) >> 15 (cv2.cvtColor's 8-bit fixed point);
///  3. equalization (global): lut[v] = round_half_even(float32(#pixels in (d, v]) *
///     (255.f / float32(#pixels above d))) for the darkest level d present (lut[d] = 0); a frame
///     of one level keeps it (cv2.equalizeHist);
///  4. area downsample to settings.width x settings.height, see DownsampleMethod;
///  5. patch normalization (nightloc::patch_normalize) when settings.normalize.
/// Uses the SIMD path of active_simd_backend() (every path gives the same bytes).
/// Throws std::invalid_argument for a null or empty frame, a row stride shorter than a row, a
/// crop that removes the whole frame, more than kMaxFramePixels pixels or kMaxFrameWidth
/// columns, settings that validate() refuses, CLAHE, or an output larger than the cropped frame
/// (upsampling).
void prepare_frame(const FrameView& frame, const PrepareSettings& settings, std::uint8_t* out,
                   PrepareWorkspace& workspace);

/// The same with a temporary workspace (allocates per call).
void prepare_frame(const FrameView& frame, const PrepareSettings& settings, std::uint8_t* out);

/// Convenience: one frame in, the prepared settings.height x settings.width image out.
std::vector<std::uint8_t> prepare_frame(const FrameView& frame, const PrepareSettings& settings = {});

}  // namespace nightloc
