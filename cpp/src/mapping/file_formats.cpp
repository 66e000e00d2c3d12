// SHA-256, CRC-32, JSON, zip members and .npy headers for the map-file reader (file_formats.hpp).
#include "mapping/file_formats.hpp"

#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace nightloc {
namespace detail {

// ---------------------------------------------------------------------------------------------
// SHA-256 (FIPS 180-4, section 6.2)

namespace {

constexpr std::array<std::uint32_t, 64> kRound = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

inline std::uint32_t rotr(std::uint32_t x, int n) { return (x >> n) | (x << (32 - n)); }

void sha256_block(std::array<std::uint32_t, 8>& h, const std::uint8_t* block) {
    std::array<std::uint32_t, 64> w{};
    for (std::size_t t = 0; t < 16; ++t) {
        w[t] = (std::uint32_t{block[4 * t]} << 24) | (std::uint32_t{block[4 * t + 1]} << 16) |
               (std::uint32_t{block[4 * t + 2]} << 8) | std::uint32_t{block[4 * t + 3]};
    }
    for (std::size_t t = 16; t < 64; ++t) {
        const std::uint32_t s0 = rotr(w[t - 15], 7) ^ rotr(w[t - 15], 18) ^ (w[t - 15] >> 3);
        const std::uint32_t s1 = rotr(w[t - 2], 17) ^ rotr(w[t - 2], 19) ^ (w[t - 2] >> 10);
        w[t] = w[t - 16] + s0 + w[t - 7] + s1;
    }
    std::uint32_t a = h[0], b = h[1], c = h[2], d = h[3], e = h[4], f = h[5], g = h[6], k = h[7];
    for (std::size_t t = 0; t < 64; ++t) {
        const std::uint32_t t1 = k + (rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25)) + ((e & f) ^ (~e & g)) + kRound[t] + w[t];
        const std::uint32_t t2 = (rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
        k = g;
        g = f;
        f = e;
        e = d + t1;
        d = c;
        c = b;
        b = a;
        a = t1 + t2;
    }
    h[0] += a;
    h[1] += b;
    h[2] += c;
    h[3] += d;
    h[4] += e;
    h[5] += f;
    h[6] += g;
    h[7] += k;
}

}  // namespace

std::string sha256_hex(const std::uint8_t* data, std::size_t size) {
    std::array<std::uint32_t, 8> h = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                      0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
    std::size_t whole = size / 64;
    for (std::size_t b = 0; b < whole; ++b) sha256_block(h, data + 64 * b);
    // the rest, a 1 bit, zeros and the length in bits (big-endian) in one or two final blocks
    std::array<std::uint8_t, 128> tail{};
    const std::size_t rest = size - 64 * whole;
    if (rest) std::memcpy(tail.data(), data + 64 * whole, rest);
    tail[rest] = 0x80;
    const std::size_t blocks = rest + 1 + 8 <= 64 ? 1 : 2;
    const std::uint64_t bits = static_cast<std::uint64_t>(size) * 8;
    for (std::size_t i = 0; i < 8; ++i) tail[64 * blocks - 1 - i] = static_cast<std::uint8_t>(bits >> (8 * i));
    for (std::size_t b = 0; b < blocks; ++b) sha256_block(h, tail.data() + 64 * b);
    static const char* hex = "0123456789abcdef";
    std::string out(64, '0');
    for (std::size_t i = 0; i < 8; ++i) {
        for (std::size_t j = 0; j < 8; ++j) out[8 * i + j] = hex[(h[i] >> (28 - 4 * j)) & 0xF];
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// CRC-32

std::uint32_t crc32(const std::uint8_t* data, std::size_t size) {
    static const std::array<std::uint32_t, 256> table = [] {
        std::array<std::uint32_t, 256> t{};
        for (std::uint32_t n = 0; n < 256; ++n) {
            std::uint32_t c = n;
            for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            t[n] = c;
        }
        return t;
    }();
    std::uint32_t c = 0xFFFFFFFFu;
    for (std::size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

// ---------------------------------------------------------------------------------------------
// JSON

const Json* Json::find(const std::string& key) const {
    if (type != Type::object) return nullptr;
    const auto it = object.find(key);
    return it == object.end() ? nullptr : &it->second;
}

namespace {

class JsonParser {
public:
    JsonParser(const char* text, std::size_t size) : p_(text), begin_(text), end_(text + size) {}

    Json document() {
        Json value = parse(0);
        skip_space();
        if (p_ != end_) fail("text after the JSON value");
        return value;
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        throw std::runtime_error("JSON header: " + what + " at byte " + std::to_string(p_ - begin_));
    }
    void skip_space() {
        while (p_ != end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\n' || *p_ == '\r')) ++p_;
    }
    bool literal(const char* word) {
        const std::size_t n = std::strlen(word);
        if (static_cast<std::size_t>(end_ - p_) >= n && std::memcmp(p_, word, n) == 0) {
            p_ += n;
            return true;
        }
        return false;
    }

    Json parse(int depth) {
        if (depth > 64) fail("nesting deeper than 64");
        skip_space();
        if (p_ == end_) fail("unexpected end");
        Json v;
        const char c = *p_;
        if (c == '{') {
            v.type = Json::Type::object;
            ++p_;
            skip_space();
            if (p_ != end_ && *p_ == '}') {
                ++p_;
                return v;
            }
            for (;;) {
                skip_space();
                if (p_ == end_ || *p_ != '"') fail("expected a string key");
                std::string key = string_body();
                skip_space();
                if (p_ == end_ || *p_ != ':') fail("expected ':'");
                ++p_;
                v.object[key] = parse(depth + 1);
                skip_space();
                if (p_ != end_ && *p_ == ',') {
                    ++p_;
                    continue;
                }
                if (p_ != end_ && *p_ == '}') {
                    ++p_;
                    return v;
                }
                fail("expected ',' or '}'");
            }
        }
        if (c == '[') {
            v.type = Json::Type::array;
            ++p_;
            skip_space();
            if (p_ != end_ && *p_ == ']') {
                ++p_;
                return v;
            }
            for (;;) {
                v.array.push_back(parse(depth + 1));
                skip_space();
                if (p_ != end_ && *p_ == ',') {
                    ++p_;
                    continue;
                }
                if (p_ != end_ && *p_ == ']') {
                    ++p_;
                    return v;
                }
                fail("expected ',' or ']'");
            }
        }
        if (c == '"') {
            v.type = Json::Type::string;
            v.string = string_body();
            return v;
        }
        if (literal("true") || literal("false")) {
            v.type = Json::Type::boolean;
            v.boolean = p_[-2] == 'u';  // tr(u)e, fal(s)e
            return v;
        }
        if (literal("null")) return v;
        // Python's json writes NaN and Infinity for non-finite floats
        if (literal("NaN")) return number_value(std::numeric_limits<double>::quiet_NaN(), false);
        if (literal("Infinity")) return number_value(std::numeric_limits<double>::infinity(), false);
        if (literal("-Infinity")) return number_value(-std::numeric_limits<double>::infinity(), false);
        return number();
    }

    static Json number_value(double x, bool integer) {
        Json v;
        v.type = Json::Type::number;
        v.number = x;
        v.integer = integer;
        return v;
    }

    Json number() {
        const char* start = p_;
        bool integer = true;
        if (p_ != end_ && *p_ == '-') ++p_;
        if (p_ == end_ || *p_ < '0' || *p_ > '9') fail("unexpected character");
        while (p_ != end_ &&
               ((*p_ >= '0' && *p_ <= '9') || *p_ == '.' || *p_ == 'e' || *p_ == 'E' || *p_ == '+' || *p_ == '-')) {
            if (*p_ == '.' || *p_ == 'e' || *p_ == 'E') integer = false;
            ++p_;
        }
        const std::string text(start, p_);
        char* stop = nullptr;
        const double x = std::strtod(text.c_str(), &stop);
        if (stop != text.c_str() + text.size()) fail("malformed number '" + text + "'");
        return number_value(x, integer);
    }

    unsigned hex4() {
        if (end_ - p_ < 4) fail("truncated \\u escape");
        unsigned u = 0;
        for (int i = 0; i < 4; ++i, ++p_) {
            const char h = *p_;
            u <<= 4;
            if (h >= '0' && h <= '9')
                u |= static_cast<unsigned>(h - '0');
            else if (h >= 'a' && h <= 'f')
                u |= static_cast<unsigned>(h - 'a' + 10);
            else if (h >= 'A' && h <= 'F')
                u |= static_cast<unsigned>(h - 'A' + 10);
            else
                fail("bad \\u escape");
        }
        return u;
    }

    static void append_utf8(std::string& out, unsigned cp) {
        if (cp < 0x80) {
            out += static_cast<char>(cp);
        } else if (cp < 0x800) {
            out += static_cast<char>(0xC0 | (cp >> 6));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        } else if (cp < 0x10000) {
            out += static_cast<char>(0xE0 | (cp >> 12));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        } else {
            out += static_cast<char>(0xF0 | (cp >> 18));
            out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (cp & 0x3F));
        }
    }

    std::string string_body() {
        ++p_;  // the opening quote
        std::string out;
        for (;;) {
            if (p_ == end_) fail("unterminated string");
            const char c = *p_++;
            if (c == '"') return out;
            if (static_cast<unsigned char>(c) < 0x20) fail("control character in a string");
            if (c != '\\') {
                out += c;
                continue;
            }
            if (p_ == end_) fail("unterminated string");
            const char e = *p_++;
            switch (e) {
                case '"':
                case '\\':
                case '/':
                    out += e;
                    break;
                case 'b':
                    out += '\b';
                    break;
                case 'f':
                    out += '\f';
                    break;
                case 'n':
                    out += '\n';
                    break;
                case 'r':
                    out += '\r';
                    break;
                case 't':
                    out += '\t';
                    break;
                case 'u': {
                    unsigned cp = hex4();
                    if (cp >= 0xD800 && cp < 0xDC00 && end_ - p_ >= 6 && p_[0] == '\\' && p_[1] == 'u') {
                        const char* keep = p_;
                        p_ += 2;
                        const unsigned low = hex4();
                        if (low >= 0xDC00 && low < 0xE000)
                            cp = 0x10000 + ((cp - 0xD800) << 10) + (low - 0xDC00);
                        else
                            p_ = keep;  // a lone high surrogate, then another escape
                    }
                    append_utf8(out, cp);
                    break;
                }
                default:
                    fail("bad escape");
            }
        }
    }

    const char* p_;
    const char* begin_;
    const char* end_;
};

}  // namespace

Json parse_json(const char* text, std::size_t size) { return JsonParser(text, size).document(); }

// ---------------------------------------------------------------------------------------------
// zip (PKWARE APPNOTE 6.3: end of central directory, zip64 records, central file headers)

namespace {

std::uint16_t u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t u32(const std::uint8_t* p) {
    return std::uint32_t{p[0]} | (std::uint32_t{p[1]} << 8) | (std::uint32_t{p[2]} << 16) | (std::uint32_t{p[3]} << 24);
}
std::uint64_t u64(const std::uint8_t* p) { return std::uint64_t{u32(p)} | (std::uint64_t{u32(p + 4)} << 32); }

[[noreturn]] void zip_fail(const std::string& what) { throw std::runtime_error("not a readable zip archive: " + what); }

// Where a zip's central directory lies: its entries, size and offset (bytes), from the
// end-of-central-directory record, or the zip64 end record when those fields overflow.
struct CentralDirectory {
    std::uint64_t entries, size, offset;
};

CentralDirectory central_directory(const std::uint8_t* data, std::size_t size) {
    // the end-of-central-directory record: 22 bytes plus a comment of up to 65535 bytes
    if (size < 22) zip_fail("shorter than a zip's end record (truncated?)");
    std::size_t eocd = size;
    const std::size_t lowest = size > 22 + 65535 ? size - 22 - 65535 : 0;
    for (std::size_t at = size - 22 + 1; at-- > lowest;) {
        if (u32(data + at) == 0x06054b50) {
            eocd = at;
            break;
        }
    }
    if (eocd == size) zip_fail("no end-of-central-directory record (truncated?)");
    std::uint64_t entries = u16(data + eocd + 10);
    std::uint64_t dir_size = u32(data + eocd + 12);
    std::uint64_t dir_offset = u32(data + eocd + 16);
    if (entries == 0xFFFF || dir_size == 0xFFFFFFFFu || dir_offset == 0xFFFFFFFFu) {
        // zip64: the locator just before the end record points at the zip64 end record
        if (eocd < 20 || u32(data + eocd - 20) != 0x07064b50) zip_fail("zip64 locator missing");
        const std::uint64_t record = u64(data + eocd - 20 + 8);
        if (record > size - 56 || u32(data + record) != 0x06064b50) zip_fail("zip64 end record missing");
        entries = u64(data + record + 32);
        dir_size = u64(data + record + 40);
        dir_offset = u64(data + record + 48);
    }
    if (dir_offset > size || dir_size > size - dir_offset) zip_fail("central directory beyond the end (truncated?)");
    return {entries, dir_size, dir_offset};
}

}  // namespace

std::vector<ZipMember> zip_members(const std::uint8_t* data, std::size_t size) {
    const CentralDirectory directory = central_directory(data, size);
    const std::uint64_t entries = directory.entries, dir_size = directory.size, dir_offset = directory.offset;
    std::vector<ZipMember> members;
    std::size_t at = static_cast<std::size_t>(dir_offset);
    const std::size_t dir_end = static_cast<std::size_t>(dir_offset + dir_size);
    for (std::uint64_t k = 0; k < entries; ++k) {
        if (at + 46 > dir_end || u32(data + at) != 0x02014b50) zip_fail("damaged central directory");
        const std::uint16_t flags = u16(data + at + 8);
        const std::uint16_t method = u16(data + at + 10);
        const std::uint32_t crc = u32(data + at + 16);
        std::uint64_t packed = u32(data + at + 20);
        std::uint64_t unpacked = u32(data + at + 24);
        const std::size_t name_len = u16(data + at + 28), extra_len = u16(data + at + 30),
                          comment_len = u16(data + at + 32);
        std::uint64_t local = u32(data + at + 42);
        if (at + 46 + name_len + extra_len + comment_len > dir_end) zip_fail("damaged central directory");
        ZipMember m;
        m.name.assign(reinterpret_cast<const char*>(data + at + 46), name_len);
        // zip64 extra field: the 64-bit values of the fields that hold 0xFFFFFFFF, in this order
        const std::uint8_t* extra = data + at + 46 + name_len;
        for (std::size_t e = 0; e + 4 <= extra_len;) {
            const std::uint16_t id = u16(extra + e), len = u16(extra + e + 2);
            if (e + 4 + len > extra_len) zip_fail("damaged extra field of " + m.name);
            if (id == 0x0001) {
                std::size_t f = e + 4;
                auto take = [&](std::uint64_t& field) {
                    if (field != 0xFFFFFFFFu) return;
                    if (f + 8 > e + 4 + len) zip_fail("short zip64 field of " + m.name);
                    field = u64(extra + f);
                    f += 8;
                };
                take(unpacked);
                take(packed);
                take(local);
            }
            e += 4 + std::size_t{len};
        }
        if (flags & 0x1) zip_fail("member " + m.name + " is encrypted");
        if (method != 0) {
            throw std::runtime_error("member " + m.name + " is compressed (zip method " + std::to_string(method) +
                                     (method == 8 ? ", deflate" : "") +
                                     "); the firmware reads maps stored uncompressed, as nightloc writes them "
                                     "(np.savez, not np.savez_compressed)");
        }
        if (packed != unpacked) zip_fail("stored member " + m.name + " has two sizes");
        if (local > size || size - local < 30 || u32(data + local) != 0x04034b50) {
            zip_fail("local header of " + m.name + " missing (truncated?)");
        }
        const std::size_t start =
            static_cast<std::size_t>(local) + 30 + u16(data + local + 26) + u16(data + local + 28);
        if (start > size || unpacked > size - start) zip_fail("member " + m.name + " runs past the end (truncated?)");
        m.offset = start;
        m.size = static_cast<std::size_t>(unpacked);
        m.crc = crc;
        members.push_back(std::move(m));
        at += 46 + name_len + extra_len + comment_len;
    }
    return members;
}

// ---------------------------------------------------------------------------------------------
// .npy (numpy's format: magic, version, header length, a Python dict literal, the data)

std::size_t NpyHeader::count() const {
    std::size_t n = 1;
    for (const std::size_t d : shape) n *= d;
    return n;
}

namespace {

[[noreturn]] void npy_fail(const std::string& what) { throw std::runtime_error("malformed .npy array: " + what); }

// the value text after 'key': in the header dict
std::string dict_value(const std::string& header, const std::string& key) {
    const std::size_t k = header.find("'" + key + "'");
    if (k == std::string::npos) npy_fail("no '" + key + "' in its header");
    std::size_t p = header.find(':', k);
    if (p == std::string::npos) npy_fail("no value for '" + key + "'");
    ++p;
    while (p < header.size() && header[p] == ' ') ++p;
    if (p >= header.size()) npy_fail("no value for '" + key + "'");
    std::size_t q = p;
    if (header[p] == '\'') {
        q = header.find('\'', p + 1);
        if (q == std::string::npos) npy_fail("unterminated '" + key + "'");
        return header.substr(p + 1, q - p - 1);
    }
    if (header[p] == '(') {
        q = header.find(')', p);
        if (q == std::string::npos) npy_fail("unterminated shape");
        return header.substr(p, q - p + 1);
    }
    while (q < header.size() && header[q] != ',' && header[q] != '}') ++q;
    return header.substr(p, q - p);
}

}  // namespace

NpyHeader parse_npy_header(const std::uint8_t* data, std::size_t size) {
    if (size < 10 || std::memcmp(data, "\x93NUMPY", 6) != 0) npy_fail("no .npy magic");
    const int major = data[6];
    std::size_t header_len = 0, start = 0;
    if (major == 1) {
        header_len = u16(data + 8);
        start = 10;
    } else if (major == 2 || major == 3) {
        if (size < 12) npy_fail("truncated header");
        header_len = u32(data + 8);
        start = 12;
    } else {
        npy_fail("format version " + std::to_string(major) + "." + std::to_string(data[7]) + ", not 1, 2 or 3");
    }
    if (header_len > size - start) npy_fail("header runs past the member (truncated?)");
    const std::string header(reinterpret_cast<const char*>(data + start), header_len);
    NpyHeader h;
    h.data_offset = start + header_len;
    h.descr = dict_value(header, "descr");
    const std::string fortran = dict_value(header, "fortran_order");
    if (fortran != "False" && fortran != "True") npy_fail("fortran_order '" + fortran + "'");
    h.fortran_order = fortran == "True";
    const std::string shape = dict_value(header, "shape");
    for (std::size_t p = 1; p < shape.size();) {
        while (p < shape.size() && (shape[p] == ' ' || shape[p] == ',')) ++p;
        if (p >= shape.size() || shape[p] == ')') break;
        if (shape[p] < '0' || shape[p] > '9') npy_fail("shape " + shape);
        std::size_t d = 0;
        while (p < shape.size() && shape[p] >= '0' && shape[p] <= '9') {
            const std::size_t digit = static_cast<std::size_t>(shape[p] - '0');
            if (d > (std::numeric_limits<std::size_t>::max() - digit) / 10) npy_fail("shape " + shape + " too large");
            d = d * 10 + digit;
            ++p;
        }
        h.shape.push_back(d);
    }
    if (h.descr.size() < 3 || (h.descr[0] != '<' && h.descr[0] != '|')) {
        npy_fail("element type '" + h.descr + "' (a little-endian number type is expected)");
    }
    const char kind = h.descr[1];
    if (kind != 'u' && kind != 'i' && kind != 'f') npy_fail("element type '" + h.descr + "' is not a number type");
    h.item_size = static_cast<std::size_t>(std::strtoul(h.descr.c_str() + 2, nullptr, 10));
    if (h.item_size != 1 && h.item_size != 2 && h.item_size != 4 && h.item_size != 8) {
        npy_fail("element type '" + h.descr + "'");
    }
    std::size_t bytes = h.item_size;
    for (const std::size_t d : h.shape) {
        if (d != 0 && bytes > std::numeric_limits<std::size_t>::max() / d) npy_fail("shape too large");
        bytes *= d;
    }
    if (bytes > size - h.data_offset) {
        npy_fail("shape needs " + std::to_string(bytes) + " bytes, the member holds " +
                 std::to_string(size - h.data_offset) + " (truncated?)");
    }
    return h;
}

}  // namespace detail
}  // namespace nightloc
