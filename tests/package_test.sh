#!/usr/bin/env bash
# The installed package, used as an outside project would: `cmake --install` this build into a
# temporary prefix, then configure, build and test examples/own_solver against that prefix
# alone (find_package(minv) in an unrelated CMake project; its solver's conformance test; its
# own minv-like command); then the README's C++ snippets, built as written against the same
# prefix. Usage: tests/package_test.sh BUILD_DIR SOURCE_DIR
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
# The README's C++ snippets (section "Use it from C++"), as written, with the example's solver.
snippet="$work/snippet"
mkdir -p "$snippet"
cp "$src/examples/own_solver/blocked_cholesky.hpp" "$src/examples/own_solver/blocked_cholesky.cpp" \
  "$snippet/"
section() { sed -n '/^### Use it from C++/,/^## /p' "$src/README.md"; }
block() { section | awk -v lang="$1" '$0 == "```" { on = 0 } on { print } $0 == "```" lang { on = 1 }'; }
{
  printf 'cmake_minimum_required(VERSION 3.25)\nproject(snippet LANGUAGES CXX)\n'
  printf 'set(CMAKE_CXX_STANDARD 20)\n'
  block cmake
} > "$snippet/CMakeLists.txt"
block cpp > "$snippet/main.cpp"
grep -q find_package "$snippet/CMakeLists.txt" && grep -q runCli "$snippet/main.cpp" ||
  { echo "package_test: the README's C++ snippets were not found" >&2; exit 1; }
cmake -S "$snippet" -B "$snippet/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
  > "$work/snippet-configure.log"
cmake --build "$snippet/build" -j"$(nproc)" > "$work/snippet-build.log" 2>&1 ||
  { cat "$work/snippet-build.log"; exit 1; }
"$snippet/build/own_minv" --report > "$work/snippet-report.log" ||
  { cat "$work/snippet-report.log"; exit 1; }
"$snippet/build/own_minv" solvers | grep -q "^blocked-cholesky "
echo "package_test: install, find_package(minv), example and README snippets: passed"
