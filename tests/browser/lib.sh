# Browser tests: the integration helpers (lib.sh: real processes on a fixed DDS domain) plus headless Chromium
# through cdp.py. A machine without Chromium skips (exit 77) with the reason; deploy/install-deps.sh installs it.
source "$(dirname "${BASH_SOURCE[0]}")/../integration/lib.sh"
CDP=(python3 "$(dirname "${BASH_SOURCE[0]}")/cdp.py")
ARTIFACTS=${ARTIFACTS:?ARTIFACTS must name the folder the screenshots are kept in}
mkdir -p "$ARTIFACTS"

if ! command -v chromium >/dev/null && ! command -v chromium-browser >/dev/null; then
  echo "SKIP: chromium is not installed (deploy/install-deps.sh installs it): no browser to load the page in"
  exit 77
fi

# browser URL STEPS...: cdp.py's JSON lines on stdout; its reason on stderr, then the test fails.
browser() { "${CDP[@]}" "$@" 2>"$WORK/cdp.err" || fail "chromium: $(cat "$WORK/cdp.err")"; }
