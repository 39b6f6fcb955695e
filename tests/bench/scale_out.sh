#!/usr/bin/env bash
# Benchmark (run by hand, not in ctest): what a fleet of worker processes on one host gets through the
# shipped `cluster` profile and a Fast DDS discovery server, started together, as a lab would start a
# cluster. Rollouts are fake (cpgmatch-sim-worker --fake-rollout-ms), so only the service is measured.
# Run it inside /work/isolated.sh (or any private network namespace): the datagram count is the
# namespace's (/proc/net/snmp), i.e. exactly this benchmark's traffic.
#
# Each row: WORKERS worker processes x SLOTS slots of DELAY_MS rollouts, STUDIES studies of BUDGET
# trials submitted at once, all processes started in the same second; KILL=1 kills -9 a tenth of the
# workers once a third of the results are in.
#   discover s      all workers started -> all listed by `cpgmatch workers` (unbounded wait: ROW_TIMEOUT)
#   results/s       counted results / (last report - first issue), from the store
#   bound           slots / rollout time: what a service with free proposals and free transport would reach
#   dgrams/result   UDP datagrams sent in the namespace from the first submit to the last result, per result
#   CPU ms/result   CPU of every benchmark process (discovery server, optimizer, workers, including the
#                   killed ones up to their death) per result; the shared machine's other load is not in it
#   opt CPU ms/result, opt RSS MB   the optimizer's
#   lost            trials of the submitted budget not done when the row ended (must be 0); a row that
#                   hits ROW_TIMEOUT (default 300 s from its start) says how far it got instead
#
# Usage: [PROFILE=cluster.xml] [INITIAL=N] [ROW_TIMEOUT=s] [BENCH_DOMAIN=100] tests/bench/scale_out.sh [build-dir] [ROWS...]
#   a row is WORKERS:SLOTS:STUDIES:BUDGET:DELAY_MS[:KILL]; INITIAL: random initial points per study
#   (default: the whole budget, so that the optimizer's GP does not pace the row; 15 is the paper's).
set -euo pipefail
build="$(cd "${1:-build}" && pwd)"; shift || true
bin="$build/bin"
rows=("$@")
((${#rows[@]} > 0)) || rows=(10:100:5:300:5000 80:12:5:300:5000)
profile=${PROFILE:-"$(cd "$(dirname "$0")/../.." && pwd)/deploy/fastdds/cluster.xml"}
work=$(mktemp -d /tmp/cpgmatch-scale.XXXXXX)
domain=${BENCH_DOMAIN:-100}
row_timeout=${ROW_TIMEOUT:-300}
tck=$(getconf CLK_TCK)
pids=()
cleanup() {
  local p
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  [[ ${KEEP_WORK:-0} == 1 ]] && echo "work dir kept: $work" >&2 || rm -rf "$work"
}
trap cleanup EXIT

udp_out() { awk '/^Udp:/ { if (h) { print $5; exit } h = 1 }' /proc/net/snmp; }
cpu_ticks() {  # cpu_ticks PID...: utime + stime of the live ones, in clock ticks
  local p sum=0
  for p in "$@"; do
    [[ -r /proc/$p/stat ]] || continue
    sum=$((sum + $(awk '{ print $14 + $15 }' "/proc/$p/stat" 2>/dev/null || echo 0)))
  done
  echo "$sum"
}
done_count() { sqlite3 "$1" "select count(*) from trials where status = 'done'" 2>/dev/null || echo 0; }
listed() { "$bin/cpgmatch" workers --json "${dds[@]}" --timeout 3 2>/dev/null |
           python3 -c 'import json,sys; print(len(json.load(sys.stdin)))' 2>/dev/null || echo 0; }

run_row() {  # run_row WORKERS SLOTS STUDIES BUDGET DELAY_MS KILL
  local workers=$1 slots=$2 studies=$3 budget=$4 delay=$5 kill_tenth=${6:-0}
  ((++domain))
  local port=$((11811 + domain)) tag="w${workers}x${slots}s${studies}b${budget}d${delay}k${kill_tenth}"
  local store="$work/$tag.db"
  dds=(--domain "$domain" --dds-profile "$profile" --discovery-server "127.0.0.1:$port")
  fast-discovery-server -i 0 -l 127.0.0.1 -p "$port" >"$work/$tag.ds.log" 2>&1 &
  local ds=$!; pids+=("$ds")
  "$bin/cpgmatch-optimizer" "${dds[@]}" --store "$store" --log-level info 2>"$work/$tag.opt.log" &
  local opt=$!; pids+=("$opt")
  local ws=() i t0 t_listed
  t0=$(date +%s.%N)
  for i in $(seq "$workers"); do
    "$bin/cpgmatch-sim-worker" "${dds[@]}" --id "w$i" --slots "$slots" --fake-rollout-ms "$delay" \
      --log-level warn 2>>"$work/$tag.workers.log" &
    ws+=($!); pids+=($!)
  done
  local deadline=$(( $(date +%s) + row_timeout )) n=0
  while (( (n = $(listed)) < workers )) && (( $(date +%s) < deadline )); do sleep 1; done
  t_listed=$(date +%s.%N)
  local discover
  discover=$(awk -v a="$t0" -v b="$t_listed" -v n="$n" -v w="$workers" \
             'BEGIN { if (n < w) printf "%d of %d", n, w; else printf "%.1f", b - a }')
  local initial=${INITIAL:-$budget} k submits=()
  local udp0 udp1; udp0=$(udp_out)
  for k in $(seq "$studies"); do
    printf 'name: scale-%d\nbudget: %d\ninitial_points: %d\nseed: %d\nrollout: {entrain_s: 0.2, eval_s: 0.2}\n' \
      "$k" "$budget" "$initial" "$k" >"$work/$tag-$k.yaml"
    "$bin/cpgmatch" study submit --config "$work/$tag-$k.yaml" "${dds[@]}" --timeout 60 >/dev/null 2>>"$work/$tag.cli.log" &
    submits+=($!)
  done
  wait "${submits[@]}" || echo "$tag: a submit failed (see $work/$tag.cli.log)" >&2
  local total=$((studies * budget)) dead_ticks=0 killed=0
  if ((kill_tenth)); then
    until (( $(done_count "$store") * 3 >= total )) || (( $(date +%s) >= deadline )); do sleep 0.2; done
    local victims=("${ws[@]:0:$(( (workers + 9) / 10 ))}")
    dead_ticks=$(cpu_ticks "${victims[@]}")
    kill -9 "${victims[@]}"; killed=${#victims[@]}
  fi
  until (( $(done_count "$store") >= total )) || (( $(date +%s) >= deadline )); do sleep 0.5; done
  udp1=$(udp_out)
  local done_n opt_ticks all_ticks rss
  done_n=$(done_count "$store")
  opt_ticks=$(cpu_ticks "$opt")
  all_ticks=$(( $(cpu_ticks "$ds" "$opt" "${ws[@]}") + dead_ticks ))
  rss=$(awk '/^VmRSS/ { printf "%.0f", $2 / 1024 }' "/proc/$opt/status")
  kill -9 "${ws[@]}" "$opt" "$ds" 2>/dev/null || true
  wait "${ws[@]}" "$opt" "$ds" 2>/dev/null || true
  sqlite3 -separator ' ' "$store" "select issued_at, reported_at from trials where status = 'done'" |
    python3 -c '
import sys
w, sl, st, b, d, kill, disc, total, done_n, dgrams, opt_t, all_t, rss, tck = sys.argv[1:15]
rows = [tuple(map(float, l.split())) for l in sys.stdin if l.strip()]
n = len(rows) or 1
wall = max(r for _, r in rows) - min(i for i, _ in rows) if rows else float("nan")
tck = float(tck)
print(f"| {w:>4} x {sl:<3} | {st:>2} x {b:<4} | {int(d)/1000:.1f} s | {kill:>4} | {disc:>8} | {wall:6.1f} | "
      f"{len(rows)/wall:8.1f} | {int(w)*int(sl)/(int(d)/1000):6.0f} | {int(dgrams)/n:7.1f} | "
      f"{1000*int(all_t)/tck/n:7.1f} | {1000*int(opt_t)/tck/n:7.1f} | {rss:>5} | "
      + (f"{0:>4} |" if int(done_n) >= int(total) else f"not finished at ROW_TIMEOUT: {done_n} of {total} done |"))
' "$workers" "$slots" "$studies" "$budget" "$delay" "$killed" "$discover" "$total" "$done_n" \
      "$((udp1 - udp0))" "$opt_ticks" "$all_ticks" "$rss" "$tck"
}

echo "| workers x slots | studies x budget | rollout | killed | discover s | wall s | results/s | bound | dgrams/result | CPU ms/result | opt CPU ms/result | opt RSS MB | lost |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for row in "${rows[@]}"; do
  IFS=: read -r w sl st b d k <<<"$row"
  run_row "$w" "$sl" "$st" "$b" "$d" "${k:-0}"
done
