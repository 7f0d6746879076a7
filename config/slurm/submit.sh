#!/usr/bin/env bash
# Queue a sharded `vpsom bench` on Slurm: an array of N shards (bench.sbatch), then the merge
# (merge.sbatch) once every shard has succeeded. Prints the two job ids. docs/cluster.md.
#   config/slurm/submit.sh N OUT [vpsom bench options...]
# OUT must be on a file system every node sees. Environment: VPSOM, the vpsom binary (default:
# the one on PATH, resolved here so that the jobs run the same binary); SBATCH_ARGS, extra
# sbatch options for both jobs (e.g. "--partition=cpu --time=02:00:00 --cpus-per-task=4").
set -euo pipefail
usage="usage: $0 N OUT [vpsom bench options...]"
n=${1:?$usage}
out=${2:?$usage}
shift 2
case $n in '' | *[!0-9]* | 0) echo "$0: N must be a positive integer, got '$n'" >&2; exit 2 ;; esac
here=$(cd "$(dirname "$0")" && pwd)
VPSOM=$(command -v "${VPSOM:-vpsom}") || { echo "$0: vpsom not found (set VPSOM)" >&2; exit 2; }
export VPSOM
mkdir -p "$out/slurm"
out=$(cd "$out" && pwd)
read -r -a extra <<<"${SBATCH_ARGS:-}"
array=$(sbatch --parsable "${extra[@]}" --array="1-$n" --output="$out/slurm/bench-%A_%a.out" \
  "$here/bench.sbatch" "$out" "$@")
array=${array%%;*}
merge=$(sbatch --parsable "${extra[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
  --output="$out/slurm/merge-%j.out" "$here/merge.sbatch" "$out")
merge=${merge%%;*}
echo "shards: job $array (array 1-$n); merge: job $merge; report: $out/report.md"
