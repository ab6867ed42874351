#!/usr/bin/env bash
# Regenerates every committed study under reports/ (see reports/REPRODUCTION.md):
#
#   scripts/reproduce.sh            # default quality (37 min on 2 cores with the build, measured)
#   scripts/reproduce.sh --paper    # thesis resolution and the full grids (4 h 26 min on 2 cores
#                                   # measured study by study, 2 h 52 min with stepsize, alpha,
#                                   # consistency and artifacts rendered again on 2026-12-05;
#                                   # 5 h 10 min as first committed; reports/REPRODUCTION.md)
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
for experiment in quickstart artifacts free_path transparent single_vs_multiple albedo stepsize cost consistency alpha presets; do
  echo "== $experiment"
  ./target/release/sweep "experiments/$experiment.toml" --quiet --reference-pool "$pool" \
    --output "reports/$experiment$suffix" "$@"
done
./target/release/sweep index reports
