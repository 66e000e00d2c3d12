// nightloc_replay MAP LOG OUT.csv: the default localizer of nightloc on a recorded log, without
// Python: what `nightloc localize MAP LOG` computes, from the map file `nightloc build-map` wrote.
//
//   nightloc_replay [--overwrite] garden.map night_log trajectory.csv
//
// LOG is a folder holding images/ (binary PGM or PPM frames, 8-bit, in natural name order:
// frame2 before frame10) and odometry.csv with the columns image,forward,left,turn (wheel
// odometry since the previous frame: metres, metres, radians counter-clockwise) or image,dx,dy
// (map frame), one row per frame in the frames' order; other columns are ignored. The filter
// assumes the map's odometry noise, or for wheel odometry kWheelOdometryNoise (as `nightloc localize`). OUT.csv gets
// image,x,y,heading,confidence,credible_radius per frame (metres, radians; heading nan without map
// headings), written to a temporary file beside it and renamed (an existing file is replaced only
// with --overwrite). The time per frame (preparation and filter) is printed on stderr. Errors name
// the file (and the CSV line) and exit with status 2.
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "nightloc/localizer.hpp"
#include "nightloc/map_file.hpp"
#include "nightloc/simd.hpp"
#include "pnm.hpp"

namespace {

struct Failure : std::runtime_error {
    using std::runtime_error::runtime_error;
};

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

std::string trim(const std::string& s) {
    std::size_t a = 0, b = s.size();
    while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
    while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
    return s.substr(a, b - a);
}

// One CSV record's fields (RFC 4180 quotes; a record is one line here).
std::vector<std::string> csv_fields(const std::string& line, const std::string& where) {
    std::vector<std::string> fields(1);
    bool quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (quoted) {
            if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
                fields.back() += '"';
                ++i;
            } else if (c == '"') {
                quoted = false;
            } else {
                fields.back() += c;
            }
        } else if (c == '"') {
            quoted = true;
        } else if (c == ',') {
            fields.emplace_back();
        } else {
            fields.back() += c;
        }
    }
    if (quoted) throw Failure(where + ": unterminated quoted field");
    return fields;
}

// Python's natural_key order: runs of digits compare as numbers, other text case-insensitively.
bool natural_less(const std::string& a, const std::string& b) {
    auto parts = [](const std::string& s) {
        std::vector<std::string> out(1);  // text, digits, text, ... (the first and last text may be empty)
        bool digits = false;
        for (const char c : s) {
            const bool d = c >= '0' && c <= '9';
            if (d != digits) {
                out.emplace_back();
                digits = d;
            }
            out.back() += c;
        }
        if (digits) out.emplace_back();
        return out;
    };
    const auto pa = parts(a), pb = parts(b);
    for (std::size_t k = 0; k < std::min(pa.size(), pb.size()); ++k) {
        const std::string &x = pa[k], &y = pb[k];
        if (k % 2 == 1) {  // digits: by value, then by text ("01" before "1")
            const std::size_t zx = std::min(x.find_first_not_of('0'), x.size()),
                              zy = std::min(y.find_first_not_of('0'), y.size());
            const std::string vx = x.substr(zx), vy = y.substr(zy);
            if (vx.size() != vy.size()) return vx.size() < vy.size();
            if (vx != vy) return vx < vy;
            if (x != y) return x < y;
        } else {
            const std::string lx = lower(x), ly = lower(y);
            if (lx != ly) return lx < ly;
            if (x != y) return x < y;
        }
    }
    return pa.size() < pb.size();
}

// The frames of LOG/images: PGM/PPM files (other image files are refused), natural order.
std::vector<std::string> list_frames(const std::string& folder) {
    static const char* image_suffixes[] = {".png",  ".jpg",  ".jpeg", ".jpe", ".bmp",  ".dib",  ".tif",
                                           ".tiff", ".webp", ".pgm",  ".ppm", ".pbm",  ".pnm",  ".pxm",
                                           ".sr",   ".ras",  ".jp2",  ".gif", ".apng", ".avif", ".pam"};
    DIR* dir = opendir(folder.c_str());
    if (dir == nullptr) throw Failure(folder + ": cannot be listed (" + std::strerror(errno) + "); LOG needs images/");
    std::vector<std::string> names;
    std::string refused;
    while (const dirent* entry = readdir(dir)) {
        const std::string name = entry->d_name;
        if (name.empty() || name[0] == '.') continue;
        const std::size_t dot = name.rfind('.');
        const std::string suffix = dot == std::string::npos ? "" : lower(name.substr(dot));
        const bool image = std::find_if(std::begin(image_suffixes), std::end(image_suffixes),
                                        [&](const char* s) { return suffix == s; }) != std::end(image_suffixes);
        if (!image) continue;
        struct stat info{};
        if (::stat((folder + "/" + name).c_str(), &info) != 0 || S_ISDIR(info.st_mode)) continue;
        if (suffix != ".pgm" && suffix != ".ppm" && suffix != ".pnm") {
            if (refused.empty()) refused = name;
            continue;
        }
        names.push_back(name);
    }
    closedir(dir);
    if (!refused.empty()) {
        throw Failure(folder + "/" + refused +
                      ": only binary PGM/PPM frames are read by the firmware path (convert the log's images, e.g. "
                      "with OpenCV's cv2.imwrite(name + '.pgm', image))");
    }
    if (names.empty()) throw Failure(folder + " holds no .pgm or .ppm frames");
    std::sort(names.begin(), names.end(), natural_less);
    return names;
}

