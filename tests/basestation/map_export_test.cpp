// The map exports read back the way their consumers read them: the PGM + YAML as ROS
// map_server's map_loader does (P5 header, width/height/maxval, the YAML keys, trinary
// thresholds, bottom row = origin), the PNG through libpng, the landmarks as JSON.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "basestation/mapper/export.hpp"

namespace cairn::mapper {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("cairn_map_export_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// map_server's YAML: flat "key: value" lines, origin a [x, y, yaw] list.
std::map<std::string, std::string> read_yaml(const fs::path& p) {
  std::ifstream in(p);
  std::map<std::string, std::string> kv;
  std::string line;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string v = line.substr(colon + 1);
    v.erase(0, v.find_first_not_of(' '));
    kv[line.substr(0, colon)] = v;
  }
  return kv;
}

std::vector<double> parse_list(std::string s) {
  std::vector<double> out;
  for (char& c : s)
    if (c == '[' || c == ']' || c == ',') c = ' ';
  std::istringstream in(s);
  double v = 0;
  while (in >> v) out.push_back(v);
  return out;
}

struct Pgm {
  int width = 0, height = 0, maxval = 0;
  std::vector<std::uint8_t> data;  // file order: top row first
};

// A binary PGM as netpbm defines it: "P5", then width, height, maxval as ASCII decimals
// separated by whitespace with '#' comments allowed, one whitespace byte, then the raster.
Pgm read_pgm(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::string magic;
  in >> magic;
  EXPECT_EQ(magic, "P5");
  auto next_int = [&]() {
    while (true) {
      const int c = in.peek();
      if (c == '#') {
        std::string comment;
        std::getline(in, comment);
      } else if (std::isspace(c)) {
        in.get();
      } else {
        break;
      }
    }
    int v = -1;
    in >> v;
    return v;
  };
  Pgm g;
  g.width = next_int();
  g.height = next_int();
  g.maxval = next_int();
  in.get();  // the single whitespace byte before the raster
  g.data.resize(static_cast<std::size_t>(g.width) * static_cast<std::size_t>(g.height));
  in.read(reinterpret_cast<char*>(g.data.data()), static_cast<std::streamsize>(g.data.size()));
  EXPECT_EQ(in.gcount(), static_cast<std::streamsize>(g.data.size()));
  in.get();
  EXPECT_TRUE(in.eof()) << "bytes after the raster";
  return g;
}

ClassGrid pattern(int w, int h) {
  ClassGrid g;
  g.geometry = {0.15, -1.2, 3.45, w, h};
  g.cells.resize(g.geometry.cells());
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) g.at(i, j) = static_cast<Cell>((i + 2 * j) % 3);
  return g;
}

TEST(MapExport, PgmAndYamlLoadAsMapServerLoadsThem) {
  const fs::path dir = temp_dir("pgm");
  const ClassGrid map = pattern(7, 5);
  write_map_server(map, (dir / "office").string());

  const auto y = read_yaml(dir / "office.yaml");
  ASSERT_EQ(y.count("image"), 1u);
  EXPECT_EQ(y.at("image"), "office.pgm");  // relative to the YAML's folder
  EXPECT_DOUBLE_EQ(std::stod(y.at("resolution")), 0.15);
  const auto origin = parse_list(y.at("origin"));
  ASSERT_EQ(origin.size(), 3u);
  EXPECT_NEAR(origin[0], -1.2, 1e-6);
  EXPECT_NEAR(origin[1], 3.45, 1e-6);
  EXPECT_EQ(origin[2], 0.0);
  EXPECT_EQ(std::stoi(y.at("negate")), 0);
  const double occ_th = std::stod(y.at("occupied_thresh")), free_th = std::stod(y.at("free_thresh"));
  EXPECT_DOUBLE_EQ(occ_th, 0.65);
  EXPECT_DOUBLE_EQ(free_th, 0.196);
  EXPECT_EQ(y.at("mode"), "trinary");

  const Pgm pgm = read_pgm(dir / y.at("image"));
  ASSERT_EQ(pgm.width, 7);
  ASSERT_EQ(pgm.height, 5);
  EXPECT_EQ(pgm.maxval, 255);
  // map_server (map_loader.cpp, trinary, negate 0): occ = (255 - v) / 255;
  // occ > occupied_thresh -> 100, occ < free_thresh -> 0, else -1; image row r is map row height - 1 - r.
  int checked = 0;
  for (int r = 0; r < pgm.height; ++r) {
    for (int c = 0; c < pgm.width; ++c) {
      const int v = pgm.data[static_cast<std::size_t>(r * pgm.width + c)];
      const double occ = (255.0 - v) / 255.0;
      const int value = occ > occ_th ? 100 : occ < free_th ? 0 : -1;
      const Cell want = map.at(c, pgm.height - 1 - r);
      const int expected = want == Cell::kObstacle ? 100 : want == Cell::kClear ? 0 : -1;
      EXPECT_EQ(value, expected) << "cell " << c << "," << pgm.height - 1 - r;
      ++checked;
    }
  }
  EXPECT_EQ(checked, 35);
  // The map's lower-left cell is the image's bottom-left pixel, with map_saver's values.
  EXPECT_EQ(pgm.data[static_cast<std::size_t>(4 * 7 + 0)], kPgmUnknown);  // (0,0): (0+0)%3 = 0 = unknown
  EXPECT_EQ(pgm.data[static_cast<std::size_t>(4 * 7 + 1)], kPgmClear);    // (1,0): clear
  EXPECT_EQ(pgm.data[static_cast<std::size_t>(4 * 7 + 2)], kPgmObstacle); // (2,0): obstacle
  fs::remove_all(dir);
}

