#include "basestation/mapper/export.hpp"

#include <png.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "common/text_lines.hpp"

namespace cairn::mapper {

namespace {

std::string base_name(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::uint8_t pgm_value(Cell c) {
  switch (c) {
    case Cell::kObstacle: return kPgmObstacle;
    case Cell::kClear: return kPgmClear;
    case Cell::kUnknown: break;
  }
  return kPgmUnknown;
}

struct Canvas {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgb;
  void set(int x, int y, const std::array<std::uint8_t, 3>& c) {
    if (x < 0 || y < 0 || x >= w || y >= h) return;
    auto* p = &rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 3];
    p[0] = c[0];
    p[1] = c[1];
    p[2] = c[2];
  }
  void dot(int x, int y, int r, const std::array<std::uint8_t, 3>& c) {
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) set(x + dx, y + dy, c);
  }
  // Bresenham; a line longer than the canvas' diagonal (a stray point) is not drawn.
  void line(double x0d, double y0d, double x1d, double y1d, const std::array<std::uint8_t, 3>& c, int thick = 0) {
    if (!std::isfinite(x0d) || !std::isfinite(y0d) || !std::isfinite(x1d) || !std::isfinite(y1d)) return;
    if (std::hypot(x1d - x0d, y1d - y0d) > 2.0 * (w + h)) return;
    int x0 = static_cast<int>(std::lround(x0d)), y0 = static_cast<int>(std::lround(y0d));
    const int x1 = static_cast<int>(std::lround(x1d)), y1 = static_cast<int>(std::lround(y1d));
    const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0), sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
    int err = dx + dy;
    while (true) {
      dot(x0, y0, thick, c);
      if (x0 == x1 && y0 == y1) break;
      const int e2 = 2 * err;
      if (e2 >= dy) {
        err += dy;
        x0 += sx;
      }
      if (e2 <= dx) {
        err += dx;
        y0 += sy;
      }
    }
  }
};

const std::array<std::array<std::uint8_t, 3>, 6> kRobotColours{{
    {{220, 30, 30}}, {{30, 90, 220}}, {{20, 160, 40}}, {{200, 120, 0}}, {{150, 40, 180}}, {{0, 160, 170}}}};

}  // namespace

Ellipse covariance_ellipse(const msg::Cov2& cov, double nsigma) {
  for (double v : cov) {
    if (!std::isfinite(v)) return {};
  }
  Mat2 m = msg::to_mat(cov);
  m = 0.5 * (m + m.transpose());
  Eigen::SelfAdjointEigenSolver<Mat2> es(m);
  if (es.info() != Eigen::Success) return {};
  const Vec2 ev = es.eigenvalues();  // ascending
  if (ev(0) < -1e-12) return {};
  Ellipse e;
  e.major = nsigma * std::sqrt(std::max(ev(1), 0.0));
  e.minor = nsigma * std::sqrt(std::max(ev(0), 0.0));
  const Vec2 v = es.eigenvectors().col(1);
  e.angle = std::atan2(v.y(), v.x());
  return e;
}

void write_map_server(const ClassGrid& map, const std::string& stem) {
  const GridGeometry& g = map.geometry;
  const std::string pgm = stem + ".pgm", yaml = stem + ".yaml";
  {
    std::ofstream out(pgm, std::ios::binary);
    if (!out) throw std::runtime_error(pgm + ": cannot open for writing");
    char res[64];
    std::snprintf(res, sizeof res, "%.3f", g.resolution);
    out << "P5\n# CREATOR: cairn-base " << res << " m/pix\n" << g.width << ' ' << g.height << "\n255\n";
    std::vector<char> row(static_cast<std::size_t>(g.width));
    for (int y = 0; y < g.height; ++y) {
      const int j = g.height - 1 - y;  // first row in the file is the top of the map
      for (int i = 0; i < g.width; ++i) row[static_cast<std::size_t>(i)] = static_cast<char>(pgm_value(map.at(i, j)));
      out.write(row.data(), static_cast<std::streamsize>(row.size()));
    }
    if (!out) throw std::runtime_error(pgm + ": write failed");
  }
  {
    std::ofstream out(yaml);
    if (!out) throw std::runtime_error(yaml + ": cannot open for writing");
    out << std::fixed << std::setprecision(6);
    out << "image: " << base_name(pgm) << "\n"
        << "mode: trinary\n"
        << "resolution: " << g.resolution << "\n"
        << "origin: [" << g.origin_x << ", " << g.origin_y << ", " << 0.0 << "]\n"
        << "negate: 0\n"
        << std::setprecision(3) << "occupied_thresh: " << kYamlOccupiedThresh << "\n"
        << "free_thresh: " << kYamlFreeThresh << "\n";
    if (!out) throw std::runtime_error(yaml + ": write failed");
  }
}

