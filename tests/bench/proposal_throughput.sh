#!/usr/bin/env bash
# Benchmark (run by hand, not in ctest): how many GP proposals the optimizer service makes per second,
# and how promptly its event loop serves samples meanwhile. Rollouts are fake (a fixed delay,
# cpgmatch-sim-worker --fake-rollout-ms), so the numbers are the service's: GP fits, acquisition
# optimisation, store and DDS. Every study is the paper's shape: budget 150, 15 random points, then GP
# proposals (gp_hedge) up to 150 observations.
#
# Each row: STUDIES studies submitted at once to WORKERS workers x SLOTS slots of DELAY_MS rollouts,
# optimizer with THREADS model threads.
#   results/s     every counted result / (last report - first issue), from the store
#   GP props/s    proposals issued after the study's first report / the time they took (per study, summed
#                 over studies that overlap; for one study: its steady state once the model is in use)
#   bound         slots / rollout time: what a service with free proposals would reach
#   loop p50/p99/max   sample arrival (DDS listener) to handled, over the run (the optimizer's own count)
#   tick p99      duration of the event loop's tick (issuing, timers, applying model results)
#   opt RSS MB    the optimizer's resident memory at the end
#   opt CPU ms/result   the optimizer process's CPU time (user + system, /proc) per result: what the
#                 service costs, much less sensitive than the rates to what else runs on the machine
#   workers CPU ms/result   the same for all the fake workers together: DDS only (their rollouts sleep)
#
# Usage: [OPTIMIZER_FLAGS=...] [BENCH_DOMAIN=70] tests/bench/proposal_throughput.sh [build-dir] [ROWS...]
#   a row is STUDIES:WORKERS:SLOTS:DELAY_MS:THREADS; default rows: the targets and a growth table.
# Targets (issue 9): one study, 64 slots of 0.4 s: >= 160 proposals/s; 20 studies: >= 200 results/s;
# loop p99 <= 20 ms.
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; shift || true
bin="$build/bin"
rows=("$@")
if ((${#rows[@]} == 0)); then
  rows=(1:1:64:400:1 1:1:64:400:2 20:8:16:400:1 20:8:16:400:2
        5:2:16:400:2 5:4:16:400:2 20:4:16:400:2 20:16:16:400:2)
fi
work=$(mktemp -d /tmp/cpgmatch-bench.XXXXXX)
domain=${BENCH_DOMAIN:-70}
row_number=0
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
source "$(dirname "$0")/lib.sh"

run_row() {  # run_row STUDIES WORKERS SLOTS DELAY_MS THREADS
  local studies=$1 workers=$2 slots=$3 delay=$4 threads=$5
  ((++row_number))
  # The row number keeps a repeated row (e.g. 20:8:16:400:2 twice) off the store and study files of the first.
  local tag="r${row_number}s${studies}w${workers}x${slots}d${delay}t${threads}"
  local store="$work/$tag.db" log="$work/$tag.opt.log"
  ((++domain))
  "$bin/cpgmatch-optimizer" --domain "$domain" --store "$store" --localhost-only --model-threads "$threads" \
    --log-level info ${OPTIMIZER_FLAGS:-} 2>"$log" &
  local opt=$!; pids+=("$opt")
  start_fake_workers "$domain" "$workers" "$slots" "$delay"
  local ws=("${WORKER_PIDS[@]}")
  wait_for_workers "$domain" "$workers"
  local submits=()
  for k in $(seq "$studies"); do
    printf 'name: bench-%d\nbudget: 150\ninitial_points: 15\nseed: %d\nrollout: {entrain_s: 0.2, eval_s: 0.2}\n' \
      "$k" "$k" >"$work/$tag-$k.yaml"
    "$bin/cpgmatch" study submit --config "$work/$tag-$k.yaml" --domain "$domain" --localhost-only --timeout 20 >/dev/null &
    submits+=($!)
  done
  wait "${submits[@]}"
  local total=$((studies * 150))
  until [[ $(sqlite3 "$store" "select count(*) from trials where status = 'done'" 2>/dev/null || echo 0) -ge $total ]]; do
    sleep 0.5
  done
  local stat cpu rss
  rss=$(awk '/^VmRSS/ { printf "%.0f", $2 / 1024 }' "/proc/$opt/status")
  stat=$(cut -d' ' -f14,15 "/proc/$opt/stat")  # utime stime, in clock ticks
  cpu=$(awk -v t="$(getconf CLK_TCK)" '{ printf "%.2f", ($1 + $2) / t }' <<<"$stat")
  local wcpu=0 w
  for w in "${ws[@]}"; do
    wcpu=$(awk -v t="$(getconf CLK_TCK)" -v acc="$wcpu" '{ printf "%.2f", acc + ($14 + $15) / t }' "/proc/$w/stat")
  done
  kill "${ws[@]}"; wait "${ws[@]}" 2>/dev/null || true
  kill "$opt"; wait "$opt" 2>/dev/null || true
  local loop tick
  loop=$(grep -o 'sample arrival to handled: n [0-9]*, p50 [0-9.]* ms, p99 [0-9.]* ms, max [0-9.]* ms' "$log" | tail -1 |
         sed -E 's/.*p50 ([0-9.]+) ms, p99 ([0-9.]+) ms, max ([0-9.]+) ms/\1 \2 \3/')
  tick=$(grep -o 'tick: n [0-9]*, p50 [0-9.]* ms, p99 [0-9.]* ms' "$log" | tail -1 | sed -E 's/.*p99 ([0-9.]+) ms/\1/')
  # Where the loop latency goes (queue wait, chunk handling, commit, publish): on stderr, beside the table.
  grep -o 'event loop breakdown: .*' "$log" | tail -1 | sed "s/^/$tag: /" >&2 || true
  sqlite3 -separator ' ' "$store" "select study_id, trial_id, issued_at, reported_at from trials where status = 'done'" |
    python3 -c '
import sys, collections
studies, workers, slots, delay, threads, loop, tick, cpu, rss, wcpu = sys.argv[1:11]
rows = [l.split() for l in sys.stdin]
by = collections.defaultdict(list)
for s, t, i, r in rows: by[s].append((int(t), float(i), float(r)))
first_issue = min(float(r[2]) for r in rows); last_report = max(float(r[3]) for r in rows)
rate = len(rows) / (last_report - first_issue)
# GP phase of each study: proposals issued after its first report (the model needs results), over the
# span from that first report to its last issue.
gp_n, gp_t0, gp_t1 = 0, float("inf"), 0.0
for s, ts in by.items():
    t0 = min(r for _, _, r in ts)
    later = [i for _, i, _ in ts if i >= t0]
    gp_n += len(later); gp_t0 = min(gp_t0, t0); gp_t1 = max(gp_t1, max(later, default=t0))
gp = gp_n / (gp_t1 - gp_t0) if gp_t1 > gp_t0 else float("nan")
bound = int(workers) * int(slots) / (int(delay) / 1000)
p50, p99, mx = (loop.split() + ["?", "?", "?"])[:3]
print(f"| {studies:>7} | {workers:>2} x {slots:<3} | {int(delay)/1000:.1f} s | {threads:>7} | {len(rows):>7} | {last_report-first_issue:6.1f} | {rate:9.1f} | {gp:10.1f} | {bound:5.0f} | {p50:>8} | {p99:>8} | {mx:>8} | {tick:>8} | {rss:>6} | {1000 * float(cpu) / len(rows):7.1f} | {1000 * float(wcpu) / len(rows):7.1f} |")
' "$studies" "$workers" "$slots" "$delay" "$threads" "${loop:-? ? ?}" "${tick:-?}" "$cpu" "$rss" "$wcpu"
}

echo "| studies | workers x slots | rollout | model threads | results | wall s | results/s | GP props/s | bound | loop p50 ms | loop p99 ms | loop max ms | tick p99 ms | opt RSS MB | opt CPU ms/result | workers CPU ms/result |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for row in "${rows[@]}"; do
  IFS=: read -r s w sl d t <<<"$row"
  run_row "$s" "$w" "$sl" "$d" "$t"
done
