#include "tools/eval/plot.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>

namespace cairn::eval {

bool render_png(const Figure& fig, const std::string& dir, const std::string& name) {
  const std::string dat = dir + "/" + name + ".dat", gp = dir + "/" + name + ".gp", png = dir + "/" + name + ".png";
  {
    std::ofstream d(dat);
    for (const auto& s : fig.series) {
      d << "# " << s.title << "\n";
      for (std::size_t i = 0; i < s.x.size(); ++i) {
        d << s.x[i] << " " << s.y[i];
        if (!s.err.empty()) d << " " << s.err[i];
        d << "\n";
      }
      d << "\n\n";
    }
  }
  {
    std::ofstream g(gp);
    g << "set terminal pngcairo size 900,600 noenhanced\n" << "set output '" << png << "'\n";
    g << "set title '" << fig.title << "'\nset xlabel '" << fig.xlabel << "'\nset ylabel '" << fig.ylabel << "'\n";
    g << "set grid\nset key outside right top\n";
    if (fig.log_y) g << "set logscale y\nset format y '%.1e'\n";
    if (fig.equal_axes) g << "set size ratio -1\n";
    for (const auto& e : fig.extra) g << e << "\n";
    g << "plot ";
    for (std::size_t i = 0; i < fig.series.size(); ++i) {
      g << (i ? ", " : "") << "'" << dat << "' index " << i << " using " << (fig.series[i].err.empty() ? "1:2" : "1:2:3") << " with " << fig.series[i].style << " title '"
        << fig.series[i].title << "'";
    }
    g << "\n";
  }
  const std::string cmd = "gnuplot '" + gp + "' 2>/dev/null";
  if (std::system("command -v gnuplot >/dev/null 2>&1") != 0) {
    std::fprintf(stderr, "cairn-eval: gnuplot not found (Debian package gnuplot-nox); data in %s, script in %s\n",
                 dat.c_str(), gp.c_str());
    return false;
  }
  if (std::system(cmd.c_str()) != 0) {
    // pngcairo missing in some builds: fall back to the plain png terminal.
    std::string fallback = "sed -i 's/pngcairo/png/' '" + gp + "' && " + cmd;
    return std::system(fallback.c_str()) == 0;
  }
  return true;
}

void ellipse_points(double cx, double cy, double sxx, double sxy, double syy, double nsigma, std::vector<double>* xs,
                    std::vector<double>* ys) {
  Eigen::Matrix2d c;
  c << sxx, sxy, sxy, syy;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(c);
  const Eigen::Vector2d ev = es.eigenvalues().cwiseMax(0.0).cwiseSqrt() * nsigma;
  for (int i = 0; i <= 72; ++i) {
    const double a = 2 * std::numbers::pi * i / 72;
    const Eigen::Vector2d p = es.eigenvectors() * Eigen::Vector2d(ev(0) * std::cos(a), ev(1) * std::sin(a));
    xs->push_back(cx + p.x());
    ys->push_back(cy + p.y());
  }
  xs->push_back(std::numeric_limits<double>::quiet_NaN());  // gnuplot breaks the line at NaN
  ys->push_back(std::numeric_limits<double>::quiet_NaN());
}

}  // namespace cairn::eval
