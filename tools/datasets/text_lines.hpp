#pragma once
// Reads a text file line by line, plain or gzip-compressed (zlib tells them apart): the
// datasets in data/ are stored gzipped, copies elsewhere may be plain.
#include <cstdint>
#include <functional>
#include <string>

namespace cairn::datasets {

/// Calls on_line(line, line_no) for every line, its '\n' removed (a '\r' before it stays).
/// Returns false if the file cannot be opened; throws std::runtime_error on a read error.
bool for_each_line(const std::string& path, const std::function<void(const std::string&, std::uint64_t)>& on_line);

/// `path` if it exists, else `path.gz` if that exists, else `path`.
std::string plain_or_gz(const std::string& path);

}  // namespace cairn::datasets
