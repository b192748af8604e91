#include "firmware/executive/marker_decoder.hpp"

#include <algorithm>
#include <cmath>

#include "common/robot_marker.hpp"

namespace cairn::firmware {

namespace {

struct Run {
  double length = 0, slack = 0;  // whole: |true - length| <= slack; cut by the view: true >= length - slack
  bool taped = false, whole = false;
};

// Whether code `code`'s runs allow `r`.
bool allows(int code, const Run& r, double margin) {
  const double want = r.taped ? marker::tape_arc(code) : marker::bare_arc(code);
  if (r.whole) return std::abs(r.length - want) <= r.slack + margin;
  return r.length - r.slack <= want + margin;
}

}  // namespace

int decode_marker(const BodyBeam* beams, std::size_t n, double margin_rad) {
  if (n < 2) return kMarkerUnread;
  // Runs between edges; an edge lies between two beams of different tape.
  bool fits[marker::kCodes + 1] = {};
  for (int c = 1; c <= marker::kCodes; ++c) fits[c] = true;
  bool any_edge = false;
  // Where a run is cut by the end of the view, the last beam is the body's most grazing
  // one, placed least surely: a whole gap to its neighbour of slack.
  const double first_gap = std::abs(beams[1].phi - beams[0].phi), last_gap = std::abs(beams[n - 1].phi - beams[n - 2].phi);
  double run_start = beams[0].phi, start_slack = first_gap;
  bool start_is_edge = false;
  auto close_run = [&](double end, double end_slack, bool end_is_edge, bool taped) {
    Run r;
    r.taped = taped;
    r.whole = start_is_edge && end_is_edge;
    r.length = std::abs(end - run_start);
    r.slack = start_slack + end_slack;
    for (int c = 1; c <= marker::kCodes; ++c) fits[c] = fits[c] && allows(c, r, margin_rad);
  };
  for (std::size_t i = 1; i < n; ++i) {
    if (beams[i].taped == beams[i - 1].taped) continue;
    const double edge = 0.5 * (beams[i - 1].phi + beams[i].phi), slack = 0.5 * std::abs(beams[i].phi - beams[i - 1].phi);
    close_run(edge, slack, true, beams[i - 1].taped);
    any_edge = true;
    run_start = edge;
    start_slack = slack;
    start_is_edge = true;
  }
  close_run(beams[n - 1].phi, last_gap, false, beams[n - 1].taped);
  if (!any_edge) {
    // Tape over more than the longest tape run of any code, with no gap between beams
    // wide enough to hide the shortest bare run: a plain marker.
    double widest = 0;
    for (std::size_t i = 1; i < n; ++i) widest = std::max(widest, std::abs(beams[i].phi - beams[i - 1].phi));
    const double seen = std::abs(beams[n - 1].phi - beams[0].phi);
    const bool plain = beams[0].taped && seen - first_gap - last_gap > marker::tape_arc(marker::kCodes) + margin_rad &&
                       widest < marker::bare_arc(marker::kCodes) - margin_rad;
    return plain ? kMarkerPlain : kMarkerUnread;
  }
  int found = kMarkerUnread;
  for (int c = 1; c <= marker::kCodes; ++c) {
    if (!fits[c]) continue;
    if (found != kMarkerUnread) return kMarkerUnread;  // two codes fit
    found = c;
  }
  return found;
}

}  // namespace cairn::firmware
