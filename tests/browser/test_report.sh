#!/usr/bin/env bash
# report.html opens offline in a real browser and shows every figure: `cpgmatch study run` (a tiny real study,
# physics rollouts) leaves report.html in its results folder, and `cpgmatch report --store` writes one of the
# same store elsewhere. Each is opened in headless Chromium from a folder of its own (so nothing beside it can
# help) with every other host unreachable: every <img> decoded (naturalWidth > 0), nothing loaded but the file.
# A screenshot is kept in $ARTIFACTS.
source "$(dirname "$0")/lib.sh"
cat >"$WORK/tiny.yaml" <<YAML
name: report-tiny
budget: 4
initial_points: 3
seed: 5
rollout: {entrain_s: 0.5, eval_s: 0.5}
YAML
"$BIN/cpgmatch" study run --config "$WORK/tiny.yaml" --workers 1 --jitter 0 --quiet --insecure --domain "$DOMAIN" \
  --out "$WORK/run" >"$WORK/run.out" 2>"$WORK/run.log" || fail "study run: $(tail -n 5 "$WORK/run.log")"
[[ -s $WORK/run/report.html ]] || fail "study run left no report.html in its results folder"
"$BIN/cpgmatch" report --store "$WORK/run/study.db" --out "$WORK/report" --jitter 0 --quiet >"$WORK/report.out" \
  2>"$WORK/report.log" || fail "report: $(cat "$WORK/report.log")"
[[ $(cat "$WORK/report.out") == "$WORK/report/report.html" ]] || fail "report printed $(cat "$WORK/report.out")"
set +e
"$BIN/cpgmatch" report --store "$WORK/none.db" --out "$WORK/x" 2>"$WORK/bad.err"; code=$?
set -e
[[ $code -eq 2 ]] && grep -q -- "--store" "$WORK/bad.err" || fail "a missing store: exit $code, $(cat "$WORK/bad.err")"

check_report() {  # check_report HTML NAME: opened alone, every figure shown, nothing loaded from elsewhere
  local alone=$WORK/alone-$2
  mkdir -p "$alone" && cp "$1" "$alone/report.html"
  browser "file://$alone/report.html" --wait "document.readyState === 'complete'" \
    --eval "document.images.length" \
    --eval "[...document.images].filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt)" \
    --eval "performance.getEntriesByType('resource').map(e => e.name).filter(n => !n.startsWith('data:'))" \
    --eval "document.querySelector('#gait table') !== null" \
    --eval "document.querySelector('#science pre').textContent.includes('paper')" \
    --screenshot "$ARTIFACTS/report-$2.png" >"$WORK/$2.jsonl"
  mapfile -t r <"$WORK/$2.jsonl"
  # fig5a, fig5b, fig6, fig6_cot, fig4, param_slices, param_importance, param_parallel: 8, unless one says why not.
  local drawn=$(ls "$(dirname "$1")"/*.png | wc -l)
  ((r[0] >= 6 && r[0] == drawn)) || fail "$2: ${r[0]} figures in the page, $drawn PNGs drawn"
  [[ ${r[1]} == '[]' ]] || fail "$2: figures not shown offline: ${r[1]}"
  [[ ${r[2]} == '[]' ]] || fail "$2: the page loaded more than itself: ${r[2]}"
  [[ ${r[3]} == true && ${r[4]} == true ]] || fail "$2: no gait table or no science table"
  echo "$2: ${r[0]} figures shown offline"
}
check_report "$WORK/run/report.html" study-run
check_report "$WORK/report/report.html" report
echo "PASS report.html: written by study run and by report, opens offline with every figure; screenshot $ARTIFACTS/report-report.png"
