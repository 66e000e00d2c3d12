// Reading and checking a log for nightloc_replay (replay_log.hpp).
#include "replay_log.hpp"

#include <dirent.h>
#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>

#include "frame_files.hpp"

namespace nightloc_app {

namespace {

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

std::string stem(const std::string& name) { return name.substr(0, name.rfind('.')); }

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
    if (quoted) throw InputError(where + ": unterminated quoted field");
    return fields;
}

// A number cell: finite, or an error naming the file, line and column.
double finite_number(const std::string& text, const std::string& column, const std::string& where,
                     const char* meaning) {
    const std::string t = trim(text);
    char* end = nullptr;
    const double v = t.empty() ? 0.0 : std::strtod(t.c_str(), &end);
    if (t.empty() || end != t.c_str() + t.size()) {
        throw InputError(where + ": column '" + column + "' holds '" + text + "', not a number");
    }
    if (!std::isfinite(v)) throw InputError(where + ": column '" + column + "' is " + t + "; " + meaning);
    return v;
}

// The image files of LOG/images (not hidden, an image suffix, not a folder), in natural order.
std::vector<std::string> list_frames(const std::string& folder) {
    DIR* dir = opendir(folder.c_str());
    if (dir == nullptr) {
        throw InputError(folder + ": cannot be listed (" + std::strerror(errno) +
                         "); a log holds its frames in images/ beside odometry.csv");
    }
    std::vector<std::string> names;
    while (const dirent* entry = readdir(dir)) {
        const std::string name = entry->d_name;
        if (name.empty() || name[0] == '.' || !is_image_name(name)) continue;
        struct stat info{};
        if (::stat((folder + "/" + name).c_str(), &info) != 0 || S_ISDIR(info.st_mode)) continue;
        names.push_back(name);
    }
    closedir(dir);
    if (names.empty()) throw InputError(folder + " holds no frames");
    std::sort(names.begin(), names.end(), natural_less);
    return names;
}

struct OdometryRow {
    nightloc::Motion motion;
    std::string timestamp = "nan";
    int line = 0;
};

struct OdometryTable {
    std::map<std::string, OdometryRow> rows;  // by image name
    std::vector<std::string> order;           // the image names, in the rows' order
    bool wheel = true;
    bool timed = false;
};

// The columns of odometry.csv's header: the key, the motion's, and the optional timestamp.
struct OdometryColumns {
    std::vector<std::string> header;
    std::size_t key = 0, timestamp = 0;
    std::vector<std::size_t> motion;
    bool wheel = true;
};

OdometryColumns read_header(const std::vector<std::string>& fields, const std::string& where) {
    OdometryColumns c;
    for (const auto& f : fields) c.header.push_back(lower(trim(f)));
    const auto find = [&](const char* name) {
        return static_cast<std::size_t>(std::find(c.header.begin(), c.header.end(), name) - c.header.begin());
    };
    const std::size_t n = c.header.size();
    c.key = find("image");
    if (c.key == n) {
        throw InputError(where + ": missing column 'image'; the header must be image,forward,left,turn or image,dx,dy");
    }
    if (find("forward") < n && find("left") < n && find("turn") < n) {
        c.motion = {find("forward"), find("left"), find("turn")};
    } else if (find("dx") < n && find("dy") < n) {
        c.wheel = false;
        c.motion = {find("dx"), find("dy")};
    } else {
        throw InputError(where + ": the header has neither forward,left,turn (wheel odometry) nor dx,dy (map frame)");
    }
    c.timestamp = find("timestamp");
    return c;
}

OdometryRow read_row(const OdometryColumns& c, const std::vector<std::string>& fields, const std::string& where) {
    OdometryRow row;
    std::vector<double> v;
    for (const std::size_t column : c.motion) {
        v.push_back(finite_number(fields[column], c.header[column], where, "odometry must be finite"));
    }
    for (std::size_t k = 0; k < 2; ++k) {
        if (std::fabs(v[k]) >= 1e8)
            throw InputError(where + ": column '" + c.header[c.motion[k]] + "' is beyond 1e8 metres");
    }
    if (c.wheel) {
        if (std::fabs(v[2]) > 2.0 * M_PI) {
            throw InputError(where + ": column 'turn' is " + std::to_string(v[2]) +
                             ", beyond a full turn (2 pi = 6.283): angles are radians, counter-clockwise");
        }
        row.motion = nightloc::Motion::robot(v[0], v[1], v[2]);
    } else {
        row.motion = nightloc::Motion::map(v[0], v[1]);
    }
    if (c.timestamp < c.header.size()) {
        row.timestamp = trim(fields[c.timestamp]);
        finite_number(row.timestamp, "timestamp", where, "times must be finite seconds");
    }
    return row;
}

// LOG/odometry.csv: one motion (and time) per image name.
OdometryTable read_odometry(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw InputError(path +
                         " does not exist or cannot be read; a log needs one row per frame: "
                         "image,forward,left,turn (wheel odometry) or image,dx,dy (map frame)");
    }
    OdometryTable table;
    OdometryColumns columns;
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        if (number == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const std::string where = path + " line " + std::to_string(number);
        const auto fields = csv_fields(line, where);
        if (std::all_of(fields.begin(), fields.end(), [](const std::string& f) { return trim(f).empty(); })) continue;
        if (columns.header.empty()) {
            columns = read_header(fields, where);
            table.wheel = columns.wheel;
            table.timed = columns.timestamp < columns.header.size();
            continue;
        }
        if (fields.size() != columns.header.size()) {
            throw InputError(where + ": " + std::to_string(fields.size()) + " fields, but the header has " +
                             std::to_string(columns.header.size()));
        }
        const std::string name = trim(fields[columns.key]);
        if (name.empty()) throw InputError(where + ": column 'image' is empty");
        if (table.rows.count(name)) {
            throw InputError(where + ": image '" + name + "' is listed twice (line " +
                             std::to_string(table.rows[name].line) + ")");
        }
        OdometryRow row = read_row(columns, fields, where);
        row.line = number;
        if (!table.order.empty() && table.timed) {
            const OdometryRow& previous = table.rows.at(table.order.back());
            if (std::strtod(row.timestamp.c_str(), nullptr) < std::strtod(previous.timestamp.c_str(), nullptr)) {
                throw InputError(where + ": timestamp " + row.timestamp + " is before the previous frame's (" +
                                 previous.timestamp + ", line " + std::to_string(previous.line) +
                                 "); frames must be in the order they were recorded");
            }
        }
        table.rows[name] = row;
        table.order.push_back(name);
    }
    if (columns.header.empty() || table.rows.empty()) {
        throw InputError(path + " has no odometry rows; it needs a header and one row per frame");
    }
    return table;
}