double finite_number(const std::string& text, const std::string& column, const std::string& where) {
    const std::string t = trim(text);
    char* end = nullptr;
    const double v = t.empty() ? 0.0 : std::strtod(t.c_str(), &end);
    if (t.empty() || end != t.c_str() + t.size()) {
        throw Failure(where + ": column '" + column + "' holds '" + text + "', not a number");
    }
    if (!std::isfinite(v)) throw Failure(where + ": column '" + column + "' is " + t + "; odometry must be finite");
    return v;
}

struct OdometryRow {
    nightloc::Motion motion;
    int line = 0;
};

// LOG/odometry.csv: one motion per image name.
std::map<std::string, OdometryRow> read_odometry(const std::string& path, std::vector<std::string>& order) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw Failure(path +
                      " does not exist or cannot be read; a log needs one row per frame: "
                      "image,forward,left,turn (wheel odometry) or image,dx,dy (map frame)");
    }
    std::map<std::string, OdometryRow> rows;
    std::vector<std::string> header;
    std::size_t key = 0;
    std::vector<std::size_t> columns;
    bool robot = true;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        if (number == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string where = path + " line " + std::to_string(number);
        const auto fields = csv_fields(line, where);
        if (std::all_of(fields.begin(), fields.end(), [](const std::string& f) { return trim(f).empty(); })) continue;
        if (header.empty()) {
            for (const auto& f : fields) header.push_back(lower(trim(f)));
            const auto find = [&](const char* name) {
                return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
            };
            key = find("image");
            if (key == header.size())
                throw Failure(where +
                              ": missing column 'image'; the header must be image,forward,left,turn or image,dx,dy");
            if (find("forward") < header.size() && find("left") < header.size() && find("turn") < header.size()) {
                columns = {find("forward"), find("left"), find("turn")};
            } else if (find("dx") < header.size() && find("dy") < header.size()) {
                robot = false;
                columns = {find("dx"), find("dy")};
            } else {
                throw Failure(where +
                              ": the header has neither forward,left,turn (wheel odometry) nor dx,dy (map frame)");
            }
            continue;
        }
        if (fields.size() != header.size()) {
            throw Failure(where + ": " + std::to_string(fields.size()) + " fields, but the header has " +
                          std::to_string(header.size()));
        }
        const std::string name = trim(fields[key]);
        if (name.empty()) throw Failure(where + ": column 'image' is empty");
        if (rows.count(name)) {
            throw Failure(where + ": image '" + name + "' is listed twice (line " + std::to_string(rows[name].line) +
                          ")");
        }
        OdometryRow row;
        row.line = number;
        std::vector<double> v;
        for (std::size_t c = 0; c < columns.size(); ++c)
            v.push_back(finite_number(fields[columns[c]], header[columns[c]], where));
        for (std::size_t c = 0; c < 2; ++c) {
            if (std::fabs(v[c]) >= 1e8)
                throw Failure(where + ": column '" + header[columns[c]] + "' is beyond 1e8 metres");
        }
        if (robot) {
            if (std::fabs(v[2]) > 2.0 * M_PI) {
                throw Failure(where + ": column 'turn' is " + std::to_string(v[2]) +
                              ", beyond a full turn (2 pi = 6.283): angles are radians, counter-clockwise");
            }
            row.motion = nightloc::Motion::robot(v[0], v[1], v[2]);
        } else {
            row.motion = nightloc::Motion::map(v[0], v[1]);
        }
        rows[name] = row;
        order.push_back(name);
    }
    if (header.empty() || rows.empty())
        throw Failure(path + " has no odometry rows; it needs a header and one row per frame");
    return rows;
}

