// The map-file reader (nightloc/map_file.hpp): zip members, .npy arrays and the JSON header of
// a map that nightloc's ReferenceMap.save wrote, checked as the Python loader checks them.
#include "nightloc/map_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <utility>

#include "mapping/file_formats.hpp"

namespace nightloc {

namespace {

using detail::Json;

constexpr const char* kUpgrade =
    "re-save it with a nightloc that writes format 3 (python -c \"import nightloc; "
    "nightloc.ReferenceMap.load('OLD.map').save('NEW.map')\"), or build it again with nightloc build-map";

class Reader {
public:
    explicit Reader(std::string path) : path_(std::move(path)) {}

    [[noreturn]] void fail(const std::string& what) const { throw MapFileError(path_ + ": " + what); }

    void read_file() {
        namespace fs = std::filesystem;
        std::error_code failure;
        const fs::file_status status = fs::status(path_, failure);
        if (status.type() == fs::file_type::not_found) fail("no such file (a map file from nightloc build-map)");
        if (failure) fail("cannot be read: " + failure.message());
        if (status.type() == fs::file_type::directory)
            fail("is a folder, not a map file (nightloc build-map writes one)");
        if (status.type() != fs::file_type::regular) fail("is not a regular file");
        const std::uintmax_t size = fs::file_size(path_, failure);
        if (failure) fail("cannot be read: " + failure.message());
        std::FILE* f = std::fopen(path_.c_str(), "rb");
        if (f == nullptr) fail(std::string("cannot be opened: ") + std::strerror(errno));
        bytes_.resize(static_cast<std::size_t>(size));
        const std::size_t got = bytes_.empty() ? 0 : std::fread(bytes_.data(), 1, bytes_.size(), f);
        std::fclose(f);
        if (got != bytes_.size()) fail("could not be read whole");
        if (bytes_.size() >= 6 && std::memcmp(bytes_.data(), "\x93NUMPY", 6) == 0) {
            fail("is a single numpy array, not a nightloc reference map");
        }
        if (bytes_.size() < 4 || std::memcmp(bytes_.data(), "PK\x03\x04", 4) != 0) {
            fail("is not a nightloc reference map (not an .npz zip archive)");
        }
        try {
            for (auto& m : detail::zip_members(bytes_.data(), bytes_.size())) members_[m.name] = m;
        } catch (const std::runtime_error& error) {
            fail(error.what());
        }
    }

    bool has(const std::string& name) const { return members_.count(name + ".npy") != 0; }

    // The array `name` (.npy member), its CRC checked; its type must be `descr`.
    std::pair<detail::NpyHeader, const std::uint8_t*> array(const std::string& name, const std::string& descr) {
        const auto it = members_.find(name + ".npy");
        if (it == members_.end()) fail("the map lacks its '" + name + "' array (corrupt file)");
        const detail::ZipMember& m = it->second;
        const std::uint8_t* data = bytes_.data() + m.offset;
        if (detail::crc32(data, m.size) != m.crc) fail("array '" + name + "' fails its CRC-32 (the file is corrupt)");
        detail::NpyHeader h;
        try {
            h = detail::parse_npy_header(data, m.size);
        } catch (const std::runtime_error& error) {
            fail("array '" + name + "': " + error.what());
        }
        const bool same = h.descr == descr || (descr.size() == 3 && descr[1] == 'u' && descr[2] == '1' &&
                                               (h.descr == "|u1" || h.descr == "<u1"));
        if (!same) fail("array '" + name + "' has type " + h.descr + ", expected " + descr);
        if (h.fortran_order && h.shape.size() > 1) fail("array '" + name + "' is in Fortran order");
        const std::uint8_t* values = data + h.data_offset;
        const std::size_t bytes = h.count() * h.item_size;
        if (checksums_ != nullptr) {
            const Json* sum = checksums_->find(name);
            if (sum == nullptr || sum->type != Json::Type::string) {
                fail("the header has no checksum for '" + name + "' (corrupt file)");
            }
            if (detail::sha256_hex(values, bytes) != sum->string) {
                fail("checksum of '" + name + "' does not match (the file is corrupt)");
            }
        }
        return {h, values};
    }

    template <class T>
    std::vector<T> vector(const std::string& name, const std::string& descr, const std::vector<std::size_t>& shape) {
        const auto [h, values] = array(name, descr);
        if (h.shape != shape)
            fail("array '" + name + "' has shape " + shape_text(h.shape) + ", expected " + shape_text(shape));
        std::vector<T> out(h.count());
        if (!out.empty()) std::memcpy(out.data(), values, out.size() * sizeof(T));
        return out;
    }

