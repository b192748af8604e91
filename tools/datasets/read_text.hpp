#pragma once
// Reads a whole text file, plain or gzip-compressed (zlib tells them apart): the datasets
// in data/ are stored gzipped, copies elsewhere may be plain. The readers then go line by
// line with common/text_lines.hpp, as their fuzz targets do.
#include <optional>
#include <string>

namespace cairn::datasets {

/// The file's (decompressed) bytes; nullopt if it cannot be opened. Throws
/// std::runtime_error naming the file on a read error (a truncated or corrupt .gz).
std::optional<std::string> read_text_file(const std::string& path);

/// `path` if it exists, else `path.gz` if that exists, else `path`.
std::string plain_or_gz(const std::string& path);

}  // namespace cairn::datasets
