// Figures for cairn-eval: data files plus a gnuplot script, rendered to PNG by
// Debian's gnuplot (gnuplot-nox). Without gnuplot the data and script are still
// written and a warning says how to render them.
#pragma once

#include <string>
#include <vector>

namespace cairn::eval {

struct Series {
  std::string title;
  std::vector<double> x, y;
  std::string style = "lines";  // gnuplot "with" clause
  std::vector<double> err = {};  // if set, a third column (e.g. style "yerrorbars")
};

struct Figure {
  std::string title, xlabel, ylabel;
  bool log_y = false;
  bool equal_axes = false;
  std::vector<Series> series;
  std::vector<std::string> extra;  // raw gnuplot lines (e.g. labels)
};

/// Writes DIR/NAME.dat, DIR/NAME.gp and renders DIR/NAME.png. Returns false if gnuplot failed or is missing.
bool render_png(const Figure& fig, const std::string& dir, const std::string& name);

/// Points of the 3σ ellipse of a 2x2 covariance around a centre.
void ellipse_points(double cx, double cy, double sxx, double sxy, double syy, double nsigma, std::vector<double>* xs,
                    std::vector<double>* ys);

}  // namespace cairn::eval
