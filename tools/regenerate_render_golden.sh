#!/usr/bin/env bash
# Re-renders the golden images of render/golden_test.cc into tests/render/golden/ when the renderer's look
# changes on purpose. Look at the new images (and the diff) before committing them.
#   tools/regenerate_render_golden.sh [BUILD_DIR]     (default: build)
set -euo pipefail
build_dir="${1:-build}"
cmake --build "$build_dir" --target render_unit_tests
IAPSIM_REGENERATE_GOLDEN=1 "$build_dir/bin/render_unit_tests" --gtest_filter='Golden.*'
git -C "$(dirname "$0")/.." status --short tests/render/golden
