// nightloc_compare_trajectories ACTUAL.csv EXPECTED.csv TOLERANCE: exit 0 when two trajectory CSVs
// (image,x,y,heading,confidence,credible_radius, other columns ignored) list the same frames in the
// same order (their names without the suffix: a log and its copy in another image format) and every
// x, y, confidence and credible_radius agree within TOLERANCE and every heading within TOLERANCE
// radians around the circle (nan only with nan); else the differences are printed and the exit
// status is 1. Used by ctest to compare nightloc_replay with Python's trajectory.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct Table {
    std::vector<std::string> header;
    std::vector<std::vector<std::string>> rows;
};

bool read(const char* path, Table& t) {
    std::ifstream in(path);
    if (!in) {
        std::fprintf(stderr, "%s cannot be read\n", path);
        return false;
    }
    std::string line;
    while (std::getline(in, line)) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.empty()) continue;
        std::vector<std::string> fields;
        std::stringstream s(line);
        std::string f;
        while (std::getline(s, f, ',')) fields.push_back(f);
        (t.header.empty() ? t.header : t.rows.emplace_back()) = fields;
    }
    return true;
}

long column(const Table& t, const char* name) {
    for (std::size_t k = 0; k < t.header.size(); ++k) {
        if (t.header[k] == name) return static_cast<long>(k);
    }
    return -1;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: nightloc_compare_trajectories ACTUAL.csv EXPECTED.csv TOLERANCE\n");
        return 2;
    }
    Table a, b;
    if (!read(argv[1], a) || !read(argv[2], b)) return 2;
    const double tolerance = std::atof(argv[3]);
    if (a.rows.size() != b.rows.size()) {
        std::fprintf(stderr, "%zu rows against %zu expected\n", a.rows.size(), b.rows.size());
        return 1;
    }
    const char* names[] = {"image", "x", "y", "heading", "confidence", "credible_radius"};
    int bad = 0;
    double worst = 0;
    for (const char* name : names) {
        const long ca = column(a, name), cb = column(b, name);
        if (ca < 0 || cb < 0) {
            std::fprintf(stderr, "column %s missing\n", name);
            return 1;
        }
        for (std::size_t r = 0; r < a.rows.size(); ++r) {
            const std::string& va = a.rows[r].at(static_cast<std::size_t>(ca));
            const std::string& vb = b.rows[r].at(static_cast<std::size_t>(cb));
            bool same = true;
            if (std::string(name) == "image") {
                same = va.substr(0, va.rfind('.')) == vb.substr(0, vb.rfind('.'));
            } else {
                const double x = std::strtod(va.c_str(), nullptr), y = std::strtod(vb.c_str(), nullptr);
                double d = std::fabs(x - y);
                if (std::string(name) == "heading") d = std::fabs(std::remainder(x - y, 2.0 * M_PI));
                same = (std::isnan(x) && std::isnan(y)) || d <= tolerance;
                if (!std::isnan(d)) worst = std::fmax(worst, d);
            }
            if (!same) {
                if (++bad <= 10)
                    std::fprintf(stderr, "row %zu %s: %s, expected %s\n", r + 1, name, va.c_str(), vb.c_str());
            }
        }
    }
    std::printf("%zu rows compared, largest difference %.3g (tolerance %g), %d outside\n", a.rows.size(), worst,
                tolerance, bad);
    return bad ? 1 : 0;
}
