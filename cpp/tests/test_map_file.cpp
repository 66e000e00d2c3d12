// C++ tests of the map-file reader's parts (src/file_formats.hpp, nightloc/map_file.hpp): SHA-256
// and CRC-32 against the published test vectors, the JSON parser, .npy headers, a zip archive
// written here by hand (stored and compressed members), the reader's errors on files that are not
// maps, angle wrapping as Python's, and settings by name. The whole reader against nightloc's own
// map files: the replay golden test (tools/firmware_golden.py) and tests/firmware/.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "check.hpp"
#include "mapping/file_formats.hpp"

#include <nightloc/localizer.hpp>
#include <nightloc/map_file.hpp>

namespace {

using nightloc::detail::Json;

std::string sha(const std::string& s) {
    return nightloc::detail::sha256_hex(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
}

void test_sha256() {
    // FIPS 180-2 appendix B and the empty message
    CHECK(sha("abc") == "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    CHECK(sha("") == "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    CHECK(sha("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq") ==
          "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    CHECK(sha(std::string(1000000, 'a')) == "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    // lengths around the padding's block boundary (55, 56, 64 bytes)
    CHECK(sha(std::string(55, 'a')) == "9f4390f8d30c2dd92ec9f095b65e2b9ae9b0a925a5258e241c9f1e910f734318");
    CHECK(sha(std::string(56, 'a')) == "b35439a4ac6f0948b6d6f9e3c6af0f5f590ce20f1bde7090ef7970686ec6738a");
    CHECK(sha(std::string(64, 'a')) == "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb");
}

void test_crc32() {
    const std::string s = "123456789";
    CHECK(nightloc::detail::crc32(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()) == 0xCBF43926u);
    CHECK(nightloc::detail::crc32(nullptr, 0) == 0);
}

Json json(const std::string& s) { return nightloc::detail::parse_json(s.data(), s.size()); }

void test_json() {
    const Json v =
        json(R"( {"a": [1, -2.5e3, true, false, null], "b": "x\"\u00e9\ud83d\ude00\n", "c": {}, "d": 0.1} )");
    CHECK(v.type == Json::Type::object && v.object.size() == 4);
    const Json& a = *v.find("a");
    CHECK(a.array.size() == 5 && a.array[0].integer && a.array[0].number == 1);
    CHECK(!a.array[1].integer && a.array[1].number == -2500.0);
    CHECK(a.array[2].boolean && !a.array[3].boolean && a.array[4].type == Json::Type::null);
    CHECK(v.find("b")->string == "x\"\xC3\xA9\xF0\x9F\x98\x80\n");
    CHECK(v.find("d")->number == 0.1 && v.find("missing") == nullptr);
    CHECK(std::isnan(json("NaN").number) && json("-Infinity").number < 0);
    CHECK_THROWS(json("{\"a\": }"), std::runtime_error);
    CHECK_THROWS(json("[1, 2"), std::runtime_error);
    CHECK_THROWS(json("\"open"), std::runtime_error);
    CHECK_THROWS(json("1 2"), std::runtime_error);
    CHECK_THROWS(json(std::string(100, '[')), std::runtime_error);
}

std::vector<std::uint8_t> npy(const std::string& dict, std::size_t data_bytes) {
    std::string header = dict;
    while ((10 + header.size() + 1) % 64) header += ' ';
    header += '\n';
    std::vector<std::uint8_t> out = {0x93,
                                     'N',
                                     'U',
                                     'M',
                                     'P',
                                     'Y',
                                     1,
                                     0,
                                     static_cast<std::uint8_t>(header.size()),
                                     static_cast<std::uint8_t>(header.size() >> 8)};
    out.insert(out.end(), header.begin(), header.end());
    out.resize(out.size() + data_bytes, 7);
    return out;
}

void test_npy() {
    const auto a = npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }", 48);
    const auto h = nightloc::detail::parse_npy_header(a.data(), a.size());
    CHECK(h.descr == "<f8" && h.item_size == 8 && h.shape == (std::vector<std::size_t>{3, 2}) && h.count() == 6);
    CHECK(h.data_offset % 64 == 0 && h.data_offset + 48 == a.size());
    const auto one = npy("{'descr': '|u1', 'fortran_order': False, 'shape': (5,), }", 5);
    CHECK(nightloc::detail::parse_npy_header(one.data(), one.size()).shape == std::vector<std::size_t>{5});
    const auto short_data = npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }", 47);
    CHECK_THROWS(nightloc::detail::parse_npy_header(short_data.data(), short_data.size()), std::runtime_error);
    const auto big_endian = npy("{'descr': '>f8', 'fortran_order': False, 'shape': (1,), }", 8);
    CHECK_THROWS(nightloc::detail::parse_npy_header(big_endian.data(), big_endian.size()), std::runtime_error);
    const auto objects = npy("{'descr': '|O', 'fortran_order': False, 'shape': (1,), }", 8);
    CHECK_THROWS(nightloc::detail::parse_npy_header(objects.data(), objects.size()), std::runtime_error);
}

void put16(std::vector<std::uint8_t>& v, unsigned x) {
    v.push_back(static_cast<std::uint8_t>(x));
    v.push_back(static_cast<std::uint8_t>(x >> 8));
}
void put32(std::vector<std::uint8_t>& v, std::uint32_t x) {
    put16(v, x & 0xFFFF);
    put16(v, x >> 16);
}

// A zip archive of members (name, bytes) with the given compression method (APPNOTE 4.3).
std::vector<std::uint8_t> zip(const std::vector<std::pair<std::string, std::string>>& members, unsigned method) {
    std::vector<std::uint8_t> out, dir;
    for (const auto& [name, body] : members) {
        const auto crc = nightloc::detail::crc32(reinterpret_cast<const std::uint8_t*>(body.data()), body.size());
        const auto offset = static_cast<std::uint32_t>(out.size());
        put32(out, 0x04034b50);
        put16(out, 20);
        put16(out, 0);
        put16(out, method);
        put32(out, 0);
        put32(out, crc);
        put32(out, static_cast<std::uint32_t>(body.size()));
        put32(out, static_cast<std::uint32_t>(body.size()));
        put16(out, static_cast<unsigned>(name.size()));
        put16(out, 0);
        out.insert(out.end(), name.begin(), name.end());
        out.insert(out.end(), body.begin(), body.end());
        put32(dir, 0x02014b50);
        put16(dir, 20);
        put16(dir, 20);
        put16(dir, 0);
        put16(dir, method);
        put32(dir, 0);
        put32(dir, crc);
        put32(dir, static_cast<std::uint32_t>(body.size()));
        put32(dir, static_cast<std::uint32_t>(body.size()));
        put16(dir, static_cast<unsigned>(name.size()));
        for (int k = 0; k < 4; ++k) put16(dir, 0);
        put32(dir, 0);
        put32(dir, offset);
        dir.insert(dir.end(), name.begin(), name.end());
    }
    const auto dir_offset = static_cast<std::uint32_t>(out.size());
    out.insert(out.end(), dir.begin(), dir.end());
    put32(out, 0x06054b50);
    put16(out, 0);
    put16(out, 0);
    put16(out, static_cast<unsigned>(members.size()));
    put16(out, static_cast<unsigned>(members.size()));
    put32(out, static_cast<std::uint32_t>(dir.size()));
    put32(out, dir_offset);
    put16(out, 0);
    return out;
}

void test_zip() {
    const auto a = zip({{"one.npy", "hello"}, {"two.npy", "world!"}}, 0);
    const auto members = nightloc::detail::zip_members(a.data(), a.size());
    CHECK(members.size() == 2 && members[1].name == "two.npy" && members[1].size == 6);
    CHECK(std::memcmp(a.data() + members[1].offset, "world!", 6) == 0);
    const auto packed = zip({{"one.npy", "hello"}}, 8);
    bool named = false;
    try {
        nightloc::detail::zip_members(packed.data(), packed.size());
    } catch (const std::runtime_error& error) {
        named = std::string(error.what()).find("one.npy is compressed (zip method 8, deflate)") != std::string::npos;
    }
    CHECK(named);
    const std::vector<std::uint8_t> cut(a.begin(), a.end() - 10);
    CHECK_THROWS(nightloc::detail::zip_members(cut.data(), cut.size()), std::runtime_error);
}

std::string load_error(const std::string& path) {
    try {
        nightloc::load_map_file(path);
    } catch (const nightloc::MapFileError& error) {
        return error.what();
    }
    return "";
}

void test_not_maps() {
    CHECK(load_error("/nonexistent/garden.map").find("/nonexistent/garden.map: no such file") == 0);
    CHECK(load_error("/").find("is a folder") != std::string::npos);
    const std::string path = "nightloc_map_file_test.bin";
    auto write = [&](const std::vector<std::uint8_t>& bytes) {
        std::FILE* f = std::fopen(path.c_str(), "wb");
        std::fwrite(bytes.data(), 1, bytes.size(), f);
        std::fclose(f);
    };
    write({'h', 'e', 'l', 'l', 'o'});
    CHECK(load_error(path).find("not an .npz zip archive") != std::string::npos);
    write(zip({{"other.npy", "x"}}, 0));
    CHECK(load_error(path).find("no header") != std::string::npos);
    const std::string old_map = R"({"format": "nightloc-reference-map", "format_version": 2})";
    auto with_text = [&](const std::string& text) {
        auto h = npy("{'descr': '|u1', 'fortran_order': False, 'shape': (" + std::to_string(text.size()) + ",), }", 0);
        std::string member(h.begin(), h.end());
        return member + text;
    };
    write(zip({{"header.npy", with_text(old_map)}}, 0));
    const std::string old_error = load_error(path);
    CHECK(old_error.find("format version 2") != std::string::npos &&
          old_error.find("ReferenceMap.load('OLD.map').save('NEW.map')") != std::string::npos);
    write(zip({{"header.npy", with_text(R"({"format": "nightloc-reference-map", "format_version": 9})")}}, 0));
    CHECK(load_error(path).find("newer nightloc") != std::string::npos);
    auto corrupt = zip({{"header.npy", with_text(old_map)}}, 0);
    corrupt[100] ^= 1;  // inside the header's JSON: its CRC-32 no longer matches
    write(corrupt);
    CHECK(load_error(path).find("CRC-32") != std::string::npos);
    std::remove(path.c_str());
}

void test_wrap_angle() {
    // Python: math.pi - (math.pi - a) % (2 * math.pi)
    CHECK(nightloc::wrap_angle(0.0) == 0.0);
    CHECK(nightloc::wrap_angle(M_PI) == M_PI);
    CHECK(nightloc::wrap_angle(-M_PI) == M_PI);
    CHECK(nightloc::wrap_angle(3 * M_PI / 2) == M_PI - std::fmod(M_PI - 3 * M_PI / 2 + 2 * M_PI, 2 * M_PI));
    CHECK(std::fabs(nightloc::wrap_angle(7.0) - (7.0 - 2 * M_PI)) < 1e-15);
}

void test_settings_by_name() {
    nightloc::GridFilterSettings s;
    nightloc::set_setting(s, "likelihood_gain", 2.5);
    nightloc::set_setting(s, "heading_bins", 24);
    CHECK(s.likelihood_gain == 2.5 && s.heading_bins == 24);
    CHECK_THROWS(nightloc::set_setting(s, "heading_bins", 2.5), nightloc::SettingError);
    CHECK_THROWS(nightloc::set_setting(s, "likelyhood_gain", 1.0), nightloc::SettingError);
    CHECK_THROWS(nightloc::set_setting(s, "score_cap", NAN), nightloc::SettingError);
    CHECK(s.likelihood_gain == 2.5 && s.heading_bins == 24 && s.score_cap == nightloc::GridFilterSettings{}.score_cap);
}

}  // namespace

int main() {
    test_sha256();
    test_crc32();
    test_json();
    test_npy();
    test_zip();
    test_not_maps();
    test_wrap_angle();
    test_settings_by_name();
    return nightloc_test::check_summary();
}