namespace {

std::string trim(std::string s) {
  const auto a = s.find_first_not_of(" \t\r\"'"), b = s.find_last_not_of(" \t\r\"'");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

}  // namespace

std::vector<msg::Landmark> read_landmarks_json(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_landmarks_json(text.str(), path);
}

std::vector<msg::Landmark> parse_landmarks_json(std::string_view text, const std::string& path) {
  std::vector<msg::Landmark> out;
  try {
    const nlohmann::json j = nlohmann::json::parse(text);
    for (const auto& l : j.at("landmarks")) {
      msg::Landmark m;
      m.id = l.at("id").get<std::uint32_t>();
      m.x = l.at("x").get<double>();
      m.y = l.at("y").get<double>();
      const auto& c = l.at("cov");
      if (c.size() != 4) throw std::runtime_error("a landmark's cov has " + std::to_string(c.size()) + " entries, not 4");
      for (std::size_t k = 0; k < 4; ++k) m.cov[k] = c.at(k).get<double>();
      if (!std::isfinite(m.x) || !std::isfinite(m.y)) throw std::runtime_error("landmark " + std::to_string(m.id) + " is not finite");
      out.push_back(m);
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return out;
}

void write_trajectories_csv(const std::vector<TrajectorySample>& samples, const std::string& path) {
  std::ofstream out(path);
  out << "robot,t_ns,x,y,theta\n";
  char line[160];
  for (const TrajectorySample& t : samples) {
    std::snprintf(line, sizeof line, "%u,%lld,%.6f,%.6f,%.6f\n", static_cast<unsigned>(t.robot),
                  static_cast<long long>(t.stamp), t.pose.x, t.pose.y, t.pose.theta);
    out << line;
  }
  out.flush();
  if (!out) throw std::runtime_error("cannot write " + path);
}

std::vector<TrajectorySample> read_trajectories_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_trajectories_csv(text.str(), path);
}

std::vector<TrajectorySample> parse_trajectories_csv(std::string_view text, const std::string& path) {
  std::vector<TrajectorySample> out;
  bool header = false;
  for_each_line(text, [&](std::size_t line_no, const std::string& line) {
    auto fail = [&](const std::string& why) { return std::runtime_error(path + ":" + std::to_string(line_no) + ": " + why); };
    if (line_no == 1) {
      if (line.rfind("robot,t_ns,x,y,theta", 0) != 0) throw fail("expected the header robot,t_ns,x,y,theta");
      header = true;
      return;
    }
    if (line.empty() || line == "\r") return;
    unsigned long robot = 0;
    long long stamp = 0;
    double x = 0, y = 0, theta = 0;
    int used = 0;
    if (std::sscanf(line.c_str(), "%lu,%lld,%lf,%lf,%lf%n", &robot, &stamp, &x, &y, &theta, &used) != 5 ||
        line.find_first_not_of(" \r", static_cast<std::size_t>(used)) != std::string::npos) {
      throw fail("expected robot,t_ns,x,y,theta");
    }
    if (robot < 1 || robot > 65535) throw fail("robot id outside 1..65535");
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(theta)) throw fail("a pose that is not finite");
    out.push_back({static_cast<std::uint16_t>(robot), stamp, {x, y, theta}});
  });
  if (!header) throw std::runtime_error(path + ": empty (expected the header robot,t_ns,x,y,theta)");
  return out;
}

ClassGrid read_map_server(const std::string& yaml_path) {
  std::ifstream in(yaml_path);
  if (!in) throw std::runtime_error(yaml_path + ": cannot open");
  std::map<std::string, std::string> kv;
  std::string line;
  while (std::getline(in, line)) {
    if (const auto h = line.find('#'); h != std::string::npos) line.resize(h);
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    kv[trim(line.substr(0, colon))] = trim(line.substr(colon + 1));
  }
  auto need = [&](const char* key) -> const std::string& {
    const auto it = kv.find(key);
    if (it == kv.end()) throw std::runtime_error(yaml_path + ": missing key '" + key + "'");
    return it->second;
  };
  auto number = [&](const char* key, const std::string& text) {
    try {
      std::size_t used = 0;
      const double v = std::stod(text, &used);
      if (!std::isfinite(v)) throw std::invalid_argument("not finite");
      return v;
    } catch (const std::exception&) {
      throw std::runtime_error(yaml_path + ": '" + key + "' is not a number: " + text);
    }
  };
  ClassGrid g;
  g.geometry.resolution = number("resolution", need("resolution"));
  if (!(g.geometry.resolution > 0)) throw std::runtime_error(yaml_path + ": resolution must be positive");
  {
    std::string o = need("origin");
    for (char& c : o)
      if (c == '[' || c == ']' || c == ',') c = ' ';
    std::istringstream os(o);
    std::vector<double> v;
    std::string tok;
    while (os >> tok) v.push_back(number("origin", tok));
    if (v.size() != 3) throw std::runtime_error(yaml_path + ": origin must be [x, y, yaw]");
    if (v[2] != 0.0) throw std::runtime_error(yaml_path + ": a rotated origin (yaw != 0) is not supported");
    g.geometry.origin_x = v[0];
    g.geometry.origin_y = v[1];
  }
  const bool negate = kv.count("negate") && number("negate", kv["negate"]) != 0.0;
  const double occ_th = number("occupied_thresh", need("occupied_thresh"));
  const double free_th = number("free_thresh", need("free_thresh"));
  if (kv.count("mode") && kv["mode"] != "trinary")
    throw std::runtime_error(yaml_path + ": mode '" + kv["mode"] + "' is not supported (trinary only)");
  std::string image = need("image");
  if (image.empty()) throw std::runtime_error(yaml_path + ": empty image");
  if (image[0] != '/') {
    const auto slash = yaml_path.find_last_of('/');
    if (slash != std::string::npos) image = yaml_path.substr(0, slash + 1) + image;
  }
  std::ifstream pin(image, std::ios::binary);
  if (!pin) throw std::runtime_error(image + ": cannot open (named by " + yaml_path + ")");
  std::string magic;
  pin >> magic;
  if (magic != "P5") throw std::runtime_error(image + ": not a binary PGM (P5)");
  auto next_int = [&]() {
    while (true) {
      const int c = pin.peek();
      if (c == '#') {
        std::string comment;
        std::getline(pin, comment);
      } else if (c != EOF && std::isspace(c)) {
        pin.get();
      } else {
        break;
      }
    }
    long v = -1;
    if (!(pin >> v) || v <= 0 || v > 1000000) throw std::runtime_error(image + ": bad PGM header");
    return static_cast<int>(v);
  };
  g.geometry.width = next_int();
  g.geometry.height = next_int();
  if (next_int() != 255) throw std::runtime_error(image + ": maxval must be 255");
  pin.get();
  std::vector<char> raster(g.geometry.cells());
  pin.read(raster.data(), static_cast<std::streamsize>(raster.size()));
  if (pin.gcount() != static_cast<std::streamsize>(raster.size())) throw std::runtime_error(image + ": raster too short");
  g.cells.resize(g.geometry.cells());
  for (int r = 0; r < g.geometry.height; ++r) {
    for (int c = 0; c < g.geometry.width; ++c) {
      const double v = static_cast<unsigned char>(raster[static_cast<std::size_t>(r) * static_cast<std::size_t>(g.geometry.width) +
                                                        static_cast<std::size_t>(c)]);
      const double occ = negate ? v / 255.0 : (255.0 - v) / 255.0;
      g.at(c, g.geometry.height - 1 - r) = occ > occ_th ? Cell::kObstacle : occ < free_th ? Cell::kClear : Cell::kUnknown;
    }
  }
  return g;
}

void write_png(const ClassGrid& map, const std::vector<Trajectory>& trajectories, const std::vector<msg::Landmark>& landmarks,
               const std::string& path, const PngOptions& options) {
  std::vector<std::uint8_t> bytes;
  try {
    bytes = render_png(map, trajectories, landmarks, options);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) throw std::runtime_error(path + ": PNG write failed: " + std::strerror(errno));
}

std::vector<std::uint8_t> render_png(const ClassGrid& map, const std::vector<Trajectory>& trajectories,
                                     const std::vector<msg::Landmark>& landmarks, const PngOptions& options) {
  const GridGeometry& g = map.geometry;
  const int s = std::max(1, options.pixels_per_cell);
  Canvas cv;
  cv.w = g.width * s;
  cv.h = g.height * s;
  if (cv.w <= 0 || cv.h <= 0) throw std::runtime_error("empty map");
  cv.rgb.assign(static_cast<std::size_t>(cv.w) * static_cast<std::size_t>(cv.h) * 3, 0);
  for (int j = 0; j < g.height; ++j) {
    for (int i = 0; i < g.width; ++i) {
      const Cell c = map.at(i, j);
      const std::uint8_t v = c == Cell::kObstacle ? 0 : c == Cell::kClear ? 255 : 190;
      for (int dy = 0; dy < s; ++dy)
        for (int dx = 0; dx < s; ++dx) cv.set(i * s + dx, (g.height - 1 - j) * s + dy, {v, v, v});
    }
  }
  const auto px = [&](const Vec2& p) {
    return Vec2((p.x() - g.origin_x) / g.resolution * s, cv.h - (p.y() - g.origin_y) / g.resolution * s);
  };
  for (const Trajectory& t : trajectories) {
    const auto& colour = kRobotColours[static_cast<std::size_t>(t.robot > 0 ? t.robot - 1 : 0) % kRobotColours.size()];  // robot 1 red, 2 blue, 3 green
    for (std::size_t k = 1; k < t.points.size(); ++k) {
      const Vec2 a = px(t.points[k - 1]), b = px(t.points[k]);
      cv.line(a.x(), a.y(), b.x(), b.y(), colour, s >= 3 ? 1 : 0);
    }
    if (!t.points.empty()) {
      const Vec2 a = px(t.points.front());
      if (std::isfinite(a.x()) && std::isfinite(a.y()))
        cv.dot(static_cast<int>(std::lround(a.x())), static_cast<int>(std::lround(a.y())), s + 1, colour);
    }
  }
  const std::array<std::uint8_t, 3> lm_colour{{230, 0, 200}};
  for (const msg::Landmark& l : landmarks) {
    const Vec2 c = px({l.x, l.y});
    if (!std::isfinite(c.x()) || !std::isfinite(c.y())) continue;
    const double arm = 1.5 * s;
    cv.line(c.x() - arm, c.y(), c.x() + arm, c.y(), lm_colour);
    cv.line(c.x(), c.y() - arm, c.x(), c.y() + arm, lm_colour);
    const Ellipse e = covariance_ellipse(l.cov, options.nsigma);
    constexpr int kSteps = 72;
    Vec2 prev;
    for (int k = 0; k <= kSteps; ++k) {
      const double u = 2.0 * M_PI * k / kSteps;
      const Vec2 local(e.major * std::cos(u), e.minor * std::sin(u));
      const Vec2 w = Vec2(l.x, l.y) + Eigen::Rotation2Dd(e.angle) * local;
      const Vec2 p = px(w);
      if (k > 0) cv.line(prev.x(), prev.y(), p.x(), p.y(), lm_colour);
      prev = p;
    }
  }
  for (const MarkedBox& b : options.boxes) {
    const Vec2 lo = px({b.min_x, b.min_y}), hi = px({b.max_x, b.max_y});  // image y grows downwards
    if (!std::isfinite(lo.x()) || !std::isfinite(lo.y()) || !std::isfinite(hi.x()) || !std::isfinite(hi.y())) continue;
    const double x0 = lo.x() - 1, x1 = hi.x(), y0 = hi.y() - 1, y1 = lo.y();  // one pixel outside the cells
    cv.line(x0, y0, x1, y0, b.rgb);
    cv.line(x1, y0, x1, y1, b.rgb);
    cv.line(x1, y1, x0, y1, b.rgb);
    cv.line(x0, y1, x0, y0, b.rgb);
  }
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(cv.w);
  image.height = static_cast<png_uint_32>(cv.h);
  image.format = PNG_FORMAT_RGB;
  // First the size, then the bytes (libpng's two-call protocol for memory output).
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, cv.rgb.data(), cv.w * 3, nullptr)) {
    const std::string msg = image.message;
    png_image_free(&image);
    throw std::runtime_error("PNG encoding failed: " + msg);
  }
  std::vector<std::uint8_t> out(size);
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, cv.rgb.data(), cv.w * 3, nullptr)) {
    const std::string msg = image.message;
    png_image_free(&image);
    throw std::runtime_error("PNG encoding failed: " + msg);
  }
  out.resize(size);
  return out;
}

void write_landmarks_json(const std::vector<msg::Landmark>& landmarks, const std::string& path) {
  nlohmann::json j;
  j["frame"] = "global";
  j["count"] = landmarks.size();
  j["landmarks"] = nlohmann::json::array();
  for (const msg::Landmark& l : landmarks) {
    const Ellipse e = covariance_ellipse(l.cov, 3.0);
    j["landmarks"].push_back({{"id", l.id},
                              {"x", l.x},
                              {"y", l.y},
                              {"cov", {l.cov[0], l.cov[1], l.cov[2], l.cov[3]}},
                              {"ellipse_3sigma", {{"major_m", e.major}, {"minor_m", e.minor}, {"angle_rad", e.angle}}}});
  }
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << j.dump(2) << "\n";
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace cairn::mapper
