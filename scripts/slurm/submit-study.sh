#!/usr/bin/env bash
# Submits a sharded `alc study` to SLURM: a job array of N shards (study.sbatch, one task per shard,
# each writes OUTDIR/shard-I.sqlite) and a merge job (merge.sbatch, OUTDIR/merged.sqlite) that
# waits for all of them with --dependency=afterok and is cancelled if one fails.
#
# usage: submit-study.sh --out DIR [--alc PATH] [--grid paper|FILE.toml] [--case A|B|C|D|all|FILE.csv]...
#                        [--shards N] [--cpus N] [--wait] [-- SBATCH_OPTION...]
#        submit-study.sh --help   this text (exit 0)
#   --out DIR     output directory, created; on a file system the compute nodes share (required)
#   --alc PATH    the alc binary, at the same path on the compute nodes (default: $ALC, else `alc` on PATH)
#   --grid G      paper or a TOML grid file (default paper)
#   --case C      a load case A|B|C|D|all, or a scenario CSV file; CSV files may be repeated (default all)
#   --shards N    array tasks (default 4)
#   --cpus N      cores per shard: sbatch --cpus-per-task and alc --jobs (default 1)
#   --wait        block until the merge job has ended; exit 0 only if it completed
#   -- ...        sbatch options for both jobs: partition, time, account, e.g.
#                 -- --partition=compute --time=02:00:00 --account=myproject
# sbatch's own environment variables (SBATCH_PARTITION, SBATCH_TIMELIMIT, SBATCH_ACCOUNT, ...) apply
# as well. Prints the two job IDs; logs go to OUTDIR/logs/.
set -euo pipefail
# (Written for bash 4.2 too, as on older login nodes: an empty array is expanded as ${a[@]+"${a[@]}"}.)

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# usage [STATUS]: the usage of the header; asked for (--help, STATUS 0) on stdout, else on stderr, exit 2.
usage() {
  local status="${1:-2}"
  if [ "$status" -eq 0 ]; then
    awk 'NR >= 6 && !/^#/ { exit } NR >= 6 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}"
  else
    awk 'NR >= 6 && !/^#/ { exit } NR >= 6 { sub(/^# ?/, ""); print }' "${BASH_SOURCE[0]}" >&2
  fi
  exit "$status"
}
die() { echo "submit-study.sh: $*" >&2; exit 1; }
# abs PATH: PATH made absolute (the jobs' working directory is not necessarily this one).
abs() { case "$1" in /*) echo "$1" ;; *) echo "$PWD/$1" ;; esac; }

alc="${ALC:-}" grid=paper out="" shards=4 cpus=1 wait=0
cases=() sbatch_opts=()
while [ $# -gt 0 ]; do
  case "$1" in
    --out|--alc|--grid|--case|--shards|--cpus) [ $# -ge 2 ] || usage ;;&
    --out) out="$2"; shift 2 ;;
    --alc) alc="$2"; shift 2 ;;
    --grid) grid="$2"; shift 2 ;;
    --case) cases+=("$2"); shift 2 ;;
    --shards) shards="$2"; shift 2 ;;
    --cpus) cpus="$2"; shift 2 ;;
    --wait) wait=1; shift ;;
    -h|--help) usage 0 ;;
    --) shift; sbatch_opts=("$@"); break ;;
    *) usage ;;
  esac
done
[ -n "$out" ] || usage
[[ "$shards" =~ ^[1-9][0-9]*$ ]] || die "--shards must be a whole number >= 1, not '$shards'"
[[ "$cpus" =~ ^[1-9][0-9]*$ ]] || die "--cpus must be a whole number >= 1, not '$cpus'"
if [ -z "$alc" ]; then
  alc="$(command -v alc)" || die "no alc binary: give --alc PATH or set ALC"
fi
[ -x "$alc" ] || die "$alc is not an executable"
alc="$(abs "$alc")"

# The study's own arguments; files become absolute paths.
study_args=(--grid "$grid")
if [ "$grid" != paper ]; then
  [ -f "$grid" ] || die "grid file $grid not found"
  study_args=(--grid "$(abs "$grid")")
fi
[ ${#cases[@]} -gt 0 ] || cases=(all)
# alc study takes one --case, or scenario files: refused here, not in every task of the array.
names=0 files=0
for c in "${cases[@]}"; do case "$c" in *.csv) files=$((files + 1)) ;; *) names=$((names + 1)) ;; esac; done
[ "$names" -le 1 ] || die "give one --case A|B|C|D|all (or several scenario CSV files), not $names"
[ "$names" -eq 0 ] || [ "$files" -eq 0 ] || die "give --case ${cases[0]} or scenario CSV files, not both"
for c in "${cases[@]}"; do
  case "$c" in
    *.csv) [ -f "$c" ] || die "scenario file $c not found"; study_args+=("$(abs "$c")") ;;
    *) study_args+=(--case "$c") ;;
  esac
done

mkdir -p "$out/logs" || die "cannot create $out/logs"
out="$(cd "$out" && pwd)"

array_job="$(sbatch --parsable --array="1-$shards" --cpus-per-task="$cpus" \
  --output="$out/logs/shard-%a-job%A.out" ${sbatch_opts[@]+"${sbatch_opts[@]}"} \
  "$here/study.sbatch" "$alc" "$out" "$shards" "${study_args[@]}")" || die "sbatch of the shard array failed"
array_job="${array_job%%;*}"  # --parsable prints JOBID or JOBID;CLUSTER

merge_args=(--parsable --dependency="afterok:$array_job" --kill-on-invalid-dep=yes
            --output="$out/logs/merge-job%j.out" ${sbatch_opts[@]+"${sbatch_opts[@]}"})
[ "$wait" = 1 ] && merge_args+=(--wait)
# With --wait, sbatch prints the ID at submission and returns when the job has ended, with the job's
# exit status (0 also when the job was cancelled because a shard failed): the job's state is checked
# below. Only when it printed no ID did the submission itself fail.
merge_rc=0
merge_job="$(sbatch "${merge_args[@]}" "$here/merge.sbatch" "$alc" "$out" "$shards")" || merge_rc=$?
[ -n "$merge_job" ] ||
  die "sbatch of the merge job failed (exit $merge_rc; shard array job $array_job stays queued: scancel $array_job)"
merge_job="${merge_job%%;*}"
echo "shards: job $array_job (array 1-$shards), merge: job $merge_job -> $out/merged.sqlite"

[ "$wait" = 1 ] || exit 0
state="$(scontrol show job -o "$merge_job" 2>/dev/null | grep -o 'JobState=[A-Z_]*' || true)"
[ "$state" = JobState=COMPLETED ] && exit 0
{
  echo "submit-study.sh: merge job $merge_job ended with ${state:-an unknown state} in $out"
  # The shards that did not complete, one line each.
  scontrol show job -o "$array_job" 2>/dev/null | grep -v 'JobState=COMPLETED' |
    awk '{ printf "  shard"; for (i = 1; i <= NF; i++) if ($i ~ /^(ArrayTaskId|JobState|Reason|ExitCode)=/) printf " %s", $i; print "" }' || true
  echo "logs: $out/logs/"
} >&2
exit 1
