#!/usr/bin/env bash
# Just the web view's browser test (ctest web_view_browser_test, docs/web-view.md): Debian's
# chromium, headless, driven by python3-selenium and chromium-driver, against cairn-base and
# two fake robots on a loopback DDS domain of its own. scripts/test.sh runs it with the suite.
#   scripts/web-browser-test.sh [BUILD_DIR]   (default build/ci, configured with the ci preset;
#                                              builds only the two programs the test starts)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/ci}
scripts/setup-deps.sh
if [[ ! -f $build/CMakeCache.txt ]]; then
  [[ $build == build/ci ]] || { echo "web-browser-test: $build is not a configured build directory" >&2; exit 1; }
  cmake --preset ci
fi
cmake --build "$build" --target cairn-base cairn-test-room-robots
ctest --test-dir "$build" -R '^web_view_browser_test$' --output-on-failure
echo "web-browser-test: passed (screenshot: $build/tests/web/out/web_view.png)"
