#!/usr/bin/env bash
# `cpgmatch dashboard` in a real browser during a real study: an optimizer, a simulation worker (fake rollouts)
# and the dashboard over DDS on the loopback; headless Chromium opens the page while the study runs and keeps it
# open (the study waits for a worker until the page shows that it does). The page shows the study running,
# Chart.js (served by the dashboard, any other host unreachable) draws its four charts (the legs' one names
# Morti's four legs, the study's robot), its completed count
# rises without a reload (server-sent events), and once the study is done the count on the page equals
# `cpgmatch status --json`'s. The screenshot taken mid-study is kept in
# $ARTIFACTS. Also: a second dashboard on the same port, and a bad --bind, exit 2 naming the flag; --bind
# beyond the loopback says so; under DDS-Security the dashboard reads as the viewer, and without a certificate
# it reads nothing.
source "$(dirname "$0")/lib.sh"
[[ -f /usr/share/javascript/chart.js/chart.min.js ]] ||
  { echo "SKIP: libjs-chart.js is not installed (deploy/install-deps.sh installs it)"; exit 77; }

write_study "$WORK/s.yaml" dashboard-live 40 6
start_optimizer "$WORK/s.db"
"$BIN/cpgmatch" dashboard --port 0 --domain "$DOMAIN" --localhost-only >"$WORK/dashboard.out" 2>"$WORK/dashboard.log" &
DASHBOARD=$!
PIDS+=("$DASHBOARD")
wait_until 10 grep -q "http://" "$WORK/dashboard.out" || fail "the dashboard printed no URL"
url=$(grep -o 'http://[^ ]*' "$WORK/dashboard.out")
port=$(sed 's|.*:\([0-9]*\)/$|\1|' <<<"$url")

# The study is submitted before any simulation worker is on the domain: it waits, and says so, while Chromium
# starts (seconds on a loaded machine, which a short study would not wait for); the worker joins once the page
# shows that message. So the page is open during the study however slow either is, and shows what it waits for.
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
completed="document.getElementById('completed-$id')?.textContent"
row="#studies tr[data-study=\"$id\"]"
state="document.querySelector('$row .state')?.textContent"
"${CDP[@]}" "$url" --timeout 40 \
  --wait "(document.querySelector('$row .msg')?.textContent || '').startsWith('waiting for simulation workers')" \
  --eval "document.querySelector('$row .msg').textContent" \
  --wait "$state === 'running' && +($completed) >= 3" \
  --eval "$state" --eval "+($completed)" --eval "+document.body.dataset.updates" \
  --eval "typeof Chart" --eval "Object.keys(Chart.instances).length" \
  --eval "Chart.getChart('chart-cost').data.datasets[0].data.length + Chart.getChart('chart-cost').data.datasets[1].data.length" \
  --eval "document.getElementById('legs-title').textContent" \
  --screenshot "$ARTIFACTS/dashboard-during-study.png" \
  --wait "$state === 'done'" \
  --eval "+($completed)" --eval "+document.body.dataset.updates" >"$WORK/page.jsonl" 2>"$WORK/cdp.err" &
