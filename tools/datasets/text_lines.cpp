#include "tools/datasets/text_lines.hpp"

#include <zlib.h>

#include <filesystem>
#include <stdexcept>

namespace cairn::datasets {

bool for_each_line(const std::string& path, const std::function<void(const std::string&, std::uint64_t)>& on_line) {
  gzFile f = gzopen(path.c_str(), "rb");  // reads plain files too
  if (!f) return false;
  std::string line;
  char buf[4096];
  std::uint64_t line_no = 0;
  try {
    while (gzgets(f, buf, sizeof buf)) {
      line += buf;
      if (!line.empty() && line.back() != '\n' && !gzeof(f)) continue;  // a long line: keep reading
      if (!line.empty() && line.back() == '\n') line.pop_back();
      on_line(line, ++line_no);
      line.clear();
    }
    if (!line.empty()) on_line(line, ++line_no);
  } catch (...) {
    gzclose(f);
    throw;
  }
  int err = 0;
  const char* msg = gzerror(f, &err);
  const std::string why = msg ? msg : "zlib error";
  gzclose(f);
  if (err != Z_OK && err != Z_STREAM_END) throw std::runtime_error("reading '" + path + "': " + why);
  return true;
}

std::string plain_or_gz(const std::string& path) {
  if (std::filesystem::exists(path)) return path;
  if (std::filesystem::exists(path + ".gz")) return path + ".gz";
  return path;
}

}  // namespace cairn::datasets
