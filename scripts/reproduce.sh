#!/usr/bin/env bash
# Regenerates every committed study under reports/ (see reports/REPRODUCTION.md):
#
#   scripts/reproduce.sh            # default quality (25 min on 2 cores, measured)
#   scripts/reproduce.sh --paper    # thesis resolution and the full grids (5 h 10 min on 2 cores,
#                                   # measured; reports/REPRODUCTION.md)
#
# Needs the real volumes on the search path ($VOLPHOT_DATA, ./data or ../shared/data).
# Finished cells are reused; delete a report folder to render it again.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --bin sweep
for experiment in quickstart artifacts single_vs_multiple albedo stepsize free_path transparent cost consistency alpha presets; do
  echo "== $experiment"
  ./target/release/sweep "experiments/$experiment.toml" --quiet "$@"
done
