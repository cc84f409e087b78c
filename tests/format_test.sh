#!/usr/bin/env bash
# Formatting (ctest entry `format`): every C++ file git tracks is as clang-format (the root's
# .clang-format: Google style, 100 columns) would write it. Usage: tests/format_test.sh SOURCE_DIR
# Fix with: clang-format -i $(git ls-files '*.cpp' '*.hpp')
set -euo pipefail
cd "$1"
command -v clang-format > /dev/null || { echo "format: clang-format is not installed" >&2; exit 1; }
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.h')
# One run over every file; each file that would change is named in a "warning" line.
mapfile -t bad < <(clang-format --dry-run "${files[@]}" 2>&1 | sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: warning: .*/\1/p' | sort -u)
if [ ${#bad[@]} -gt 0 ]; then
  printf 'format: not as clang-format writes it: %s\n' "${bad[@]}"
  exit 1
fi
echo "format: ${#files[@]} files as clang-format writes them"
