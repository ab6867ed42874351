#!/usr/bin/env bash
# Regenerates every committed study under reports/ (see reports/REPRODUCTION.md):
#
#   scripts/reproduce.sh            # default quality, into reports/<study>/
#   scripts/reproduce.sh --paper    # thesis resolution and the full grids, into reports/<study>-paper/
#
# The wall time of each study is written to reports/bench/reproduce[-paper].json.
#
# Needs the real volumes on the search path ($VOLPHOT_DATA, ./data or ../shared/data).
# Finished cells are reused; delete a report folder to render it again.
#
# The studies share their path-traced references through one pool (`sweep run
# --reference-pool`, default reports/reference-pool, or $VOLPHOT_REFERENCE_POOL): a scene two
# studies compare against is traced once, refined to the larger sample count, and each
# study gets the image it would have rendered alone. The studies run in the order of their
# references' sample counts (64, 128, 256, 1024), so every reference is refined, never
# traced again from the start.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin sweep
pool="${VOLPHOT_REFERENCE_POOL:-reports/reference-pool}"
# `sweep run` writes to out/<name> by default; the committed studies live in reports/.
suffix=""
for arg in "$@"; do
  case "$arg" in
    --paper) suffix="-paper" ;;
    --quick) suffix="-quick" ;;
  esac
done
# Each study's wall time goes to reports/bench/reproduce<suffix>.json (the documents cite it).
times=()
start_all=$(date +%s.%N)
for experiment in quickstart artifacts nused_seeds free_path transparent single_vs_multiple cinematic albedo stepsize cost consistency_seeds consistency alpha presets; do
  echo "== $experiment"
  start=$(date +%s.%N)
  ./target/release/sweep "experiments/$experiment.toml" --quiet --reference-pool "$pool" \
    --output "reports/$experiment$suffix" "$@"
  times+=("{\"study\": \"$experiment$suffix\", \"seconds\": $(awk "BEGIN { print $(date +%s.%N) - $start }")}")
done
total=$(awk "BEGIN { print $(date +%s.%N) - $start_all }")
mkdir -p reports/bench
{
  # The commit measured, with -dirty when tracked files had uncommitted changes (then it
  # does not describe the build).
  commit="$(git rev-parse --short=12 HEAD 2>/dev/null || echo unknown)"
  if [ -n "$(git status --porcelain --untracked-files=no 2>/dev/null)" ]; then commit="$commit-dirty"; fi
  echo "{\"host\": \"$(hostname)\", \"cores\": $(nproc), \"commit\": \"$commit\","
  echo " \"studies\": [$(IFS=,; echo "${times[*]}")],"
  echo " \"total_seconds\": $total}"
} > "reports/bench/reproduce$suffix.json"
./target/release/sweep index reports
