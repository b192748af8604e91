#include "tools/datasets/read_text.hpp"

#include <zlib.h>

#include <filesystem>
#include <stdexcept>

namespace cairn::datasets {

std::optional<std::string> read_text_file(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");  // reads plain files too
  if (!f) return std::nullopt;
  std::string text;
  char buf[1 << 16];
  int n = 0;
  while ((n = gzread(f, buf, sizeof buf)) > 0) text.append(buf, static_cast<std::size_t>(n));
  int err = 0;
  const char* msg = gzerror(f, &err);
  const std::string why = msg ? msg : "zlib error";
  gzclose(f);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END)) throw std::runtime_error("reading '" + path + "': " + why);
  return text;
}

std::string plain_or_gz(const std::string& path) {
  if (std::filesystem::exists(path)) return path;
  if (std::filesystem::exists(path + ".gz")) return path + ".gz";
  return path;
}

}  // namespace cairn::datasets
