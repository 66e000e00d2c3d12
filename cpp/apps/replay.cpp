// nightloc_replay MAP LOG OUT.csv: nightloc's default localizer over a recorded log, without Python:
// what `nightloc localize MAP LOG` computes, from the map file `nightloc build-map` wrote. The log's
// layout and the output's columns: kHelp below (`nightloc_replay --help`).
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "frame_files.hpp"
#include "nightloc/localizer.hpp"
#include "nightloc/map_file.hpp"
#include "nightloc/simd.hpp"
#include "replay_log.hpp"

namespace {

using nightloc_app::InputError;

const char kUsage[] = "usage: nightloc_replay [--overwrite] MAP LOG OUT.csv";

const char kHelp[] = R"(
Runs nightloc's default localizer (the grid Bayes filter over position x heading) over every frame
of a recorded log with its odometry, without Python: the trajectory `nightloc localize MAP LOG`
computes (the same arithmetic: equal to its printed digits).

inputs:
  MAP       the map file `nightloc build-map` writes (or `nightloc localize --learn`); its
            preparation, grid and filter settings are those the filter uses
  LOG       a log folder as `nightloc synth` writes it and `nightloc localize` reads it:
              LOG/images/       the frames, in natural name order (frame2 before frame10):
                                binary PGM (P5, grey) or PPM (P6, colour), 8-bit; PNG (8-bit grey,
                                colour or palette; alpha ignored) where built with libpng (below)
              LOG/odometry.csv  one row per frame, in the frames' order: image,forward,left,turn
                                (wheel odometry since the previous frame: metres ahead, metres
                                left, radians counter-clockwise) or image,dx,dy (map frame,
                                metres); an optional timestamp column (seconds); others ignored
            Frames of other formats (JPEG, 16-bit, ...), or a log held in a video or a ROS bag:
            convert it first with `nightloc export-log LOG NEW_LOG` (PGM/PPM frames, the odometry
            rows renamed to match, the times kept) and replay NEW_LOG.

output:
  OUT.csv   image,x,y,heading,confidence,credible_radius,ref_index,timestamp, one row per frame:
            the columns of localize's trajectory.csv (metres, radians, 0..1, metres, the closest
            reference, seconds as in odometry.csv), 9 decimals; heading nan when the map has no
            headings, timestamp nan when odometry.csv has none. Written whole to a hidden file
            beside OUT.csv, then renamed into place; the folder of OUT.csv must exist.

options:
  --overwrite  replace an existing OUT.csv (else it is refused)
  -h, --help   this text

The filter assumes the map's odometry noise, or for wheel odometry 4 % of each step's length and
0.02 rad per step, as `nightloc localize` does. The time per frame (preparation and filter) is
printed on stderr. Bad input: one line on stderr naming the file (and the CSV line) and the fix,
exit status 2, nothing written.
)";

std::string number(double v, int digits) {
    if (std::isnan(v)) return "nan";
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
    return buffer;
}

void print_help() {
    std::printf("%s\n%s\n", kUsage, kHelp);
    const char* png = nightloc_app::png_library_version();
    if (png != nullptr) {
        std::printf("PNG frames: read (libpng %s)\n", png);
    } else {
        std::printf("PNG frames: not read (built without libpng; nightloc export-log converts a log)\n");
    }
}

std::string folder_of(const std::string& path) {
    const std::size_t slash = path.rfind('/');
    if (slash == std::string::npos) return ".";
    return slash == 0 ? "/" : path.substr(0, slash);
}

