#!/usr/bin/env bash
# Mutation check of the unit tests (issue 24): applies each one-line mutant of a list to a copy of the tree,
# builds the unit-test target that should catch it and runs it; a mutant is killed when the target fails
# (to build or a test), survived when it passes. Not part of `make test` (each mutant is an incremental
# build); the README's testing section has its last report.
#
# usage: tools/mutate.sh [--build-dir DIR] [MUTANTS] [WORK_DIR]
#   MUTANTS   list file (default tests/mutation/mutants.txt): "FILE | TEXT | REPLACEMENT | TARGET" per line,
#             '#' comments; TEXT must occur exactly once in FILE (<NL> in TEXT and REPLACEMENT is a line
#             break).
#   WORK_DIR  where the copy and its build live (default /tmp/iapsim-mutate); kept between runs, so a second
#             run builds only what the mutants touch.
#   --build-dir DIR  instead of a copy, mutate this source tree in place (each file restored after its
#             mutant, and on any exit) and build in DIR, an existing build of it: no full build first.
# Exits 1 when a mutant survived or could not be applied, 0 when every one was killed.
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
build_dir=""
if [ "${1:-}" = --build-dir ]; then
  build_dir=$(realpath "$2")
  shift 2
fi
list=$(realpath "${1:-$src/tests/mutation/mutants.txt}")
work=${2:-/tmp/iapsim-mutate}
mkdir -p "$work"
if [ -n "$build_dir" ]; then
  tree=$src build=$build_dir
  # a mutant left in the tree by an interruption is put back
  trap 'for f in $(find "$tree" -name "*.mutate-orig" -not -path "*/build/*"); do mv "$f" "${f%.mutate-orig}"; touch "${f%.mutate-orig}"; done' EXIT
else
  # the copy: the committed tree plus the working changes, without build outputs; tar keeps the files'
  # times, so a kept build recompiles only what changed
  tree=$work/tree build=$work/build
  rm -rf "$tree" && mkdir -p "$tree"
  (cd "$src" && tar --exclude=./build --exclude=./.git -cf - .) | (cd "$tree" && tar -xf -)
  cmake -S "$tree" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release > "$work/cmake.log"
fi

killed=0 survived=0 broken=0
while IFS= read -r line; do
  [[ -z "${line// }" || "$line" =~ ^[[:space:]]*# ]] && continue
  IFS='|' read -r file text replacement target <<< "$line"
  file=$(echo "$file" | xargs) target=$(echo "$target" | xargs)
  text=${text# } text=${text% } replacement=${replacement# } replacement=${replacement% }
  # apply: exactly one occurrence of TEXT, in Python for literal (not regex) matching
  if ! /usr/bin/python3 - "$tree/$file" "$text" "$replacement" <<'PY'
import sys
path, text, replacement = sys.argv[1], sys.argv[2].replace("<NL>", "\n"), sys.argv[3].replace("<NL>", "\n")
source = open(path).read()
if source.count(text) != 1:
    sys.exit(f"{path}: the mutant's text occurs {source.count(text)} times, expected once: {text!r}")
open(path + ".mutate-orig", "w").write(source)
open(path, "w").write(source.replace(text, replacement))
PY
  then
    echo "NOT APPLIED  $file: $text"
    broken=$((broken + 1))
    continue
  fi
  verdict=survived
  if ! ninja -C "$build" "$target" > "$work/build.log" 2>&1 < /dev/null; then
    verdict="killed (does not build)"
  elif ! "$build/bin/$target" > "$work/test.log" 2>&1 < /dev/null; then
    verdict="killed ($(grep -c '^\[  FAILED  \] .* ms)$' "$work/test.log" || true) tests fail)"
  fi
  mv "$tree/$file.mutate-orig" "$tree/$file"
  touch "$tree/$file"  # newer than the mutant's objects, so the next build recompiles it
  if [ "$verdict" = survived ]; then
    survived=$((survived + 1))
    echo "SURVIVED     $file: $text -> $replacement ($target)"
  else
    killed=$((killed + 1))
    echo "killed       $file: $text ($target: ${verdict#killed })"
  fi
done < "$list"
# leave the build matching the unmutated tree
ninja -C "$build" > "$work/build.log" 2>&1 || true
echo "mutants: $killed killed, $survived survived, $broken not applied"
[ "$survived" -eq 0 ] && [ "$broken" -eq 0 ]