    template <class T>
    std::vector<T> vector_1d(const std::string& name, const std::string& descr) {
        const auto [h, values] = array(name, descr);
        if (h.shape.size() != 1) fail("array '" + name + "' has shape " + shape_text(h.shape) + ", expected one axis");
        std::vector<T> out(h.count());
        if (!out.empty()) std::memcpy(out.data(), values, out.size() * sizeof(T));
        return out;
    }

    static std::string shape_text(const std::vector<std::size_t>& shape) {
        std::string s = "(";
        for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
        return s + (shape.size() == 1 ? ",)" : ")");
    }

    Json header() {
        const auto [h, values] = array("header", "|u1");
        if (h.shape.size() != 1) fail("the header is not a byte string");
        try {
            return detail::parse_json(reinterpret_cast<const char*>(values), h.count());
        } catch (const std::runtime_error& error) {
            fail(error.what());
        }
    }

    // header fields
    const Json& field(const Json& object, const std::string& key, Json::Type type, const std::string& where) const {
        const Json* v = object.find(key);
        if (v == nullptr) fail("the " + where + " lacks '" + key + "'");
        if (v->type != type) fail("the " + where + "'s '" + key + "' has the wrong type");
        return *v;
    }
    double number(const Json& object, const std::string& key, const std::string& where) const {
        return field(object, key, Json::Type::number, where).number;
    }
    std::size_t count(const Json& object, const std::string& key, const std::string& where) const {
        const Json& v = field(object, key, Json::Type::number, where);
        if (!v.integer || v.number < 0 || v.number > 1e15) {
            fail("the " + where + "'s '" + key + "' is not a non-negative integer");
        }
        return static_cast<std::size_t>(v.number);
    }

