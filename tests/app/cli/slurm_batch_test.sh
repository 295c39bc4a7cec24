#!/usr/bin/env bash
# docs/batch.md's Slurm job-array recipe, run as written there (issue #14 item 6), on a single-node Slurm
# that this test starts for itself: a private munge key and munged socket, slurmctld and slurmd on loopback
# ports with a generated slurm.conf, everything in one temporary folder. 8 small simulated sessions, one with
# a truncated frame, in 4 array tasks: 7 solved and the damaged one failed naming the frame; then the same
# submission again skips the 7 (inputs fingerprint) and fails the damaged one again.
#
# Usage: slurm_batch_test.sh SCANBENCH_BINARY DOCS_BATCH_MD
# Exit code: 0 passed, 1 failed, 77 skipped (Slurm cannot run here; the reason is printed). The daemons
# are stopped on every way out.
set -uo pipefail

if [ $# -ne 2 ]; then
  echo "usage: $0 SCANBENCH_BINARY DOCS_BATCH_MD" >&2
  exit 1
fi
scanbench_binary=$1
batch_md=$2
node=scanbench-node
shards=4         # the recipe's --array=1-4
damaged=s6       # sorted position 6 of 8: shard 2 of 4 (positions 2 and 6)
damaged_task=2
damaged_frame=frames/led_03.dng

# Nothing of a surrounding Slurm (a test run inside a job) may reach our daemons or clients.
while read -r variable; do unset "$variable"; done < <(compgen -e | grep -E '^(SLURM|SBATCH|SQUEUE|SINFO|SCONTROL|SCANCEL)_')

tmp=""
munged_pid="" slurmctld_pid="" slurmd_pid=""
job_ids=()

stop_pid() {  # TERM, up to 10 s, then KILL: only the daemons this script started
  local pid=$1
  [ -n "$pid" ] || return 0
  kill "$pid" 2>/dev/null || return 0
  for _ in $(seq 50); do
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.2
  done
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  return 0
}

teardown() {
  local code=$?
  if [ -n "$slurmctld_pid" ] && kill -0 "$slurmctld_pid" 2>/dev/null; then
    # Jobs still queued or running (a failure midway) are cancelled before their daemons go.
    for id in "${job_ids[@]}"; do scancel "$id" 2>/dev/null; done
    for _ in $(seq 50); do
      [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
      sleep 0.2
    done
  fi
  stop_pid "$slurmd_pid"
  stop_pid "$slurmctld_pid"
  stop_pid "$munged_pid"
  [ -n "$tmp" ] && rm -rf "$tmp"
  exit "$code"
}
trap teardown EXIT
trap 'exit 130' INT TERM

show_logs() {
  [ -n "$tmp" ] || return 0
  for log in "$tmp"/log/* "$tmp"/work/logs/*; do
    [ -f "$log" ] || continue
    echo "---- $log (last 25 lines)"
    tail -n 25 "$log"
  done
}
skip() {
  echo "SKIPPED: slurm batch test (tests/app/cli/slurm_batch_test.sh): $*"
  show_logs
  exit 77
}
fail() {
  echo "FAILED: $*"
  show_logs
  exit 1
}

# ---- can Slurm run here?
for command in munged mungekey munge slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
  command -v "$command" >/dev/null ||
    skip "'$command' is not installed (Debian: slurm-wlm and munge, see scripts/install-deps.sh)"
done
[ "$(id -u)" -eq 0 ] || skip "slurmd needs root to start job steps; run as root (as CI does)"
hardware=$(slurmd -C 2>&1 | head -n 1)
case "$hardware" in
  NodeName=*CPUs=*) ;;
  *) skip "'slurmd -C' does not describe this machine: $hardware" ;;
esac
[ -x "$scanbench_binary" ] || fail "$scanbench_binary: no such program"
[ -f "$batch_md" ] || fail "$batch_md: no such file"

# ---- the recipe, copied out of the doc: the ```sh block under '### Slurm job array'
recipe=$(awk '/^### Slurm job array/ { section = 1 } section && /^```sh$/ { inside = 1; next }
              inside && /^```$/ { exit } inside { print }' "$batch_md")
case "$recipe" in
  '#!/bin/sh'*) ;;
  *) fail "$batch_md: no \`\`\`sh block starting with #!/bin/sh under '### Slurm job array'" ;;
esac
grep -q -- "^#SBATCH --array=1-$shards\$" <<<"$recipe" ||
  fail "$batch_md: the Slurm recipe's array is not '--array=1-$shards' (the test expects $shards tasks)"
grep -q 'scanbench batch' <<<"$recipe" || fail "$batch_md: the Slurm recipe runs no 'scanbench batch'"

tmp=$(mktemp -d /tmp/scanbench-slurm.XXXXXX) || fail "mktemp failed"
chmod 755 "$tmp"  # munged wants its socket folder and the path to it searchable by all
mkdir -p "$tmp/munge" "$tmp/munge-socket" "$tmp/state" "$tmp/spool" "$tmp/log" "$tmp/bin" "$tmp/work/logs" \
  "$tmp/library"
chmod 700 "$tmp/munge"
chmod 755 "$tmp/munge-socket"
printf '%s\n' "$recipe" >"$tmp/work/resolve.sh"
ln -s "$(realpath "$scanbench_binary")" "$tmp/bin/scanbench"

# ---- munge: a private key and socket
socket=$tmp/munge-socket/munge.socket
mungekey --create --keyfile="$tmp/munge/munge.key" >"$tmp/log/mungekey.out" 2>&1 ||
  skip "mungekey could not create a key: $(cat "$tmp/log/mungekey.out")"
chmod 600 "$tmp/munge/munge.key"
munged --foreground --socket="$socket" --key-file="$tmp/munge/munge.key" --pid-file="$tmp/munge/munged.pid" \
  --seed-file="$tmp/munge/munged.seed" --log-file="$tmp/log/munged.log" >"$tmp/log/munged.out" 2>&1 &
munged_pid=$!
for _ in $(seq 50); do
  [ -S "$socket" ] && break
  kill -0 "$munged_pid" 2>/dev/null || skip "munged exited at start"
  sleep 0.1
done
munge -n -S "$socket" | unmunge -S "$socket" >/dev/null 2>&1 || skip "munged does not answer on $socket"

# ---- slurm.conf: loopback, one node with this machine's cores, no cgroups, all state in $tmp
listening_ports() {  # hexadecimal local ports of listening TCP sockets
  awk '$4 == "0A" { split($2, address, ":"); print address[2] }' /proc/net/tcp /proc/net/tcp6 2>/dev/null
}
free_port() {
  local port
  for _ in $(seq 100); do
    port=$((20000 + RANDOM % 40000))
    [ "$port" = "${1:-}" ] && continue
    listening_ports | grep -qix "$(printf '%04X' "$port")" || { echo "$port"; return 0; }
  done
  return 1
}
slurmctld_port=$(free_port) || skip "no free TCP port for slurmctld"
slurmd_port=$(free_port "$slurmctld_port") || skip "no free TCP port for slurmd"
host=$(uname -n)
host=${host%%.*}
user=$(id -un)
export SLURM_CONF=$tmp/slurm.conf
cat >"$SLURM_CONF" <<EOF
ClusterName=scanbench-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$slurmctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
# No cgroups: a container has no delegated cgroup tree.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/builtin
ReturnToService=2
NodeName=$node NodeAddr=127.0.0.1 ${hardware#NodeName=* } State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -D -c -f "$SLURM_CONF" >"$tmp/log/slurmctld.out" 2>&1 &
slurmctld_pid=$!
slurmd -D -N "$node" -f "$SLURM_CONF" >"$tmp/log/slurmd.out" 2>&1 &
slurmd_pid=$!
state=""
for _ in $(seq 150); do  # up to 30 s
  kill -0 "$slurmctld_pid" 2>/dev/null || skip "slurmctld exited at start"
  kill -0 "$slurmd_pid" 2>/dev/null || skip "slurmd exited at start"
  state=$(sinfo -h -n "$node" -o %T 2>/dev/null)
  [ "$state" = idle ] && break
  sleep 0.2
done
[ "$state" = idle ] || skip "node $node did not become idle within 30 s (state '${state:-none}')"
echo "Slurm up after $SECONDS s: slurmctld on 127.0.0.1:$slurmctld_port, slurmd on :$slurmd_port, node $node: ${hardware#NodeName=* }"

# ---- the library: 8 small simulated sessions, one frame of one truncated. Two are rendered (different
# noise seeds, in parallel) and copied to make 8: each session keeps its own results/, so copies are as good
# as new renders for the batch, and rendering all 8 would take most of the test's time.
library=$tmp/library
simulate() {
  "$tmp/bin/scanbench" simulate "$library/s$1" --width 160 --height 106 --seed "$1" --render-threads 1 \
    >"$tmp/log/simulate-s$1.out" 2>&1 || fail "scanbench simulate s$1 failed: $(cat "$tmp/log/simulate-s$1.out")"
}
simulate 1 &
other_pid=$!
simulate 2 || exit 1
wait "$other_pid" || exit 1
for i in 3 4 5 6 7 8; do cp -r "$library/s$(( (i + 1) % 2 + 1 ))" "$library/s$i" || fail "could not copy a session"; done
printf '# scanbench slurm test library\n' >"$library/lib.txt"
for i in $(seq 8); do echo "s$i" >>"$library/lib.txt"; done
truncate -s 10000 "$library/$damaged/$damaged_frame" || fail "could not truncate $damaged/$damaged_frame"
echo "8 sessions simulated (at $SECONDS s)"

# ---- submit the recipe; the resources only are made to fit this machine (command-line options win over
# the script's #SBATCH lines)
# Submits resolve.sh and waits for the whole array; sets job_id.
submit() {
  job_id=$(cd "$tmp/work" && LIBRARY=$library PATH="$tmp/bin:$PATH" \
    sbatch --parsable --cpus-per-task=1 --mem=1G resolve.sh 2>"$tmp/log/sbatch.err") ||
    fail "sbatch refused the recipe: $(cat "$tmp/log/sbatch.err")"
  job_id=${job_id%%;*}
  job_ids+=("$job_id")
  local task finished=""
  for _ in $(seq 600); do  # up to 120 s
    [ -z "$(squeue -h -j "$job_id" -o %i 2>/dev/null)" ] && finished=1 && break
    sleep 0.2
  done
  [ -n "$finished" ] || fail "job array $job_id did not finish within 120 s"
  for task in $(seq "$shards"); do
    [ -f "$library/batch-$job_id-$task.csv" ] ||
      fail "task $task of job $job_id wrote no summary $library/batch-$job_id-$task.csv"
  done
}

# Each array task's exit code, as "task:code" lines sorted by task.
task_exit_codes() {
  scontrol -o show job "$1" | sed -n 's/.* ArrayTaskId=\([0-9]*\) .* ExitCode=\([0-9]*\):.*/\1:\2/p' | sort -n
}
expected_exit_codes() {
  for task in $(seq "$shards"); do
    echo "$task:$([ "$task" -eq "$damaged_task" ] && echo 1 || echo 0)"
  done
}

# The summary rows of a job's shards (minus their header lines), as "session,status" sorted by session.
# The session paths hold no comma, so the first two CSV fields are plain.
summary_rows() {
  local task
  for task in $(seq "$shards"); do tail -n +2 "$library/batch-$1-$task.csv"; done
}
statuses() {
  summary_rows "$1" | awk -F, '{ n = split($1, parts, "/"); print parts[n] "," $2 }' | sort
}
expected_statuses() {  # $1 = status of the good sessions
  for i in $(seq 8); do
    echo "s$i,$([ "s$i" = "$damaged" ] && echo failed || echo "$1")"
  done | sort
}
result_folders() {  # "session count" of complete result folders
  for i in $(seq 8); do
    echo "s$i $(find "$library/s$i/results" -mindepth 1 -maxdepth 1 -type d ! -name '.*' | wc -l)"
  done
}
check_damaged_error() {  # $1 = job id
  local message
  message=$(summary_rows "$1" | grep "/$damaged,failed,")
  if ! { grep -q "$damaged_frame" <<<"$message" && grep -q "mismatch" <<<"$message"; }; then
    fail "job $1: the failed session's error does not name $damaged_frame: $message"
  fi
  grep -q "$damaged_frame" "$tmp/work/logs/resolve-$1_$damaged_task.log" ||
    fail "job $1: task $damaged_task's log does not name $damaged_frame"
}

start=$SECONDS
submit
first=$job_id
[ "$(task_exit_codes "$first")" = "$(expected_exit_codes)" ] ||
  fail "job $first: task exit codes $(task_exit_codes "$first" | tr '\n' ' ')(expected $(expected_exit_codes | tr '\n' ' '))"
[ "$(statuses "$first")" = "$(expected_statuses solved)" ] ||
  fail "job $first: statuses $(statuses "$first" | tr '\n' ' ')(expected 7 solved, $damaged failed)"
check_damaged_error "$first"
folders_after_first=$(result_folders)
[ "$folders_after_first" = "$(for i in $(seq 8); do echo "s$i $([ "s$i" = "$damaged" ] && echo 0 || echo 1)"; done)" ] ||
  fail "job $first: result folders per session: $(echo "$folders_after_first" | tr '\n' ' ')"
for i in $(seq 8); do
  [ "s$i" = "$damaged" ] && continue
  ls "$library/s$i"/results/*/report.json >/dev/null 2>&1 || fail "s$i: solved but no results/*/report.json"
done
echo "job array $first: 4 tasks, 7 sessions solved, $damaged failed naming $damaged_frame ($((SECONDS - start)) s)"

start=$SECONDS
submit
second=$job_id
[ "$(task_exit_codes "$second")" = "$(expected_exit_codes)" ] ||
  fail "job $second: task exit codes $(task_exit_codes "$second" | tr '\n' ' ')(expected $(expected_exit_codes | tr '\n' ' '))"
[ "$(statuses "$second")" = "$(expected_statuses skipped)" ] ||
  fail "job $second: statuses $(statuses "$second" | tr '\n' ' ')(expected 7 skipped, $damaged failed)"
check_damaged_error "$second"
[ "$(result_folders)" = "$folders_after_first" ] || fail "job $second wrote result folders: $(result_folders | tr '\n' ' ')"
echo "job array $second (rerun): 7 sessions skipped, $damaged failed again ($((SECONDS - start)) s)"
echo "slurm batch test: passed"
