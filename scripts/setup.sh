#!/usr/bin/env bash
# One-time setup, run by every make target: system libraries for offscreen rendering (EGL),
# the virtual environment .venv, the pinned packages of environment.txt and stair_lite itself.
# Re-running is cheap: the pip step is skipped while environment.txt and pyproject.toml are unchanged.
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES="libegl1 libegl-mesa0 libgl1 libgl1-mesa-dri"
[ "${STAIR_BROWSER:-0}" = "1" ] && APT_PACKAGES="$APT_PACKAGES chromium"  # the book's browser check (make test)
missing=""
for pkg in $APT_PACKAGES; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing="$missing $pkg"
done
python3 -c 'import ensurepip, venv' 2>/dev/null || missing="$missing python3-venv"
if [ -n "$missing" ]; then
  if [ "$(id -u)" = "0" ]; then
    echo "[setup] installing system packages:$missing"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $missing >/dev/null
  else
    echo "[setup] missing system packages (offscreen rendering; chromium for the book check):$missing" >&2
    echo "[setup] install them as root, then run make again:" >&2
    echo "    sudo apt-get install -y --no-install-recommends $APT_PACKAGES python3-venv" >&2
    exit 1
  fi
fi

python3 -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' || {
  echo "[setup] Python >= 3.11 is needed, found $(python3 --version)" >&2; exit 1; }

[ -x .venv/bin/python ] || { echo "[setup] creating .venv"; python3 -m venv .venv; }
stamp=.venv/.stair_lite_installed
wanted=$(cat environment.txt pyproject.toml | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$wanted" ]; then
  echo "[setup] installing environment.txt into .venv (first time: about 2 minutes)"
  .venv/bin/python -m pip install -q --disable-pip-version-check -r environment.txt
  .venv/bin/python -m pip install -q --disable-pip-version-check --no-deps -e .
  echo "$wanted" > "$stamp"
fi
