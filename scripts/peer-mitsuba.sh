#!/usr/bin/env bash
# Mitsuba 3 as a peer: install it into its own virtual environment (from PyPI), then render
# an exported scene with Mitsuba and with volphot and print the time-to-error table.
#
#   scripts/peer-mitsuba.sh [SCENE.toml] [sweep bench options…]
#   scripts/peer-mitsuba.sh --install      # install only; prints the environment's python
#   scripts/peer-mitsuba.sh experiments/scenes/phantom-head.toml --resolution 128x128 --json peer.json
#
# Default scene: experiments/scenes/phantom-head.toml at 128×128. Options are those of
# `sweep bench --peer mitsuba` (--peer-spp, --seeds, --reference-passes, --threads, --json…).
# Environment: VOLPHOT_PEER_VENV (default ${XDG_CACHE_HOME:-~/.cache}/volphot/mitsuba-venv),
# VOLPHOT_SWEEP_BIN (a built `sweep`; default: build it with cargo).
# Mitsuba's llvm variant needs libLLVM ≥ 17 (it aborts on 15/16): as root on Debian this
# installs libllvm19; without it the scalar variant is used.
set -euo pipefail

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
VENV="${VOLPHOT_PEER_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/volphot/mitsuba-venv}"
MITSUBA_VERSION="3.9.1"

log() { echo "peer-mitsuba: $*" >&2; }

INSTALL_ONLY=0
if [ "${1:-}" = "--install" ]; then
  INSTALL_ONLY=1; shift
fi

# The scene is checked before anything is installed (a mistyped path used to cost a
# Mitsuba install, and as root a Debian package, before `sweep` said it was missing).
SCENE="$ROOT/experiments/scenes/phantom-head.toml"
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then
  SCENE="$1"; shift
fi
if [ ! -f "$SCENE" ] || [ ! -r "$SCENE" ]; then
  log "error: scene $SCENE: no such readable file (expected a volphot scene, e.g. experiments/scenes/phantom-head.toml); nothing was installed"
  exit 2
fi
# Absolute, since the bench runs from the checkout's root.
SCENE="$(cd "$(dirname "$SCENE")" && pwd)/$(basename "$SCENE")"

if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c "import mitsuba, numpy" 2>/dev/null; then
  log "installing Mitsuba $MITSUBA_VERSION into $VENV"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install --quiet "mitsuba==$MITSUBA_VERSION" numpy
fi
if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null && ! ls /usr/lib/*-linux-gnu/libLLVM*.so.19* >/dev/null 2>&1; then
  log "installing libllvm19 for Mitsuba's llvm variant"
  (apt-get install -y --no-install-recommends libllvm19 >/dev/null 2>&1 \
    || (apt-get update >/dev/null 2>&1 && apt-get install -y --no-install-recommends libllvm19 >/dev/null 2>&1)) \
    || log "libllvm19 not available: Mitsuba renders with scalar_rgb"
fi

if [ "$INSTALL_ONLY" -eq 1 ]; then
  # For the tests that run Mitsuba's own scripts (scripts/peer_envmap.py): the interpreter.
  echo "$VENV/bin/python"
  exit 0
fi

SWEEP="${VOLPHOT_SWEEP_BIN:-}"
if [ -z "$SWEEP" ]; then
  (cd "$ROOT" && cargo build --release --locked -q -p volphot-sweep)
  SWEEP="$ROOT/target/release/sweep"
fi

EXTRA=()
if [[ " $* " != *" --resolution "* ]]; then
  EXTRA+=(--resolution 128x128)
fi
cd "$ROOT"
exec "$SWEEP" bench --peer mitsuba --scene "$SCENE" --python "$VENV/bin/python" "${EXTRA[@]}" "$@"
