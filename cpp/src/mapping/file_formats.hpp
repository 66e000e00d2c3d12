// Internal pieces of the map-file reader (nightloc/map_file.hpp), apart so that the tests reach
// them: SHA-256 and CRC-32 of bytes, a JSON parser, a zip archive's stored members and a .npy
// array's header. Each parser throws std::runtime_error with a message saying what is wrong
// (the reader prefixes the file's name).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace nightloc {
namespace detail {

/// The SHA-256 digest of `size` bytes as 64 lower-case hex digits (FIPS 180-4).
std::string sha256_hex(const std::uint8_t* data, std::size_t size);

/// The CRC-32 of `size` bytes (the zip format's: reflected polynomial 0xEDB88320).
std::uint32_t crc32(const std::uint8_t* data, std::size_t size);

/// A parsed JSON value. Numbers are doubles (`integer` tells whether the text was an integer
/// without fraction or exponent); objects keep their keys sorted (duplicates: the last wins).
struct Json {
    enum class Type { null, boolean, number, string, array, object };
    Type type = Type::null;
    bool boolean = false;
    double number = 0;
    bool integer = false;
    std::string string;
    std::vector<Json> array;
    std::map<std::string, Json> object;

    /// The member `key` of an object, or nullptr (also when this is not an object).
    const Json* find(const std::string& key) const;
};

/// Parses a whole JSON text (RFC 8259; \u escapes become UTF-8, lone surrogates too).
/// Throws std::runtime_error naming the byte offset of the problem.
Json parse_json(const char* text, std::size_t size);

/// One member of a zip archive stored without compression: its name and its bytes' place.
struct ZipMember {
    std::string name;
    std::size_t offset = 0;  ///< of its data in the archive
    std::size_t size = 0;    ///< bytes
    std::uint32_t crc = 0;   ///< the CRC-32 the archive states
};

/// The members of a zip archive held in memory (`size` bytes), from its central directory
/// (zip64 records and extra fields understood). Throws std::runtime_error for a truncated or
/// damaged archive, an encrypted member or a compressed one (naming the member and method).
std::vector<ZipMember> zip_members(const std::uint8_t* data, std::size_t size);

/// A .npy array's header: element type, shape and where its data starts.
struct NpyHeader {
    std::string descr;  ///< e.g. "<f8", "|u1", "<i4"
    bool fortran_order = false;
    std::vector<std::size_t> shape;  ///< empty: a scalar
    std::size_t data_offset = 0;     ///< bytes from the start of the .npy member
    std::size_t item_size = 0;       ///< bytes per element, from descr
    std::size_t count() const;       ///< elements (the product of the shape)
};

/// Parses the header of a .npy member of `size` bytes (format versions 1.0, 2.0 and 3.0).
/// Throws std::runtime_error for another magic or version, a malformed header, a big-endian or
/// object type, or data shorter than the shape needs.
NpyHeader parse_npy_header(const std::uint8_t* data, std::size_t size);

}  // namespace detail
}  // namespace nightloc
