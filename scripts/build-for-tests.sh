#!/usr/bin/env bash
# Configures a CMake preset and builds only what its tests need: every test that
# `ctest -L INCLUDE -LE EXCLUDE` would pick (label regexes, both optional), the executable
# each one runs and every program of the build tree on its command line; add_dependencies
# brings the programs a test starts by itself. The sanitizer passes of scripts/test.sh use
# it so that they do not compile tools and tests they never run.
#   scripts/build-for-tests.sh [--list] PRESET [-L INCLUDE] [-LE EXCLUDE]   (--list: print the targets, build nothing)
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: scripts/build-for-tests.sh [--list] PRESET [-L INCLUDE] [-LE EXCLUDE]"
list=0
[[ ${1:-} == --list ]] && { list=1; shift; }
preset=${1:?$usage}
shift
include='' exclude=''
while (($#)); do
  case "$1" in
    -L) include=${2:?$usage}; shift 2 ;;
    -LE) exclude=${2:?$usage}; shift 2 ;;
    *) echo "build-for-tests: unknown argument '$1' ($usage)" >&2; exit 2 ;;
  esac
done
cmake --preset "$preset" >/dev/null
build=build/$preset
mapfile -t targets < <(python3 - "$build" "$include" "$exclude" <<'EOF'
import os, re, sys
build, include, exclude = os.path.realpath(sys.argv[1]), sys.argv[2], sys.argv[3]
commands, labels = {}, {}
for root, _, files in os.walk(build):
    if 'CTestTestfile.cmake' not in files:
        continue
    for line in open(os.path.join(root, 'CTestTestfile.cmake')):
        m = re.match(r'add_test\(\[=\[(.+?)\]=\] (.*)\)$', line)
        if m:
            commands[m.group(1)] = re.findall(r'"((?:[^"\\]|\\.)*)"', m.group(2))
        m = re.match(r'set_tests_properties\(\[=\[(.+?)\]=\] PROPERTIES .*?\bLABELS "([^"]*)"', line)
        if m:
            labels[m.group(1)] = m.group(2).split(';')
if not commands:
    sys.exit(f'build-for-tests: no tests found under {build}')
# Only what the build can make: a test's output directory or data file under the build
# tree is an argument, not a target.
import subprocess
known = {line.split(': ')[0] for line in subprocess.run(['ninja', '-C', build, '-t', 'targets', 'all'],
                                                      capture_output=True, text=True, check=True).stdout.splitlines()}
out = set()
for name, args in commands.items():
    mine = labels.get(name, [])
    if include and not any(re.search(include, l) for l in mine):
        continue
    if exclude and any(re.search(exclude, l) for l in mine):
        continue
    for arg in args:
        for part in arg.split('='):   # --flag=PATH too
            if part.startswith(build + '/') and os.path.relpath(part, build) in known:
                out.add(os.path.relpath(part, build))
print('\n'.join(sorted(out)))
EOF
)
picked="labels: included '${include:-any}', excluded '${exclude:-none}'"
((${#targets[@]})) || { echo "build-for-tests: no test of $preset selected ($picked)" >&2; exit 1; }
((list)) && { printf '%s\n' "${targets[@]}"; exit 0; }
echo "build-for-tests: $preset: ${#targets[@]} test executables and programs ($picked)"
cmake --build --preset "$preset" --target "${targets[@]}"
