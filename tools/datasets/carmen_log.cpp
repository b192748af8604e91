#include "tools/datasets/carmen_log.hpp"

#include <charconv>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "common/text_lines.hpp"
#include "tools/datasets/read_text.hpp"

namespace cairn::eval {

namespace {

constexpr std::size_t kMaxErrors = 10;
constexpr std::size_t kMaxReadings = 8192;

// Splits on spaces/tabs, one token at a time.
class Tokens {
 public:
  explicit Tokens(std::string_view s) : s_(s) {}
  bool next(std::string_view* tok) {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t' || s_[pos_] == '\r' || s_[pos_] == '\n')) ++pos_;
    if (pos_ >= s_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < s_.size() && s_[pos_] != ' ' && s_[pos_] != '\t' && s_[pos_] != '\r' && s_[pos_] != '\n') ++pos_;
    *tok = s_.substr(start, pos_ - start);
    return true;
  }
  bool number(double* v) {
    std::string_view t;
    if (!next(&t)) return false;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), *v);
    return r.ec == std::errc() && r.ptr == t.data() + t.size() && std::isfinite(*v);
  }

 private:
  std::string_view s_;
  std::size_t pos_ = 0;
};

void bad_line(CarmenLog* log, std::uint64_t line_no, const char* why) {
  ++log->bad;
  if (log->errors.size() < kMaxErrors) log->errors.push_back("line " + std::to_string(line_no) + ": " + why);
}

}  // namespace

void parse_carmen_line(std::string_view line, std::uint64_t line_no, CarmenLog* log) {
  ++log->lines;
  Tokens t(line);
  std::string_view kind;
  if (!t.next(&kind) || kind.front() == '#') return;
  if (kind == "FLASER") {
    double n = 0;
    if (!t.number(&n) || n < 1 || n > kMaxReadings || n != std::floor(n)) return bad_line(log, line_no, "FLASER: bad reading count");
    CarmenScan s;
    s.ranges.resize(static_cast<std::size_t>(n));
    for (auto& r : s.ranges) {
      double v = 0;
      if (!t.number(&v) || v < 0) return bad_line(log, line_no, "FLASER: bad or missing range");
      r = static_cast<float>(v);
    }
    double v[7];
    for (double& x : v)
      if (!t.number(&x)) return bad_line(log, line_no, "FLASER: bad or missing pose/timestamp");
    s.pose = {v[0], v[1], normalize_angle(v[2])};
    s.odom = {v[3], v[4], normalize_angle(v[5])};
    s.stamp = v[6];
    log->scans.push_back(std::move(s));
  } else if (kind == "ODOM") {
    double v[7];
    for (double& x : v)
      if (!t.number(&x)) return bad_line(log, line_no, "ODOM: bad or missing field");
    log->odom.push_back({{v[0], v[1], normalize_angle(v[2])}, v[3], v[4], v[6]});
  } else {
    ++log->skipped;
  }
}

CarmenLog read_carmen_log(const std::string& path) {
  const std::optional<std::string> text = datasets::read_text_file(path);
  if (!text) throw std::runtime_error("cannot open Carmen log '" + path + "'");
  CarmenLog log;
  for_each_line(*text, [&](std::size_t line_no, const std::string& line) { parse_carmen_line(line, line_no, &log); });
  return log;
}

}  // namespace cairn::eval