TEST(MapExport, ReadMapServerRoundTripsAndRejectsBadFiles) {
  const fs::path dir = temp_dir("read");
  const ClassGrid map = pattern(9, 4);
  write_map_server(map, (dir / "m").string());
  const ClassGrid back = read_map_server((dir / "m.yaml").string());
  EXPECT_EQ(back.geometry.width, 9);
  EXPECT_EQ(back.geometry.height, 4);
  EXPECT_NEAR(back.geometry.origin_x, -1.2, 1e-6);
  EXPECT_NEAR(back.geometry.origin_y, 3.45, 1e-6);
  EXPECT_DOUBLE_EQ(back.geometry.resolution, 0.15);
  EXPECT_EQ(back.cells, map.cells);
  std::ofstream(dir / "bad.yaml") << "image: missing.pgm\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  EXPECT_THROW(read_map_server((dir / "bad.yaml").string()), std::runtime_error);
  std::ofstream(dir / "nores.yaml") << "image: m.pgm\norigin: [0, 0, 0]\n";
  EXPECT_THROW(read_map_server((dir / "nores.yaml").string()), std::runtime_error);
  fs::remove_all(dir);
}

TEST(MapExport, WritingToAMissingFolderThrowsNamingTheFile) {
  try {
    write_map_server(pattern(2, 2), "/nonexistent-cairn-dir/map");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-cairn-dir/map.pgm"), std::string::npos);
  }
  EXPECT_THROW(write_png(pattern(2, 2), {}, {}, "/nonexistent-cairn-dir/map.png"), std::runtime_error);
  EXPECT_THROW(write_landmarks_json({}, "/nonexistent-cairn-dir/l.json"), std::runtime_error);
}

TEST(MapExport, CovarianceEllipse) {
  const Ellipse e = covariance_ellipse({4.0, 0.0, 0.0, 1.0}, 3.0);
  EXPECT_NEAR(e.major, 6.0, 1e-9);
  EXPECT_NEAR(e.minor, 3.0, 1e-9);
  EXPECT_NEAR(std::abs(std::sin(e.angle)), 0.0, 1e-9);
  const Ellipse r = covariance_ellipse({1.0, 0.0, 0.0, 9.0}, 1.0);
  EXPECT_NEAR(r.major, 3.0, 1e-9);
  EXPECT_NEAR(std::abs(std::cos(r.angle)), 0.0, 1e-9);
  const Ellipse bad = covariance_ellipse({std::nan(""), 0, 0, 1}, 3.0);
  EXPECT_EQ(bad.major, 0.0);
}

TEST(MapExport, PngShowsMapTrajectoriesAndLandmarkEllipses) {
  const fs::path dir = temp_dir("png");
  ClassGrid map;
  map.geometry = {0.1, 0.0, 0.0, 50, 40};
  map.cells.assign(map.geometry.cells(), Cell::kClear);
  for (int i = 0; i < 50; ++i) map.at(i, 0) = Cell::kObstacle;
  map.at(49, 39) = Cell::kUnknown;
  std::vector<Trajectory> traj{{1, {{1.0, 2.0}, {4.0, 2.0}}}};
  std::vector<msg::Landmark> lms{{7, 2.5, 3.0, {0.04, 0.0, 0.0, 0.01}}};  // 3σ: 0.6 m along x, 0.3 m along y
  const std::string path = (dir / "map.png").string();
  write_png(map, traj, lms, path, {4, 3.0, {}});

  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&img, path.c_str())) << img.message;
  img.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> px(PNG_IMAGE_SIZE(img));
  ASSERT_TRUE(png_image_finish_read(&img, nullptr, px.data(), 0, nullptr)) << img.message;
  ASSERT_EQ(img.width, 200u);
  ASSERT_EQ(img.height, 160u);
  auto at = [&](double x, double y) {  // world -> pixel
    const int u = static_cast<int>(x / 0.1 * 4), v = static_cast<int>(160 - y / 0.1 * 4);
    const std::uint8_t* p = &px[(static_cast<std::size_t>(v) * 200 + static_cast<std::size_t>(u)) * 3];
    return std::array<int, 3>{p[0], p[1], p[2]};
  };
  EXPECT_EQ(at(2.0, 0.05), (std::array<int, 3>{0, 0, 0}));          // obstacle row
  EXPECT_EQ(at(3.0, 1.0), (std::array<int, 3>{255, 255, 255}));     // clear
  EXPECT_EQ(at(4.95, 3.95), (std::array<int, 3>{190, 190, 190}));   // unknown
  EXPECT_EQ(at(3.0, 2.0), (std::array<int, 3>{220, 30, 30}));       // robot 1's trajectory
  EXPECT_EQ(at(2.5 + 0.6, 3.0), (std::array<int, 3>{230, 0, 200})); // ellipse, end of the major axis
  EXPECT_EQ(at(2.5, 3.0 + 0.3 - 0.01), (std::array<int, 3>{230, 0, 200}));  // end of the minor axis
  EXPECT_EQ(at(2.5 + 0.45, 3.0 + 0.05), (std::array<int, 3>{255, 255, 255}));  // inside, off the cross
  fs::remove_all(dir);
}

