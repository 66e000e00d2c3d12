// A recorded log as nightloc_replay reads it: LOG/images/ (the frames, in natural name order) and
// LOG/odometry.csv (one row per frame, in that order), the layout `nightloc synth`, `nightloc
// export-log` and `nightloc localize` share (python/nightloc/io/traverse.py).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "nightloc/localizer.hpp"

namespace nightloc_app {

/// A problem with the user's input: one line naming the file (and CSV line) and the fix.
struct InputError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// The frames of a log with their odometry, checked against each other.
struct ReplayLog {
    std::vector<std::string> frames;        ///< file names inside LOG/images, in natural name order
    std::vector<nightloc::Motion> motions;  ///< the odometry row of each frame (the first one's unused)
    std::vector<std::string> timestamps;    ///< each frame's `timestamp` cell as written (seconds), or "nan"
    bool wheel_odometry = true;             ///< rows are forward,left,turn (else map-frame dx,dy)
};

/// Reads and checks the log folder `log` (the path as the user gave it, which every message names).
/// Throws InputError for a missing folder, a bad odometry.csv (the line and column), rows that do
/// not list exactly the frames in their order, and the first frame (in frame order) this program
/// cannot read: another format than PGM/PPM (or PNG with libpng), saying how to convert the log.
ReplayLog read_log(const std::string& log);

/// Python's natural_key order (nightloc.io.images): runs of digits compare as numbers (frame2
/// before frame10), other text case-insensitively.
bool natural_less(const std::string& a, const std::string& b);

}  // namespace nightloc_app
