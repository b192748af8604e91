#!/usr/bin/env bash
# Configures a CMake preset and builds only what its tests need: every test whose labels
# do not match LABEL_REGEX (as `ctest -LE LABEL_REGEX` would pick them), the executable
# each one runs and every program of the build tree on its command line; add_dependencies
# brings the programs a test starts by itself. The sanitizer passes of scripts/test.sh use
# it so that they do not compile tools and tests they never run.
#   scripts/build-for-tests.sh [--list] PRESET [LABEL_REGEX]   (--list: print the targets, build nothing)
set -euo pipefail
cd "$(dirname "$0")/.."
list=0
[[ ${1:-} == --list ]] && { list=1; shift; }
preset=${1:?usage: scripts/build-for-tests.sh [--list] PRESET [LABEL_REGEX]}
exclude=${2:-}
cmake --preset "$preset" >/dev/null
build=build/$preset
mapfile -t targets < <(python3 - "$build" "$exclude" <<'EOF'
import os, re, sys
build, exclude = os.path.realpath(sys.argv[1]), sys.argv[2]
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
out = set()
for name, args in commands.items():
    if exclude and any(re.search(exclude, l) for l in labels.get(name, [])):
        continue
    for arg in args:
        for part in arg.split('='):   # --flag=PATH too
            if part.startswith(build + '/') and not os.path.isdir(part):
                out.add(os.path.relpath(part, build))
print('\n'.join(sorted(out)))
EOF
)
((${#targets[@]})) || { echo "build-for-tests: no test of $preset selected (labels excluded: '$exclude')" >&2; exit 1; }
((list)) && { printf '%s\n' "${targets[@]}"; exit 0; }
echo "build-for-tests: $preset: ${#targets[@]} test executables and programs (labels excluded: '${exclude:-none}')"
cmake --build --preset "$preset" --target "${targets[@]}"