// OUT.csv can be written: its folder exists, it is not a folder, an existing file only with --overwrite.
void check_output(const std::string& out_path, bool overwrite) {
    struct stat info{};
    const std::string folder = folder_of(out_path);
    if (::stat(folder.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) {
        throw InputError("the folder of " + out_path + ", " + folder + ", " +
                         (::stat(folder.c_str(), &info) != 0 ? "does not exist" : "is not a folder") +
                         "; create it first (mkdir -p " + folder + ") or choose another OUT.csv");
    }
    if (::stat(out_path.c_str(), &info) == 0) {
        if (S_ISDIR(info.st_mode)) throw InputError(out_path + " is a folder; OUT is the CSV file to write");
        if (!overwrite) throw InputError(out_path + " exists; pass --overwrite to replace it");
    }
}

// The whole file under a hidden name beside OUT.csv, then one rename: never a half-written OUT.
void write_trajectory(const std::string& out_path, const nightloc_app::ReplayLog& log,
                      const std::vector<nightloc::LocalizerEstimate>& estimates) {
    const std::string folder = folder_of(out_path), name = out_path.substr(out_path.rfind('/') + 1);
    const std::string temporary = folder + "/." + name + ".tmp-" + std::to_string(::getpid());
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw InputError(out_path + ": cannot be written (" + std::strerror(errno) + ")");
        out << "image,x,y,heading,confidence,credible_radius,ref_index,timestamp\n";
        for (std::size_t k = 0; k < log.frames.size(); ++k) {
            const auto& e = estimates[k];
            out << log.frames[k] << ',' << number(e.x, 9) << ',' << number(e.y, 9) << ',' << number(e.heading, 9) << ','
                << number(e.confidence, 9) << ',' << number(e.credible_radius, 9) << ',' << e.ref_index << ','
                << log.timestamps[k] << '\n';
        }
        out.flush();
        if (!out) {
            std::remove(temporary.c_str());
            throw InputError(out_path + ": cannot be written (the disk is full?)");
        }
    }
    if (std::rename(temporary.c_str(), out_path.c_str()) != 0) {
        const int error = errno;
        std::remove(temporary.c_str());
        throw InputError(out_path + ": cannot be written (" + std::strerror(error) + ")");
    }
}

int run(int argc, char** argv) {
    bool overwrite = false;
    std::vector<std::string> args;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--overwrite") {
            overwrite = true;
        } else if (a == "-h" || a == "--help") {
            print_help();
            return 0;
        } else if (a.size() > 1 && a[0] == '-') {
            throw InputError("unknown option " + a + " (" + kUsage + "; --help for more)");
        } else {
            args.push_back(a);
        }
    }
    if (args.size() != 3) throw InputError(std::string(kUsage) + " (--help for more)");
    const std::string &map_path = args[0], &log_path = args[1], &out_path = args[2];
    check_output(out_path, overwrite);
    const nightloc::MapFile map = nightloc::load_map_file(map_path);
    nightloc::Localizer localizer(map);
    const nightloc_app::ReplayLog log = nightloc_app::read_log(log_path);
    // a log of wheel odometry: the step-scaled noise `nightloc localize` assumes for it
    if (log.wheel_odometry) localizer.set_noise(nightloc::kWheelOdometryNoise);
    std::vector<nightloc::LocalizerEstimate> estimates;
    estimates.reserve(log.frames.size());
    nightloc_app::FrameImage image;
    double seconds = 0;
    for (std::size_t k = 0; k < log.frames.size(); ++k) {
        const std::string file = log_path + "/images/" + log.frames[k];
        try {
            nightloc_app::read_frame(file, image);
        } catch (const std::runtime_error& error) {
            throw InputError(error.what());
        }
        const nightloc::FrameView view{image.pixels.data(), image.height, image.width, image.width * image.channels,
                                       image.channels == 1 ? nightloc::PixelOrder::grey : nightloc::PixelOrder::rgb};
        const auto start = std::chrono::steady_clock::now();
        try {
            estimates.push_back(localizer.update(view, log.motions[k]));
        } catch (const std::invalid_argument& error) {
            throw InputError(file + ": " + error.what());
        }
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    write_trajectory(out_path, log, estimates);
    std::fprintf(stderr, "%zu frames of %s localized against %zu references (SIMD path %s): %.3f ms per frame\n",
                 log.frames.size(), log_path.c_str(), map.count,
                 nightloc::simd_backend_name(nightloc::active_simd_backend()),
                 1e3 * seconds / static_cast<double>(log.frames.size()));
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const std::exception& error) {
        std::fprintf(stderr, "nightloc_replay: %s\n", error.what());
        return 2;
    }
}
