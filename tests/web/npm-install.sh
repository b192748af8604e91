#!/usr/bin/env bash
# Installs the browser tests' npm packages (puppeteer-core, pinned by package-lock.json)
# into DIR (the build tree), unless that exact lock is installed there already.
#   tests/web/npm-install.sh DIR
set -euo pipefail
src=$(cd "$(dirname "$0")" && pwd)
dir=$1
mkdir -p "$dir"
cp "$src/package.json" "$src/package-lock.json" "$src/web_view_test.mjs" "$dir/"
if cmp -s "$src/package-lock.json" "$dir/node_modules/.cairn-lock" 2>/dev/null; then
  echo "npm-install: puppeteer-core already installed in $dir"
  exit 0
fi
command -v npm >/dev/null || { echo "npm-install: npm is missing: scripts/setup-deps.sh installs it" >&2; exit 1; }
# No install scripts: puppeteer-core downloads no browser; the test drives Debian's chromium.
(cd "$dir" && npm ci --ignore-scripts --no-audit --no-fund)
cp "$src/package-lock.json" "$dir/node_modules/.cairn-lock"
