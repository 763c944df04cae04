#!/usr/bin/env bash
# cmake --install into a temporary prefix, then build and run a project that uses find_package(loopd).
# Usage: check_install.sh BUILD_DIR SOURCE_DIR [SANITIZERS]
# SANITIZERS (LOOPD_SANITIZE of the build, e.g. address,undefined): the installed static libraries are instrumented, so
# the consumer is compiled and linked with the same -fsanitize to link against them.
set -euo pipefail
build=$1; src=$2; sanitize=${3:-}
consumer_flags=()
if [ -n "$sanitize" ]; then
  consumer_flags=(-DCMAKE_CXX_FLAGS="-fsanitize=$sanitize -fno-omit-frame-pointer" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$sanitize")
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cmake --install "$build" --prefix "$tmp/prefix" >/dev/null
for f in bin/loopd bin/loopd-sim bin/loopd-eval bin/loopd-spy share/java/loopd_types.jar include/loopd/loop_event_t.hpp \
         include/loopd/base/point_cloud.hpp lib/cmake/loopd/loopdConfig.cmake share/loopd/page/index.html share/loopd/page/view.js; do
  [ -e "$tmp/prefix/$f" ] || { echo "missing after install: $f"; exit 1; }
done
cmake -S "$src/test/install/consumer" -B "$tmp/consumer" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release "${consumer_flags[@]}" >/dev/null
cmake --build "$tmp/consumer" -j2 >/dev/null
"$tmp/consumer/consumer"
"$tmp/prefix/bin/loopd" --version