BROWSER=$!
PIDS+=("$BROWSER")
wait_until 40 test -s "$WORK/page.jsonl" || fail "the page never showed what the study waits for: $(cat "$WORK/cdp.err")"
start_worker w --slots 1 --fake-rollout-ms 120
wait "$BROWSER" || fail "chromium: $(cat "$WORK/cdp.err")"
mapfile -t page <"$WORK/page.jsonl"
[[ ${#page[@]} -eq 10 ]] || fail "chromium gave ${#page[@]} values: ${page[*]}"
[[ ${page[0]} == "\"waiting for simulation workers: none on domain $DOMAIN\"" ]] || fail "the page's message: ${page[0]}"
page=("${page[@]:1}")
[[ ${page[0]} == '"running"' ]] || fail "mid-study the page said the study is ${page[0]}"
[[ ${page[3]} == '"function"' ]] || fail "Chart.js did not load from the dashboard: typeof Chart = ${page[3]}"
[[ ${page[4]} -eq 4 ]] || fail "${page[4]} charts drawn, not 4 (cost, terms, parameters, legs)"
[[ ${page[5]} -ge 3 ]] || fail "the cost chart has ${page[5]} points mid-study"
[[ ${page[6]} == '"Legs: 4 (FL FR HL HR)'* ]] || fail "the legs' title: ${page[6]}"
[[ -s $ARTIFACTS/dashboard-during-study.png ]] || fail "no screenshot"
# Live: the same page, never reloaded, went from the mid-study count to the end through further updates.
((page[7] > page[1])) || fail "the page's completed count did not rise without a reload: ${page[1]} -> ${page[7]}"
((page[8] > page[2])) || fail "no further update reached the page: ${page[2]} -> ${page[8]} snapshots"
status=$(state_json "$id")
[[ $(json_field "$status" state) == done ]] || fail "status: $status"
[[ $(json_field "$status" completed) -eq ${page[7]} ]] ||
  fail "the page says $((page[7])) completed, status --json $(json_field "$status" completed)"

# One dashboard per port: a second one on the same port exits 2 naming --port; a bad address names --bind.
set +e
"$BIN/cpgmatch" dashboard --port "$port" --domain "$DOMAIN" --localhost-only >/dev/null 2>"$WORK/second.err"
code=$?
"$BIN/cpgmatch" dashboard --bind 127.0.0.300 --domain "$DOMAIN" >/dev/null 2>"$WORK/bad-bind.err"
bad_bind=$?
set -e
[[ $code -eq 2 ]] && grep -q -- "--port $port: already in use" "$WORK/second.err" ||
  fail "a second dashboard on port $port: exit $code, $(cat "$WORK/second.err")"
[[ $bad_bind -eq 2 ]] && grep -q -- "--bind '127.0.0.300'" "$WORK/bad-bind.err" ||
  fail "--bind 127.0.0.300: exit $bad_bind, $(cat "$WORK/bad-bind.err")"
"$BIN/cpgmatch" dashboard --bind 0.0.0.0 --port 0 --domain "$DOMAIN" --localhost-only >"$WORK/open.out" 2>"$WORK/open.err" &
OPEN=$!
PIDS+=("$OPEN")
wait_until 10 grep -q "without authentication" "$WORK/open.err" || fail "--bind 0.0.0.0 did not say it serves the network"
kill "$OPEN" "$DASHBOARD"
wait "$DASHBOARD" || fail "the dashboard did not end cleanly on SIGTERM (exit $?)"
kill "$OPT_PID" "$WORKER_PID"

# Under DDS-Security the dashboard is the viewer (its default enclave): it reads the study and its trials; the
# same dashboard without a certificate reads nothing of the secure domain.
KS=$WORK/keystore
"$(dirname "$0")/../../deploy/make-study-pki.sh" "$KS" --days 2 >"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh: $(cat "$WORK/pki.log")"
write_study "$WORK/secure.yaml" dashboard-secure 8 4
start_optimizer "$WORK/secure.db" --keystore "$KS"
# A worker's id must be its certificate's CN or CN/suffix (docs/deploy.md): "worker" here.
"$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --id worker --slots 2 --fake-rollout-ms 20 --localhost-only --keystore "$KS" \
  >>"$WORK/worker-secure.log" 2>&1 &
PIDS+=("$!")
for who in viewer nobody; do
  flags=(); [[ $who == viewer ]] && flags=(--keystore "$KS")
  "$BIN/cpgmatch" dashboard --port 0 --domain "$DOMAIN" --localhost-only "${flags[@]}" >"$WORK/$who.out" 2>"$WORK/$who.log" &
  PIDS+=("$!")
done
"$BIN/cpgmatch" study submit --config "$WORK/secure.yaml" --wait --quiet --domain "$DOMAIN" --localhost-only --timeout 30 \
  --keystore "$KS" >/dev/null 2>>"$WORK/cli.log" || fail "the secure study did not finish: $(tail -n 3 "$WORK/cli.log")"
seen() {  # seen WHO: "<studies> <trials of the first>" on WHO's dashboard
  curl -sf "$(grep -o 'http://[^ ]*' "$WORK/$1.out")api/snapshot" |
    python3 -c 'import json,sys; s=json.load(sys.stdin)["studies"]; print(len(s), len(s[0]["trials"]) if s else 0)'
}
viewer_saw() { [[ $(seen viewer) == "1 8" ]]; }
wait_until 10 viewer_saw || fail "the viewer's dashboard shows (studies, trials) $(seen viewer), not 1 study of 8 trials"
[[ $(seen nobody) == "0 0" ]] || fail "a dashboard without a certificate read the secure domain: $(seen nobody)"
echo "PASS dashboard in chromium: mid-study ${page[1]} completed, live to ${page[7]} (= status --json) over $((page[8] - page[2])) updates, ${page[6]}; screenshot $ARTIFACTS/dashboard-during-study.png; under DDS-Security the viewer reads 8 of 8 trials, no certificate none"
