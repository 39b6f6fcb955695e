#!/usr/bin/env bash
# The robot agent and the emulator take the flags every other cpgmatch program has: --version on both;
# on the agent --dds-profile local|cluster|FILE, --discovery-server, --keystore / $CPGMATCH_KEYSTORE and
# --enclave, through the same runtime helpers. Bad values exit 2 naming the flag; then two hardware-only
# studies through the emulator show the flags doing their job: one where every process finds the others
# only through a Fast DDS discovery server (the agent with the cluster profile given as a FILE), one under
# DDS-Security with the agent as its own worker identity (and a viewer identity refused).
source "$(dirname "$0")/robot_lib.sh"
AGENT="$BIN/cpgmatch-robot-agent"
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"

expect_exit() {  # expect_exit CODE TEXT COMMAND...: the command exits CODE and its stderr mentions TEXT
  local code=$1 text=$2 out rc; shift 2
  set +e; out=$(timeout 60 "$@" 2>&1 >/dev/null); rc=$?; set -e
  [[ $rc == "$code" && $out == *"$text"* ]] || fail "expected exit $code mentioning '$text' from: $* -- got $rc: $out"
}

# ---- --version -------------------------------------------------------------------------------------------
for exe in cpgmatch-robot-agent cpgmatch-robot-emulator; do
  v=$("$BIN/$exe" --version) || fail "$exe --version exited $?"
  [[ $v =~ ^$exe\ [0-9]+\.[0-9]+\.[0-9]+\ \(git\ [^\)]+\)$ ]] || fail "$exe --version: '$v'"
done

# ---- bad DDS flags: exit 2 naming the flag, before the agent joins a domain ------------------------------
A=("$AGENT" --can udp:127.0.0.1:1 --domain "$DOMAIN" --localhost-only --id flags --insecure)
expect_exit 2 "--dds-profile: 'no-such-profile' is neither local, cluster nor an XML profiles file" "${A[@]}" --dds-profile no-such-profile
expect_exit 2 "--dds-profile: the profile makes this process a client of discovery servers but names none" "${A[@]}" --dds-profile cluster
expect_exit 2 "--discovery-server: 'nowhere' is not a discovery server list" "${A[@]}" --discovery-server nowhere
expect_exit 2 "--keystore: '$WORK/no-keystore' is not a folder" "${A[@]}" --keystore "$WORK/no-keystore"
expect_exit 2 "--keystore: '$WORK/env-keystore' is not a folder" env CPGMATCH_KEYSTORE="$WORK/env-keystore" "${A[@]}"
PKI="$ROOT/deploy/make-study-pki.sh"
KS=$WORK/keystore
"$PKI" "$KS" --days 2 >"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh: $(cat "$WORK/pki.log")"
"$PKI" "$KS" morti:worker >>"$WORK/pki.log" 2>&1 || fail "make-study-pki.sh morti:worker: $(cat "$WORK/pki.log")"
expect_exit 2 "--keystore: $KS/enclaves/nobody/identity_ca.cert.pem is missing" "${A[@]}" --keystore "$KS" --enclave nobody
expect_exit 2 "--enclave: '../morti' is not an enclave name" "${A[@]}" --keystore "$KS" --enclave ../morti
# Secure by default: no keystore, no start (exit 2 naming --keystore and --insecure), before the bus opens.
SECURE_ONLY=("$AGENT" --can udp:127.0.0.1:1 --domain "$DOMAIN" --localhost-only --id flags)
expect_exit 2 "--keystore: a robot agent needs DDS-Security" "${SECURE_ONLY[@]}"
expect_exit 2 "Pass --insecure to run" "${SECURE_ONLY[@]}"
# --run-once uses no DDS: its flags are not needed there, and the bus is the only thing it opens.
expect_exit 2 "unknown scheme 'tcp'" "$AGENT" --can tcp:1.2.3.4:5 --run-once --dds-profile no-such-profile

relaxed_robot_yaml "$WORK/robot.yaml"
PORT=$(free_udp_port)
start_emulator "udp:127.0.0.1:$PORT" --lockstep
write_study "$WORK/s.yaml" agent-flags 2 2
echo "explore_on: hardware" >>"$WORK/s.yaml"  # the agent is the only worker
start_agent() {  # start_agent ID [flags]; sets AGENT_PID
  local id=$1; shift
  "$AGENT" --domain "$DOMAIN" --id "$id" --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --no-realtime "$@" \
    >>"$WORK/agent-$id.log" 2>&1 &
  AGENT_PID=$!; PIDS+=("$AGENT_PID")
}
stop_agent() { kill -TERM "$AGENT_PID"; wait "$AGENT_PID" || fail "agent exited $? after SIGTERM"; }
hardware_reports_from() {  # hardware_reports_from STORE ID
  sql "$1" "select count(*) from trials where status='done' and worker_id='$2' and json_extract(report_json,'$.worker_kind')='hardware' and json_extract(report_json,'$.ok')"
}