std::string number(double v, int digits) {
    if (std::isnan(v)) return "nan";
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
    return buffer;
}

int run(int argc, char** argv) {
    bool overwrite = false;
    std::vector<std::string> args;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--overwrite")
            overwrite = true;
        else if (a == "-h" || a == "--help") {
            std::printf("usage: nightloc_replay [--overwrite] MAP LOG OUT.csv\n");
            return 0;
        } else
            args.push_back(a);
    }
    if (args.size() != 3) throw Failure("usage: nightloc_replay [--overwrite] MAP LOG OUT.csv");
    const std::string &map_path = args[0], &log = args[1], &out_path = args[2];
    struct stat info{};
    if (::stat(out_path.c_str(), &info) == 0) {
        if (S_ISDIR(info.st_mode)) throw Failure(out_path + " is a folder; OUT is the CSV file to write");
        if (!overwrite) throw Failure(out_path + " exists; pass --overwrite to replace it");
    }
    const nightloc::MapFile map = nightloc::load_map_file(map_path);
    nightloc::Localizer localizer(map);
    std::vector<std::string> order;
    const std::string odometry_path = log + "/odometry.csv";
    const auto rows = read_odometry(odometry_path, order);
    const auto frames = list_frames(log + "/images");
    // a log of wheel odometry: the step-scaled noise `nightloc localize` assumes for it
    if (std::any_of(rows.begin(), rows.end(),
                    [](const auto& row) { return row.second.motion.kind == nightloc::Motion::Kind::robot; })) {
        localizer.set_noise(nightloc::kWheelOdometryNoise);
    }
    // every frame has a row, and the rows list exactly the frames, in their order
    for (const auto& name : frames) {
        if (!rows.count(name)) throw Failure(odometry_path + " has no row for image '" + name + "'");
    }
    if (order.size() != frames.size()) {
        for (const auto& name : order) {
            if (!std::binary_search(frames.begin(), frames.end(), name, natural_less)) {
                throw Failure(odometry_path + " line " + std::to_string(rows.at(name).line) + ": image '" + name +
                              "' is not in " + log + "/images");
            }
        }
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
        if (order[k] != frames[k]) {
            throw Failure(odometry_path + " line " + std::to_string(rows.at(order[k]).line) + ": image '" + order[k] +
                          "' is out of the frames' order (natural name order: '" + frames[k] +
                          "' comes here); rows must be in the order the frames were recorded");
        }
    }
    std::vector<nightloc::LocalizerEstimate> estimates;
    estimates.reserve(frames.size());
    nightloc_app::PnmImage image;
    double seconds = 0;
    for (const auto& name : frames) {
        const std::string file = log + "/images/" + name;
        nightloc_app::read_pnm(file, image);
        const nightloc::FrameView view{image.pixels.data(), image.height, image.width, image.width * image.channels,
                                       image.channels == 1 ? nightloc::PixelOrder::grey : nightloc::PixelOrder::rgb};
        const auto start = std::chrono::steady_clock::now();
        try {
            estimates.push_back(localizer.update(view, rows.at(name).motion));
        } catch (const std::invalid_argument& error) {
            throw Failure(file + ": " + error.what());
        }
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    // the whole file, then one rename: never a half-written OUT
    const std::string temporary = out_path + ".tmp-" + std::to_string(::getpid());
    {
        std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
        if (!out) throw Failure(temporary + ": cannot be written (" + std::strerror(errno) + ")");
        out << "image,x,y,heading,confidence,credible_radius\n";
        for (std::size_t k = 0; k < frames.size(); ++k) {
            const auto& e = estimates[k];
            out << frames[k] << ',' << number(e.x, 9) << ',' << number(e.y, 9) << ',' << number(e.heading, 9) << ','
                << number(e.confidence, 9) << ',' << number(e.credible_radius, 9) << '\n';
        }
        out.flush();
        if (!out) {
            std::remove(temporary.c_str());
            throw Failure(temporary + ": write failed");
        }
    }
    if (std::rename(temporary.c_str(), out_path.c_str()) != 0) {
        std::remove(temporary.c_str());
        throw Failure(out_path + ": cannot be written (" + std::strerror(errno) + ")");
    }
    std::fprintf(stderr, "%zu frames of %s localized against %zu references (SIMD path %s): %.3f ms per frame\n",
                 frames.size(), log.c_str(), map.count, nightloc::simd_backend_name(nightloc::active_simd_backend()),
                 1e3 * seconds / static_cast<double>(frames.size()));
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