    void use_checksums(const Json* checksums) { checksums_ = checksums; }
    const std::string& path() const { return path_; }

private:
    std::string path_;
    std::vector<std::uint8_t> bytes_;
    std::map<std::string, detail::ZipMember> members_;
    const Json* checksums_ = nullptr;
};

// The header's params (Python's PreparationParams, every field written): the fields the core holds
// by the names of setting_fields<PrepareSettings>() (a missing one keeps PrepareSettings' default),
// then channel_order and crop, which the core does not hold.
MapPreparation preparation_of(const Reader& r, const Json& params) {
    const std::string where = "header's params";
    if (params.type != Json::Type::object) r.fail("the header's params are not a table");
    PrepareSettings core;
    for (const SettingField<PrepareSettings>& field : setting_fields<PrepareSettings>()) {
        const Json* value = params.find(field.info.name);
        if (value == nullptr) continue;  // crop_* (the header holds crop), or a map without the key
        double number = 0;
        if (field.info.kind == SettingKind::flag) {
            number = r.field(params, field.info.name, Json::Type::boolean, where).boolean ? 1 : 0;
        } else if (field.info.kind == SettingKind::choice) {
            const std::string& name = r.field(params, field.info.name, Json::Type::string, where).string;
            try {
                number = choice_value(field.info, name);
            } catch (const SettingError& error) {
                r.fail(std::string("the header's ") + error.what());
            }
        } else {
            number = r.number(params, field.info.name, where);
        }
        try {
            set_setting(core, field.info.name, number);
        } catch (const SettingError& error) {
            r.fail(std::string("the header's ") + error.what());
        }
    }
    MapPreparation p;
    p.width = core.width;
    p.height = core.height;
    p.radius = core.radius;
    p.wrap = core.wrap;
    p.equalize = equalization_name(static_cast<std::size_t>(core.equalize));
    p.patch_normalize = core.patch_normalize;
    p.scale = core.scale;
    p.channel_order = r.field(params, "channel_order", Json::Type::string, where).string;
    if (p.channel_order != "bgr" && p.channel_order != "rgb") r.fail("unknown channel_order '" + p.channel_order + "'");
    const Json& crop = r.field(params, "crop", Json::Type::array, where);
    if (crop.array.size() != 4) r.fail("the header's crop is not 4 numbers");
    for (std::size_t i = 0; i < 4; ++i) {
        const Json& c = crop.array[i];
        if (c.type != Json::Type::number || !(c.number >= 0)) r.fail("the header's crop holds a bad value");
        p.crop[i] = c.number;
        p.crop_fraction[i] = !c.integer;
    }
    return p;
}

void read_tables(Reader& r, const Json& header, MapFile& m) {
    const Json* loc = header.find("localizer");
    if (loc == nullptr || loc->type != Json::Type::object) {
        r.fail("the header has no localizer tables; " + std::string(kUpgrade));
    }
    const std::string where = "header's localizer";
    const std::string method = r.field(*loc, "method", Json::Type::string, where).string;
    if (method != "filter") r.fail("the map's localizer is '" + method + "'; the firmware runs the grid filter only");
    const Json& grid = r.field(*loc, "grid", Json::Type::object, where);
    MapLocalizerTables& t = m.localizer;
    t.grid_width = r.count(grid, "width", "localizer grid");
    t.grid_height = r.count(grid, "height", "localizer grid");
    t.map.x0 = r.number(grid, "x0", "localizer grid");
    t.map.y0 = r.number(grid, "y0", "localizer grid");
    t.map.dx = r.number(grid, "dx", "localizer grid");
    t.map.dy = r.number(grid, "dy", "localizer grid");
    if (t.grid_width < 2 || t.grid_height < 2 || t.grid_width * t.grid_height > (std::size_t{1} << 26)) {
        r.fail("the localizer grid's size is out of range");
    }
    t.map.columns = r.count(*loc, "columns", where);
    if (t.map.columns != m.preparation.width) r.fail("the localizer's columns differ from the images' width");
    for (const Json& s : r.field(*loc, "shifts", Json::Type::array, where).array) {
        if (s.type != Json::Type::number || !s.integer) r.fail("the localizer's shifts are not integers");
        t.map.shifts.push_back(static_cast<std::int32_t>(s.number));
    }
    t.map.field_of_view = r.number(*loc, "field_of_view", where);
    const Json& window = r.field(*loc, "window", Json::Type::array, where);
    if (window.array.size() != 2) r.fail("the localizer's window is not [columns, rows]");
    Json wrapped;
    wrapped.type = Json::Type::object;
    wrapped.object["columns"] = window.array[0];
    wrapped.object["rows"] = window.array[1];
    t.map.window =
        ShiftWindow{r.count(wrapped, "columns", "localizer window"), r.count(wrapped, "rows", "localizer window")};
    const Json& settings = r.field(*loc, "settings", Json::Type::object, where);
    for (const auto& [name, value] : settings.object) {
        if (value.type != Json::Type::number) r.fail("the localizer setting '" + name + "' is not a number");
        if (find_setting<GridFilterSettings>(name) == nullptr) {
            r.fail("unknown grid filter setting '" + name +
                   "' (a map written by a newer nightloc? update the firmware)");
        }
        try {
            set_setting(t.settings, name, value.number);
        } catch (const SettingError& error) {
            r.fail(std::string("the localizer setting ") + error.what());
        }
    }
    const std::size_t cells = t.grid_width * t.grid_height;
    auto indptr = r.vector<std::int32_t>("filter_weights_indptr", "<i4", {cells + 1});
    auto indices = r.vector_1d<std::int32_t>("filter_weights_indices", "<i4");
    auto data = r.vector<float>("filter_weights_data", "<f4", {indices.size()});
    t.map.place_of_ref = r.vector<std::int32_t>("filter_place_of_ref", "<i4", {m.count});
    t.closest_ref = r.vector<std::int32_t>("filter_closest_ref", "<i4", {cells});
    std::int32_t places = 0;
    for (const std::int32_t p : t.map.place_of_ref) {
        if (p < 0 || static_cast<std::size_t>(p) >= m.count) r.fail("filter_place_of_ref holds a bad place");
        places = std::max(places, p + 1);
    }
    for (const std::int32_t c : t.closest_ref) {
        if (c < 0 || static_cast<std::size_t>(c) >= m.count) r.fail("filter_closest_ref holds a bad reference");
    }
    try {
        t.map.weights =
            std::make_shared<const HeatWeights>(t.grid_height, t.grid_width, static_cast<std::size_t>(places),
                                                std::move(indptr), std::move(indices), std::move(data));
    } catch (const std::invalid_argument& error) {
        r.fail(std::string("the localizer's interpolation weights are invalid: ") + error.what());
    }
    t.map.ref_headings = m.headings;
}

}  // namespace

PrepareSettings MapPreparation::settings(std::size_t frame_height, std::size_t frame_width) const {
    if (equalize == "clahe") {
        throw MapFileError(
            "the map's images are equalized with CLAHE, which the C++ core does not implement; build the map with "
            "equalize = \"global\" or \"none\" for firmware");
    }
    PrepareSettings s;
    const std::size_t sides[4] = {frame_height, frame_height, frame_width, frame_width};
    std::size_t* out[4] = {&s.crop_top, &s.crop_bottom, &s.crop_left, &s.crop_right};
    for (std::size_t i = 0; i < 4; ++i) {
        // Python: int(round(f * n)) for a fraction (round half to even: nearbyint's default mode)
        *out[i] = crop_fraction[i] ? static_cast<std::size_t>(std::nearbyint(crop[i] * static_cast<double>(sides[i])))
                                   : static_cast<std::size_t>(crop[i]);
    }
    s.equalize = static_cast<Equalization>(
        static_cast<int>(choice_value(find_setting<PrepareSettings>("equalize")->info, equalize)));
    s.width = width;
    s.height = height;
    s.patch_normalize = patch_normalize;
    s.radius = radius;
    s.wrap = wrap;
    s.scale = scale;
    return s;
}

MapFile load_map_file(const std::string& path) {
    Reader r(path);
    r.read_file();
    if (!r.has("header")) r.fail("is an .npz archive but not a nightloc reference map (no header)");
    const Json header = r.header();
    if (header.type != Json::Type::object) r.fail("the map header is not a JSON object");
    const Json* format = header.find("format");
    if (format == nullptr || format->type != Json::Type::string || format->string != "nightloc-reference-map") {
        r.fail("is not a nightloc reference map (its header's format is not nightloc-reference-map)");
    }
    MapFile m;
    m.path = path;
    const Json* version = header.find("format_version");
    if (version == nullptr || version->type != Json::Type::number || !version->integer || version->number < 1) {
        r.fail("bad format_version");
    }
    m.format_version = static_cast<int>(version->number);
    if (const Json* v = header.find("nightloc_version"); v != nullptr && v->type == Json::Type::string) {
        m.nightloc_version = v->string;
    }
    if (m.format_version > kMapFormatVersion) {
        r.fail("has map format version " + std::to_string(m.format_version) + ", written by a newer nightloc (" +
               m.nightloc_version + "); this firmware reads versions " + std::to_string(kMinMapFormatVersion) + " to " +
               std::to_string(kMapFormatVersion) + ": update the firmware");
    }
    if (m.format_version < kMinMapFormatVersion) {
        r.fail("has map format version " + std::to_string(m.format_version) +
               ", without the localizer's tables that firmware needs; " + kUpgrade);
    }
    const Json& checksums = r.field(header, "checksums", Json::Type::object, "header");
    r.use_checksums(&checksums);
    m.count = r.count(header, "count", "header");
    if (m.count < 1) r.fail("the header's image count is 0");
    m.preparation = preparation_of(r, r.field(header, "params", Json::Type::object, "header"));
    const std::size_t h = m.preparation.height, w = m.preparation.width;
    m.images = r.vector<std::uint8_t>("images", "|u1", {m.count, h, w});
    m.positions = r.vector<double>("positions", "<f8", {m.count, 2});
    for (const double v : m.positions) {
        if (!std::isfinite(v)) r.fail("positions hold NaN or infinity");
    }
    if (r.has("headings") || checksums.find("headings") != nullptr) {
        m.headings = r.vector<double>("headings", "<f8", {m.count});
        for (const double v : m.headings) {
            if (!std::isfinite(v)) r.fail("headings hold NaN or infinity");
        }
    }
    const Json& names = r.field(header, "names", Json::Type::array, "header");
    if (names.array.size() != m.count)
        r.fail("the header lists " + std::to_string(names.array.size()) + " names for " + std::to_string(m.count) +
               " images");
    for (const Json& n : names.array) {
        if (n.type != Json::Type::string) r.fail("the header's names are not strings");
        m.names.push_back(n.string);
    }
    if (const Json* size = header.find("frame_size"); size != nullptr && size->type != Json::Type::null) {
        if (size->type != Json::Type::array || size->array.size() != 2) {
            r.fail("the header's frame_size is not [width, height]");
        }
        Json wrapped;
        wrapped.type = Json::Type::object;
        wrapped.object["width"] = size->array[0];
        wrapped.object["height"] = size->array[1];
        m.frame_width = r.count(wrapped, "width", "frame_size");
        m.frame_height = r.count(wrapped, "height", "frame_size");
    }
    if (m.format_version >= 4 && header.find("experience") != nullptr) {
        m.appearance_night = r.vector<std::int32_t>("appearance_night", "<i4", {m.count});
        for (const std::int32_t night : m.appearance_night) {
            if (night < 0) r.fail("appearance_night holds a negative night");
        }
    }
    read_tables(r, header, m);
    m.localizer.map.learned.clear();  // the filter brings learned appearances' scores onto the day scale
    for (const std::int32_t night : m.appearance_night) m.localizer.map.learned.push_back(night > 0 ? 1 : 0);
    return m;
}

}  // namespace nightloc
