#!/usr/bin/env bash
# Installs the Debian packages polyrad needs, when they are missing. Runs as root (or with sudo).
set -euo pipefail

packages=(
  cmake g++ make
  libeigen3-dev libembree-dev libopenimageio-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-matplotlib
  libcpp-httplib-dev pkg-config
  chromium chromium-driver python3-selenium
  clang-14 libclang-rt-14-dev libomp-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "polyrad: installing ${missing[*]}" >&2
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
if ! "${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}" >&2; then
  "${sudo_cmd[@]}" apt-get update >&2
  "${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}" >&2
fi
