# Helpers shared by the service benchmarks (sourced): fake-rollout workers on a private domain.
# The caller defines $bin (build/bin), $work (a scratch folder) and the array pids (killed at exit).

start_fake_workers() {  # start_fake_workers DOMAIN COUNT SLOTS DELAY_MS: workers w1..wCOUNT; sets WORKER_PIDS
  local domain=$1 count=$2 slots=$3 delay=$4 i
  WORKER_PIDS=()
  for i in $(seq "$count"); do
    "$bin/cpgmatch-sim-worker" --domain "$domain" --id "w$i" --slots "$slots" --fake-rollout-ms "$delay" \
      --localhost-only --log-level warn 2>>"$work/workers.log" &
    WORKER_PIDS+=($!); pids+=($!)
  done
}

wait_for_workers() {  # wait_for_workers DOMAIN COUNT: until COUNT workers have announced themselves
  local domain=$1 count=$2
  until [[ $("$bin/cpgmatch" workers --json --domain "$domain" --localhost-only --timeout 5 |
             python3 -c 'import json,sys; print(len(json.load(sys.stdin)))') -ge $count ]]; do
    sleep 0.2
  done
}
