#!/usr/bin/env bash
# Installs what ember needs to build on Debian/Ubuntu, and nothing that is already there:
# Embree (libembree-dev: Embree 3 on Debian 12, Embree 4 on Debian 13+), libclang for
# bindgen, pkg-config, valgrind (for the FFI memory checks), and Intel Open Image Denoise
# (scripts/oidn.sh: a system one if there is one, else Intel's build from PyPI into .oidn/).
# Idempotent: a second run installs and downloads nothing and exits 0.
set -euo pipefail

packages=(libembree-dev libclang-dev pkg-config valgrind)
# pip fetches Open Image Denoise's wheel (scripts/oidn.sh); not needed where OIDN is found.
if ! bash "$(dirname "$0")/oidn.sh" --found; then
  command -v python3 >/dev/null && python3 -m pip --version >/dev/null 2>&1 || packages+=(python3-pip)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  sudo=()
  if [[ $(id -u) != 0 ]]; then
    command -v sudo >/dev/null || { echo "setup: need root (or sudo) to install ${missing[*]}" >&2; exit 1; }
    sudo=(sudo)
  fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo[@]}" apt-get update -q >/dev/null
  "${sudo[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null
fi

if ! command -v cargo >/dev/null; then
  echo "setup: no Rust toolchain found: install one with rustup (Rust 1.87 or newer)" >&2
  exit 1
fi
bash "$(dirname "$0")/oidn.sh"
echo "setup: ready (Embree headers: $(ls -d /usr/include/embree* 2>/dev/null | tr '\n' ' '))" >&2
