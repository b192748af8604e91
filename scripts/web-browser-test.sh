#!/usr/bin/env bash
# The web view in a real browser (docs/web-view.md, "Tests"): Debian's chromium, headless,
# driven by puppeteer-core (npm, pinned by tests/web/package-lock.json), against cairn-base
# and two fake robots on a loopback DDS domain of its own. Not part of scripts/test.sh:
# it needs npm's registry, which a fresh machine does not reach (its TLS chain is not
# trusted there); the port to Debian's python3-selenium is the next step.
#   scripts/web-browser-test.sh [BUILD_DIR]   (default build/ci; built if missing)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build/ci}
scripts/setup-deps.sh --web
[[ -x $build/basestation/cairn-base && -x $build/tests/cairn-test-room-robots ]] ||
  cmake --build "$build" --target cairn-base cairn-test-room-robots
export CYCLONEDDS_URI="file://$PWD/config/dds/loopback.xml"
tests/web/npm-install.sh "$build/tests/web"
node "$build/tests/web/web_view_test.mjs" --base "$build/basestation/cairn-base" \
  --robots "$build/tests/cairn-test-room-robots" --config tests/web/base-web.toml \
  --dds config/dds/loopback.xml --out "$build/tests/web/out"
echo "web-browser-test: passed (screenshot: $build/tests/web/out/web_view.png)"