TEST(MapExport, PngOutlinesMarkedBoxesOutsideTheirCells) {
  const fs::path dir = temp_dir("png_boxes");
  ClassGrid map;
  map.geometry = {0.1, 0.0, 0.0, 50, 40};
  map.cells.assign(map.geometry.cells(), Cell::kClear);
  PngOptions options;
  options.boxes = {{1.0, 1.0, 1.5, 1.2, kTooNarrowRgb}, {3.0, 2.0, 3.1, 2.1, kDisconnectedRgb}};
  const std::string path = (dir / "map.png").string();
  write_png(map, {}, {}, path, options);
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&img, path.c_str())) << img.message;
  img.format = PNG_FORMAT_RGB;
  std::vector<std::uint8_t> px(PNG_IMAGE_SIZE(img));
  ASSERT_TRUE(png_image_finish_read(&img, nullptr, px.data(), 0, nullptr)) << img.message;
  ASSERT_EQ(img.width, 200u);
  auto pixel = [&](int u, int v) {
    const std::uint8_t* p = &px[(static_cast<std::size_t>(v) * 200 + static_cast<std::size_t>(u)) * 3];
    return std::array<std::uint8_t, 3>{p[0], p[1], p[2]};
  };
  const std::array<std::uint8_t, 3> white{{255, 255, 255}};
  // Box 1: cells i 10..14, j 10..11 are pixels u 40..59, v 112..119 (v = 160 - 4 (j + 1) ..);
  // the outline is one pixel outside: u 39 and 60, v 111 and 120.
  EXPECT_EQ(pixel(39, 115), kTooNarrowRgb);
  EXPECT_EQ(pixel(60, 115), kTooNarrowRgb);
  EXPECT_EQ(pixel(50, 111), kTooNarrowRgb);
  EXPECT_EQ(pixel(50, 120), kTooNarrowRgb);
  EXPECT_EQ(pixel(40, 112), white) << "the cells themselves stay visible";
  EXPECT_EQ(pixel(50, 115), white);
  // Box 2, one cell (30, 20): pixels u 120..123, v 76..79; outline u 119 / 124, v 75 / 80.
  EXPECT_EQ(pixel(119, 78), kDisconnectedRgb);
  EXPECT_EQ(pixel(124, 78), kDisconnectedRgb);
  EXPECT_EQ(pixel(121, 75), kDisconnectedRgb);
  EXPECT_EQ(pixel(121, 80), kDisconnectedRgb);
  EXPECT_EQ(pixel(121, 78), white);
  fs::remove_all(dir);
}

TEST(MapExport, LandmarkJson) {
  const fs::path dir = temp_dir("json");
  std::vector<msg::Landmark> lms{{3, 1.5, -2.0, {0.04, 0.0, 0.0, 0.01}}, {9, 0.0, 0.0, {0.01, 0.0, 0.0, 0.01}}};
  write_landmarks_json(lms, (dir / "landmarks.json").string());
  std::ifstream in(dir / "landmarks.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("frame"), "global");
  ASSERT_EQ(j.at("count"), 2);
  EXPECT_EQ(j.at("landmarks")[0].at("id"), 3);
  EXPECT_DOUBLE_EQ(j.at("landmarks")[0].at("x").get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(j.at("landmarks")[0].at("cov")[0].get<double>(), 0.04);
  EXPECT_NEAR(j.at("landmarks")[0].at("ellipse_3sigma").at("major_m").get<double>(), 0.6, 1e-9);
  EXPECT_NEAR(j.at("landmarks")[0].at("ellipse_3sigma").at("minor_m").get<double>(), 0.3, 1e-9);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace cairn::mapper
