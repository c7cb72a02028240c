# What the end-to-end test scripts share; source it right after `set -euo pipefail` with the script's
# arguments BUILD_BIN_DIR SOURCE_DIR: $bin, $src, $iapsim, a scratch folder $work (the working folder)
# removed on exit, `fail`, `expect_exit` and `wait_code`.
# shellcheck shell=bash
bin=$(realpath "$1")
src=$(realpath "$2")
iapsim=$bin/iapsim
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# each script works in its own folder: what a command writes beside it (runs/latest, the newest run) is its
# own while other tests run at the same time (make test runs them side by side)
cd "$work"
fail() { echo "FAIL: $*" >&2; exit 1; }
expect_exit() {  # CODE TEXT COMMAND...: expects the exit code and TEXT (literally) on its standard error
  set +e
  "${@:3}" > /dev/null 2> "$work/expect.err"
  local code=$?
  set -e
  [ $code -eq "$1" ] || fail "${*:3} exited $code: $(cat "$work/expect.err")"
  grep -qF -- "$2" "$work/expect.err" || fail "${*:3}: $(cat "$work/expect.err")"
}
wait_code() {  # PID: waits for that background job and sets $code to its exit code
  set +e
  wait "$1"
  code=$?
  set -e
}
