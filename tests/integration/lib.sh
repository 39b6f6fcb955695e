# Helpers for the process-level integration tests: real executables, real DDS on loopback/shared
# memory, one domain per test (passed by ctest) so that parallel tests never meet.
set -euo pipefail

BIN=${BIN:?BIN must point at build/bin}
DOMAIN=${DOMAIN:?DOMAIN must be set}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/cpgmatch-it.XXXXXX")
PIDS=()

cleanup() {
  local pid
  for pid in "${PIDS[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  if [[ ${KEEP_WORK:-0} == 1 ]]; then echo "work dir kept: $WORK"; else rm -rf "$WORK"; fi
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  for f in "$WORK"/*.log; do [[ -f $f ]] && { echo "--- $f" >&2; tail -n 30 "$f" >&2; }; done
  exit 1
}

start_optimizer() {  # start_optimizer STORE [extra args]; sets OPT_PID
  local store=$1; shift
  "$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$store" --localhost-only "$@" >>"$WORK/optimizer.log" 2>&1 &
  OPT_PID=$!
  PIDS+=("$OPT_PID")
}

start_worker() {  # start_worker ID [extra args]; sets WORKER_PID
  local id=$1; shift
  "$BIN/cpgmatch-sim-worker" --domain "$DOMAIN" --id "$id" --localhost-only "$@" >>"$WORK/worker-$id.log" 2>&1 &
  WORKER_PID=$!
  PIDS+=("$WORKER_PID")
}

cli() { "$BIN/cpgmatch" "$@" --domain "$DOMAIN" --localhost-only 2>>"$WORK/cli.log"; }

state_json() {  # state_json STUDY_ID
  cli status --study "$1" --json --timeout 5 2>/dev/null || echo '{}'
}

json_field() {  # json_field JSON FIELD
  python3 -c 'import json,sys; v=json.loads(sys.argv[1]).get(sys.argv[2]); print("" if v is None else v)' "$1" "$2"
}

wait_until() {  # wait_until TIMEOUT_S COMMAND...: polls until the command succeeds
  local timeout=$1; shift
  local deadline=$((SECONDS + timeout))
  until "$@"; do
    ((SECONDS < deadline)) || return 1
    sleep 0.2
  done
}

completed_at_least() { [[ $(json_field "$(state_json "$1")" completed) -ge $2 ]] 2>/dev/null; }
study_is() { [[ $(json_field "$(state_json "$1")" state) == "$2" ]]; }

write_study() {  # write_study FILE NAME BUDGET [INITIAL]
  cat >"$1" <<YAML
name: $2
budget: $3
initial_points: ${4:-$3}
seed: 3
rollout: {entrain_s: 0.5, eval_s: 0.5}
YAML
}

sql() { sqlite3 "$1" "$2"; }

free_udp_port() {
  python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# Starts a Fast DDS discovery server on 127.0.0.1; sets DS_PORT and DS_PID. The server binary itself
# (fastdds-tools), not the `fastdds discovery` wrapper: the wrapper runs it as a child, which the cleanup's
# SIGKILL of the wrapper would leave running. A free port is only free when it was probed: under a parallel
# ctest another process may take it before the server binds it (one run of 7 timed out after 60 s), so the
# server must be seen holding its port before anyone uses it.
server_holds_port() { ss -Hulpn "sport = :$DS_PORT" 2>/dev/null | grep -q "pid=$DS_PID,"; }
# start_discovery_server [ID]: server id ID (default 0), which is its position in a client's server list.
start_discovery_server() {
  local attempt id=${1:-0} log="$WORK/discovery.log"
  ((id == 0)) || log="$WORK/discovery-$id.log"
  for attempt in 1 2 3; do
    DS_PORT=$(free_udp_port)
    fast-discovery-server -i "$id" -l 127.0.0.1 -p "$DS_PORT" >"$log" 2>&1 &
    DS_PID=$!; PIDS+=("$DS_PID")
    if wait_until 5 server_holds_port; then return 0; fi
    echo "discovery server attempt $attempt: port $DS_PORT not held by it; another port" >&2
    kill "$DS_PID" 2>/dev/null || true
  done
  fail "the discovery server never held its port: $(cat "$log")"
}
