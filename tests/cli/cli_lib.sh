# Shared by the command-line test scripts (source it): a temporary folder removed on exit, pass/fail
# counters, and the two checks every script uses.
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
passed=0; failed=0
check() {  # check NAME CONDITION-COMMAND...
  local name="$1"; shift
  if "$@"; then passed=$((passed+1)); else failed=$((failed+1)); echo "FAIL: $name"; fi
}
expect_exit() {  # expect_exit CODE PATTERN CMD...: exit code and a stderr pattern
  local code="$1" pattern="$2"; shift 2
  "$@" >"$tmp/out" 2>"$tmp/err"; local got=$?
  [ "$got" -eq "$code" ] && grep -q -- "$pattern" "$tmp/err" || { echo "  got exit $got, stderr: $(head -c 300 "$tmp/err")"; return 1; }
}
