// Line by line over a text held in memory, for the readers of line-based files (they take
// text, not streams, so their fuzz targets feed them bytes). Lines are numbered from 1;
// the '\n' is not part of a line; a last line without one is still a line.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <string_view>

namespace cairn {

template <typename OnLine>  // void(std::size_t line_no, const std::string& line)
void for_each_line(std::string_view text, OnLine&& on_line) {
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    const std::size_t end = std::min(text.find('\n', pos), text.size());
    const std::string line(text.substr(pos, end - pos));
    pos = end + 1;
    on_line(++line_no, line);
  }
}

}  // namespace cairn
