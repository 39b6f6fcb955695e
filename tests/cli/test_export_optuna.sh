#!/usr/bin/env bash
# `cpgmatch export` of a real small study (`study run`, 8 rollouts): the CSV and JSON have one row per
# stored trial, and the Optuna journal loads with Debian's python3-optuna (JournalStorage over
# JournalFileStorage) with the store's trial count and best cost, and optuna.visualization draws from it.
# Skips (exit 77) when python3-optuna is not installed (deploy/install-deps.sh installs it).
#   test_export_optuna.sh PATH/TO/cpgmatch
set -euo pipefail
bin=${1:?usage: test_export_optuna.sh PATH/TO/cpgmatch}
# Debian's interpreter first: a python3 earlier on PATH (pyenv, a venv) does not see python3-optuna.
py=""
for candidate in /usr/bin/python3 python3; do
  if "$candidate" -c 'import optuna, plotly' 2>/dev/null; then py=$candidate; break; fi
done
[[ -n $py ]] || { echo "SKIP: python3-optuna and python3-plotly are not installed (apt install python3-optuna python3-plotly)"; exit 77; }
work=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-export.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

printf 'name: export-me\nbudget: 8\ninitial_points: 5\nseed: 4\nrollout: {entrain_s: 1.0, eval_s: 1.0}\n' >"$work/s.yaml"
"$bin" study run --config "$work/s.yaml" --workers 2 --out "$work/run" --quiet --jitter 0 >"$work/run.out" 2>"$work/run.err" ||
  { cat "$work/run.err"; fail "study run"; }
store=$work/run/study.db
trials=$(sqlite3 "$store" "SELECT count(*) FROM trials")
[[ $trials -eq 8 ]] || fail "the study stored $trials trials, expected 8"

"$bin" export --store "$store" --format csv --out "$work/t.csv" 2>"$work/export.err" || { cat "$work/export.err"; fail "export csv"; }
rows=$(($(wc -l <"$work/t.csv") - 1))
[[ $rows -eq $trials ]] || fail "csv has $rows rows for $trials trials"
"$bin" export --store "$store" --study 1 --format json >"$work/t.json"
"$bin" export --store "$store" --format optuna-journal --out "$work/t.journal" 2>>"$work/export.err"

"$py" - "$work/t.journal" "$work/t.json" "$store" <<'PY'
import json, sqlite3, sys, warnings
warnings.filterwarnings("ignore")  # JournalStorage is "experimental" in Optuna 3.1
import optuna
import optuna.visualization as vis
optuna.logging.set_verbosity(optuna.logging.WARNING)
journal, exported_json, store = sys.argv[1:4]
db = sqlite3.connect(store)
count, = db.execute("SELECT count(*) FROM trials WHERE study_id = 1").fetchone()
best, = db.execute("SELECT min(cost) FROM trials WHERE study_id = 1 AND status = 'done' AND ok = 1").fetchone()
ran, = db.execute("SELECT count(*) FROM trials WHERE study_id = 1 AND status = 'done' AND ok = 1").fetchone()
storage = optuna.storages.JournalStorage(optuna.storages.JournalFileStorage(journal))
study = optuna.load_study(study_name="export-me", storage=storage)
assert len(study.trials) == count, (len(study.trials), count)
assert study.best_value == best, (study.best_value, best)
complete = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
assert len(complete) == ran, (len(complete), ran)
assert set(study.best_params) == {"hip_offset", "hip_amplitude", "duty_factor_front", "duty_factor_hind",
                                  "knee_phase_shift", "overswing"}, study.best_params
assert study.best_trial.user_attrs["rollout"] == study.best_trial.number + 1
assert study.user_attrs["cpgmatch_study_id"] == 1
# Optuna's own plots draw every completed trial.
history = vis.plot_optimization_history(study)
assert len(history.data[0].x) == ran, (len(history.data[0].x), ran)
slices = vis.plot_slice(study)
assert len(slices.data) == 6 and all(len(d.x) == ran for d in slices.data), [len(d.x) for d in slices.data]
parallel = vis.plot_parallel_coordinate(study)
assert len(parallel.data[0].dimensions) == 7, len(parallel.data[0].dimensions)  # the objective and 6 parameters
assert len(vis.plot_edf(study).data) == 1
j = json.load(open(exported_json))
assert len(j["studies"]) == 1 and len(j["studies"][0]["trials"]) == count
print(f"optuna {optuna.__version__}: {len(study.trials)} trials, best value {study.best_value} (store: {count}, {best})")
PY
echo "PASS export: $trials trials as csv ($rows rows), json and an Optuna journal"