// The rows list exactly the frames, in their order.
void check_rows_match_frames(const OdometryTable& table, const std::vector<std::string>& frames,
                             const std::string& odometry_path, const std::string& image_folder) {
    for (const auto& name : frames) {
        if (table.rows.count(name)) continue;
        std::string hint;
        for (const auto& listed : table.order) {
            if (stem(listed) == stem(name)) {
                hint = " (it lists '" + listed +
                       "': frames converted without renaming their rows; nightloc export-log converts both)";
                break;
            }
        }
        throw InputError(odometry_path + " has no row for image '" + name + "'" + hint);
    }
    if (table.order.size() != frames.size()) {
        for (const auto& name : table.order) {
            if (!std::binary_search(frames.begin(), frames.end(), name, natural_less)) {
                throw InputError(odometry_path + " line " + std::to_string(table.rows.at(name).line) + ": image '" +
                                 name + "' is not in " + image_folder);
            }
        }
    }
    for (std::size_t k = 0; k < frames.size(); ++k) {
        if (table.order[k] != frames[k]) {
            throw InputError(odometry_path + " line " + std::to_string(table.rows.at(table.order[k]).line) +
                             ": image '" + table.order[k] + "' is out of the frames' order (natural name order: '" +
                             frames[k] + "' comes here); rows must be in the order the frames were recorded");
        }
    }
}

// The first frame, in frame order, of a format this program does not read.
void check_formats(const std::vector<std::string>& frames, const std::string& log, const std::string& image_folder) {
    for (const auto& name : frames) {
        const FrameKind kind = frame_kind(name);
        if (kind == FrameKind::pnm || (kind == FrameKind::png && png_library_version() != nullptr)) continue;
        if (kind == FrameKind::png) throw InputError(image_folder + "/" + name + ": " + png_unavailable(log));
        throw InputError(image_folder + "/" + name + ": the firmware path reads PGM/PPM" +
                         (png_library_version() ? ", PNG" : "") +
                         " frames only; convert the log with `nightloc export-log " + log +
                         " NEW_LOG` (PGM/PPM frames, the odometry rows renamed to match) and replay NEW_LOG");
    }
}

}  // namespace

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

ReplayLog read_log(const std::string& log) {
    struct stat info{};
    if (::stat(log.c_str(), &info) != 0 || !S_ISDIR(info.st_mode)) {
        throw InputError(log + ": " + (::stat(log.c_str(), &info) != 0 ? "no such folder" : "not a folder") +
                         "; LOG is a log folder: images/ and odometry.csv, as nightloc synth writes them");
    }
    const std::string odometry_path = log + "/odometry.csv", image_folder = log + "/images";
    const OdometryTable table = read_odometry(odometry_path);
    ReplayLog result;
    result.frames = list_frames(image_folder);
    check_rows_match_frames(table, result.frames, odometry_path, image_folder);
    check_formats(result.frames, log, image_folder);
    result.wheel_odometry = table.wheel;
    for (const auto& name : result.frames) {
        const OdometryRow& row = table.rows.at(name);
        result.motions.push_back(row.motion);
        result.timestamps.push_back(row.timestamp);
    }
    return result;
}

}  // namespace nightloc_app
