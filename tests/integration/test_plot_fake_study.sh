#!/usr/bin/env bash
# `cpgmatch plot --store` never fails on a valid study: a study of fake rollouts (a smooth synthetic cost,
# no torque, every cost term zero) through the real service gives no positive torque for fig6's log axis
# and no term for fig5b's; plot exits 0, draws every figure it can and says on stderr what it left out.
# The export of the same store has one CSV row per trial.
source "$(dirname "$0")/lib.sh"
write_study "$WORK/s.yaml" fake-plot 10 4
start_optimizer "$WORK/s.db"
start_worker w --slots 2 --fake-rollout-ms 20
id=$(cli study submit --config "$WORK/s.yaml" --timeout 20) || fail "submit failed"
wait_until 60 study_is "$id" done || fail "the study did not finish: $(state_json "$id")"

"$BIN/cpgmatch" plot --store "$WORK/s.db" --study "$id" --out "$WORK/figs" >"$WORK/plot.out" 2>"$WORK/plot.err" ||
  fail "plot exited $?: $(cat "$WORK/plot.err")"
grep -q "not drawn: fig6: none of the 10 rollouts that walked has a positive normalised torque" "$WORK/plot.err" ||
  fail "plot did not say why fig6 has no torque: $(cat "$WORK/plot.err")"
grep -q "not drawn: fig5b: no cost term is at or above" "$WORK/plot.err" || fail "plot did not say fig5b's log panel is empty"
for stem in fig5a fig5b fig6 param_slices param_importance param_parallel; do
  [[ -s $WORK/figs/$stem.png && -s $WORK/figs/$stem.svg ]] || fail "$stem was not drawn"
  grep -q "$WORK/figs/$stem.png" "$WORK/plot.out" || fail "plot did not list $stem.png"
done
! grep -q "figure failed" "$WORK/plot.err" || fail "a figure failed: $(cat "$WORK/plot.err")"

"$BIN/cpgmatch" export --store "$WORK/s.db" --format csv --out "$WORK/t.csv" 2>/dev/null || fail "export exited $?"
rows=$(($(wc -l <"$WORK/t.csv") - 1))
trials=$(sql "$WORK/s.db" "SELECT count(*) FROM trials WHERE study_id = $id")
[[ $rows -eq $trials && $trials -eq 10 ]] || fail "export: $rows csv rows for $trials trials"
echo "PASS plot of a fake study: 6 figures, fig6 and fig5b said what they could not draw; export: $rows rows"