# ---- cluster: discovery through a Fast DDS discovery server only ------------------------------------------
# No --localhost-only anywhere: the cluster profile is a discovery-server client with multicast off, so the
# processes can only meet through the server.
start_discovery_server
CLUSTER=(--dds-profile cluster --discovery-server "127.0.0.1:$DS_PORT")
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/cluster.db" "${CLUSTER[@]}" >>"$WORK/optimizer-cluster.log" 2>&1 &
OPT_PID=$!; PIDS+=("$OPT_PID")
start_agent morti-cluster --insecure --dds-profile "$ROOT/deploy/fastdds/cluster.xml" --discovery-server "127.0.0.1:$DS_PORT"
out=$("$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 60 --domain "$DOMAIN" "${CLUSTER[@]}" \
      2>>"$WORK/cli.log") || fail "cluster study: submit --wait failed: $out"
[[ $(json_field "$out" completed) == 2 ]] || fail "cluster study: $out"
n=$(hardware_reports_from "$WORK/cluster.db" morti-cluster)
[[ $n == 2 ]] || fail "cluster study: expected 2 ok hardware reports from morti-cluster, got $n"
grep -q "Participant Type:   SERVER" "$WORK/discovery.log" || fail "the discovery server did not start: $(cat "$WORK/discovery.log")"
grep -q "INSECURE: no DDS-Security (--insecure)" "$WORK/agent-morti-cluster.log" || fail "--insecure is not said aloud"
stop_agent
kill -TERM "$OPT_PID" "$DS_PID"; wait "$OPT_PID" "$DS_PID" || true

# ---- DDS-Security: the agent as the keystore's worker identity 'morti' -----------------------------------
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/secure.db" --localhost-only --keystore "$KS" \
  >>"$WORK/optimizer-secure.log" 2>&1 &
OPT_PID=$!; PIDS+=("$OPT_PID")
# A viewer identity may not write reports: the agent cannot join as one (exit 1, naming the topic).
expect_exit 1 "cannot create a writer on cpgmatch/reports" "$AGENT" --domain "$DOMAIN" --localhost-only --id viewer \
  --can "udp:127.0.0.1:$PORT" --robot "$WORK/robot.yaml" --no-realtime --keystore "$KS" --enclave viewer
# The keystore from the environment, the enclave from the flag.
CPGMATCH_KEYSTORE=$KS start_agent morti --localhost-only --enclave morti
out=$("$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 60 --domain "$DOMAIN" \
      --localhost-only --keystore "$KS" 2>>"$WORK/cli.log") || fail "secure study: submit --wait failed: $out"
[[ $(json_field "$out" completed) == 2 ]] || fail "secure study: $out"
n=$(hardware_reports_from "$WORK/secure.db" morti)
[[ $n == 2 ]] || fail "secure study: expected 2 ok hardware reports from morti, got $n"
# Emergency stops under DDS-Security: the operator identity may send them and the agent (a worker) hears
# them; a viewer may not create the writer.
ESTOP=("$BIN/cpgmatch" estop --robot morti --domain "$DOMAIN" --localhost-only --keystore "$KS" --timeout 20)
"${ESTOP[@]}" --reason "secure stop" >>"$WORK/cli.log" 2>&1 || fail "secure estop by the operator failed"
wait_until 10 grep -q "EMERGENCY STOP .*secure stop" "$WORK/agent-morti.log" || fail "the secure agent did not hear the stop"
"${ESTOP[@]}" --release >>"$WORK/cli.log" 2>&1 || fail "secure release by the operator failed"
wait_until 10 grep -q "accepting candidates again" "$WORK/agent-morti.log" || fail "the secure agent did not hear the release"
expect_exit 1 "cannot create a writer on cpgmatch/estop" "$BIN/cpgmatch" estop --robot morti --domain "$DOMAIN" \
  --localhost-only --keystore "$KS" --enclave viewer --timeout 3
stop_agent
echo "PASS agent and emulator flags: --version; bad --dds-profile, --discovery-server, --keystore, \$CPGMATCH_KEYSTORE," \
     "--enclave exit 2 naming them; a hardware study over a discovery server (cluster profile, FILE form on the" \
     "agent) and one under DDS-Security (agent enclave morti; a viewer identity refused; estop and release by the" \
     "operator heard, a viewer may not send one)"
