#!/usr/bin/env bash
# The installed package, used as an outside project would: `cmake --install` this build into a
# temporary prefix, then configure, build and test examples/own_solver against that prefix
# alone (find_package(minv) in an unrelated CMake project; its solver's conformance test; its
# own minv-like command). Usage: tests/package_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix="$work/prefix"
cmake --install "$build" --prefix "$prefix" > "$work/install.log"
# Nothing installed may point back into the build or source folders.
if grep -rIl -e "$build" -e "$src" "$prefix/include" "$prefix/lib/cmake" 2>/dev/null; then
  echo "package_test: installed files refer to the build or source folder (above)" >&2
  exit 1
fi
test -x "$prefix/bin/minv"
"$prefix/bin/minv" solvers > /dev/null
cmake -S "$src/examples/own_solver" -B "$work/example" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" > "$work/configure.log"
cmake --build "$work/example" -j"$(nproc)" > "$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
ctest --test-dir "$work/example" --output-on-failure
"$work/example/own_minv" solvers | grep -q "^blocked-cholesky "
echo "package_test: install, find_package(minv), example build and conformance passed"
