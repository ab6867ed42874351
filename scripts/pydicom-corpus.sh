#!/usr/bin/env bash
# pydicom's test files as a reference for volphot's DICOM reader: install pydicom and the
# decoders it needs for compressed files into their own virtual environment (from PyPI),
# then export pydicom's arrays and three-slice series (scripts/pydicom_corpus.py).
#
#   scripts/pydicom-corpus.sh OUT        # install if needed, then export into OUT
#   scripts/pydicom-corpus.sh --install  # install only (what .ci/run does)
#
# Environment: VOLPHOT_PYDICOM_VENV (default ${XDG_CACHE_HOME:-~/.cache}/volphot/pydicom-venv).
# The test `pydicom_corpus_matches_pydicom_file_by_file` (crates/core/tests/it/dicom.rs) runs it.
set -euo pipefail

ROOT="$(cd "$(dirname "$0")/.." && pwd)"
VENV="${VOLPHOT_PYDICOM_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/volphot/pydicom-venv}"
PACKAGES=(pydicom==3.0.2 numpy pylibjpeg==2.1.0 pylibjpeg-libjpeg==2.5.0 pylibjpeg-rle==2.2.0 pylibjpeg-openjpeg==2.6.0)

log() { echo "pydicom-corpus: $*" >&2; }

if [ ! -x "$VENV/bin/python" ] || ! "$VENV/bin/python" -c "import pydicom, numpy, pylibjpeg, libjpeg, rle, openjpeg" 2>/dev/null; then
  log "installing ${PACKAGES[*]} into $VENV"
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install --quiet --disable-pip-version-check "${PACKAGES[@]}"
fi
if [ "${1:-}" = "--install" ]; then
  exit 0
fi
if [ $# -ne 1 ]; then
  echo "usage: scripts/pydicom-corpus.sh OUT | --install" >&2
  exit 2
fi
exec "$VENV/bin/python" "$ROOT/scripts/pydicom_corpus.py" "$1"
