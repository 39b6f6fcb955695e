#!/usr/bin/env bash
# The Slurm batch script deploy/slurm/sim-workers.sbatch, run as Slurm would run it on a 2-node allocation,
# with a stand-in `srun` (there is no Slurm here): srun starts one copy of the task per node with the
# node's SLURM_PROCID, and Slurm's SIGTERM before the time limit goes to the step, i.e. to every task. Checks that the
# script's workers, clients of a Fast DDS discovery server (cluster profile, no multicast), join an optimizer
# under the ids slurm-<job>-<rank>, run a study with the slots the allocation gives them, and all leave on
# SIGTERM with exit 0 (they hand their queue back, so nothing waits for a lease).
source "$(dirname "$0")/../integration/lib.sh"
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
JOB_PGID=
kill_job() { [[ -n $JOB_PGID ]] && kill -9 -- "-$JOB_PGID" 2>/dev/null || true; }
trap 'kill_job; cleanup' EXIT

# srun stand-in: drops srun's own options, runs the task SLURM_NNODES times (SLURM_PROCID = rank), passes
# SIGTERM on to every task and exits with the first failing task's status, as srun does.
mkdir -p "$WORK/slurm-bin"
cat >"$WORK/slurm-bin/srun" <<'SRUN'
#!/usr/bin/env bash
while [[ $1 == --* ]]; do shift; done
pids=()
for ((rank = 0; rank < ${SLURM_NNODES:-1}; ++rank)); do
  SLURM_PROCID=$rank "$@" &
  pids+=($!)
done
trap 'kill -TERM "${pids[@]}" 2>/dev/null' TERM
status=0
for pid in "${pids[@]}"; do
  while true; do
    wait "$pid"; rc=$?
    kill -0 "$pid" 2>/dev/null || break  # a trap interrupted the wait: the task is still running
  done
  ((status == 0)) && status=$rc
done
exit "$status"
SRUN
chmod +x "$WORK/slurm-bin/srun"

start_discovery_server
CLUSTER=(--dds-profile cluster --discovery-server "127.0.0.1:$DS_PORT")
"$BIN/cpgmatch-optimizer" --domain "$DOMAIN" --store "$WORK/s.db" "${CLUSTER[@]}" >>"$WORK/optimizer.log" 2>&1 &
PIDS+=($!)

# The batch script in its own process group, as a job is: the group is what Slurm signals.
setsid env PATH="$WORK/slurm-bin:$PATH" SLURM_JOB_ID=4242 SLURM_NNODES=2 SLURM_CPUS_PER_TASK=2 \
  CPGMATCH_DISCOVERY="127.0.0.1:$DS_PORT" CPGMATCH_DOMAIN="$DOMAIN" CPGMATCH_WORKER="$BIN/cpgmatch-sim-worker" \
  bash "$ROOT/deploy/slurm/sim-workers.sbatch" >"$WORK/job.log" 2>&1 &
JOB_PID=$!
JOB_PGID=$JOB_PID

# Both tasks must have joined before the study starts, or the first could take every rollout.
joined() { grep -q "worker slurm-4242-$1 joined: 2 slots" "$WORK/optimizer.log"; }
wait_until 30 joined 0 && wait_until 30 joined 1 || fail "the job's workers did not both join the optimizer with the allocation's 2 slots"
write_study "$WORK/s.yaml" slurm 8 8
out=$("$BIN/cpgmatch" study submit --config "$WORK/s.yaml" --wait --json --quiet --timeout 90 --domain "$DOMAIN" \
      "${CLUSTER[@]}" 2>>"$WORK/cli.log") || fail "submit --wait failed: $out"
[[ $(json_field "$out" completed) == 8 ]] || fail "the study did not complete its 8 rollouts: $out"
ids=$(sql "$WORK/s.db" "select group_concat(distinct worker_id) from (select worker_id from trials where status='done' order by worker_id)")
[[ $ids == "slurm-4242-0,slurm-4242-1" ]] || fail "rollouts ran on '$ids', expected both slurm-4242-0 and slurm-4242-1"

# Slurm's SIGTERM before the time limit (--signal=TERM@120, no "B:") goes to the job's steps, not to the batch
# shell: srun passes it on to its tasks. The job must then end cleanly and soon.
srun_pid=$(pgrep -g "$JOB_PGID" -f "$WORK/slurm-bin/srun") || fail "no srun step in the job"
kill -TERM "$srun_pid"
job_gone() { ! kill -0 "$JOB_PID" 2>/dev/null; }
wait_until 20 job_gone || fail "the job was still running 20 s after SIGTERM"
set +e; wait "$JOB_PID"; rc=$?; set -e
[[ $rc == 0 ]] || fail "the batch script exited $rc after SIGTERM (its workers must leave cleanly)"
pgrep -g "$JOB_PGID" >/dev/null && fail "processes of the job outlived it: $(pgrep -a -g "$JOB_PGID")"
JOB_PGID=
echo "PASS slurm script: 2 tasks of job 4242 (stand-in srun) joined through a discovery server as slurm-4242-0/1" \
     "with 2 slots each, ran an 8-rollout study, and left with exit 0 on SIGTERM"
