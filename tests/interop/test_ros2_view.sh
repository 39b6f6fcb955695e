#!/usr/bin/env bash
# The ROS 2 view, seen as ROS 2 sees it (Debian has no ROS 2): a Cyclone DDS reader built from the IDL of the
# cpgmatch_msgs .msg files, as rmw_cyclonedds would, reads the state of a running study from
# rt/cpgmatch/study_state, one of its trials from rt/cpgmatch/trials and its worker from rt/cpgmatch/workers,
# under rosidl's type names. The services
# find their domain in $ROS_DOMAIN_ID (no --domain), as ROS 2 nodes do; a bad $ROS_DOMAIN_ID is refused by name;
# --no-ros2-view publishes nothing there; a study resumed by a restarted optimizer is on the view again.
source "$(dirname "$0")/../integration/lib.sh"
READER=${READER:?READER must point at ros2_state_reader}
# UDP only on the Fast DDS side (Cyclone cannot use Fast DDS's shared memory).
export FASTRTPS_DEFAULT_PROFILES_FILE="$(cd "$(dirname "$0")/../.." && pwd)/deploy/fastdds/udp-only.xml"
unset CPGMATCH_DOMAIN

# A bad ROS_DOMAIN_ID: exit 2, the variable named.
set +e
out=$(ROS_DOMAIN_ID=eleven "$BIN/cpgmatch-optimizer" --store "$WORK/bad.db" 2>&1); rc=$?
set -e
[[ $rc == 2 && $out == *"ROS_DOMAIN_ID: 'eleven' is not a domain id"* ]] || fail "bad ROS_DOMAIN_ID: exit $rc: $out"

export ROS_DOMAIN_ID=$DOMAIN
write_study "$WORK/s.yaml" ros2view 200 200
"$BIN/cpgmatch-optimizer" --store "$WORK/s.db" >>"$WORK/optimizer.log" 2>&1 &
PIDS+=($!)
OPT=$!
# One slot, 250 ms a rollout: the study is still running while the reader looks.
"$BIN/cpgmatch-sim-worker" --id rw --slots 1 --fake-rollout-ms 250 >>"$WORK/worker.log" 2>&1 &
PIDS+=($!)
"$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --quiet --timeout 20 >/dev/null 2>>"$WORK/cli.log" ||
  fail "submit failed"
out=$("$READER" "$DOMAIN" 1 3 30) || fail "the ROS 2-style Cyclone reader got no state or trial: $out"
state=$(sed -n 1p <<<"$out")
trial=$(sed -n 2p <<<"$out")
worker=$(sed -n 3p <<<"$out")
[[ $state == "state study 1 status 0 completed "* ]] || fail "not the state of a running study: $state"
[[ $state == *" budget 200 name ros2view type cpgmatch_msgs::msg::dds_::StudyState_" ]] || fail "state: $state"
[[ $trial == "trial study 1 trial "*" outcome 0 cost "*" type cpgmatch_msgs::msg::dds_::TrialRecord_" ]] ||
  fail "trial: $trial"
[[ $worker == "worker rw kind 0 slots 1 alive 1 type cpgmatch_msgs::msg::dds_::Worker_" ]] || fail "worker: $worker"

# --no-ros2-view: the same running study, nothing on rt/ (the reader gives up after 4 s).
kill -TERM "$OPT"; wait "$OPT" 2>/dev/null || true
"$BIN/cpgmatch-optimizer" --store "$WORK/s.db" --no-ros2-view >>"$WORK/optimizer-noview.log" 2>&1 &
PIDS+=($!)
OPT=$!
if quiet=$("$READER" "$DOMAIN" 1 0 4 2>&1); then fail "--no-ros2-view still published: $quiet"; fi

# Restarted with the view: the resumed study is on it again, with the trials run before the restart.
kill -TERM "$OPT"; wait "$OPT" 2>/dev/null || true
"$BIN/cpgmatch-optimizer" --store "$WORK/s.db" >>"$WORK/optimizer-again.log" 2>&1 &
PIDS+=($!)
again=$("$READER" "$DOMAIN" 1 3 20) || fail "the resumed study is not on the view: $again"
[[ $(sed -n 1p <<<"$again") == "state study 1 status 0 completed "* ]] || fail "resumed: $again"
# The oldest trial in the history, run before the restarts: the resumed study's trials were published again.
[[ $(sed -n 2p <<<"$again") == "trial study 1 trial 0 "* ]] || fail "resumed, the first trial is not trial 0: $again"
echo "PASS a ROS 2-style Cyclone DDS reader reads the running study under rosidl's names: $state; $trial; $worker;" \
  "--no-ros2-view publishes nothing; a resumed study is on the view again"
