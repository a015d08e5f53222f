#!/usr/bin/env bash
# Makes Intel Open Image Denoise available to the build (the `denoise` feature, on by
# default). Debian packages no OIDN, so unless one is already there (OIDN_DIR set by the
# user, or pkg-config's OpenImageDenoise) this fetches Intel's official Linux build from
# PyPI (the `pyoidn` wheel, pinned and checked by SHA-256) and unpacks the four shared
# libraries of its CPU device into .oidn/lib/ of this repository, where
# .cargo/config.toml points OIDN_DIR and build.rs records an rpath: nothing Python is
# needed afterwards. Idempotent: when .oidn/lib/ is complete it downloads nothing.
#
# Usage: scripts/oidn.sh           install if needed
#        scripts/oidn.sh --found   exit 0 if nothing needs installing, 1 otherwise
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
dest=$root/.oidn/lib
version=2.5.1
wheel=pyoidn-$version.0-py3-none-manylinux2014_x86_64.whl
sha256=32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e
# The library, its core (with the trained weights), the CPU device and TBB; the CUDA,
# HIP and SYCL devices beside them in the wheel are not needed.
libs=(libOpenImageDenoise.so.$version libOpenImageDenoise_core.so.$version
  libOpenImageDenoise_device_cpu.so.$version libtbb.so.12)

found() {
  if [[ -n ${OIDN_DIR:-} && $OIDN_DIR != "$root/.oidn" ]]; then
    echo "Open Image Denoise from OIDN_DIR=$OIDN_DIR"
  elif pkg-config --exists OpenImageDenoise 2>/dev/null; then
    echo "Open Image Denoise $(pkg-config --modversion OpenImageDenoise) from pkg-config"
  else
    for l in "${libs[@]}" libOpenImageDenoise.so libOpenImageDenoise.so.2; do
      [[ -f $dest/$l ]] || return 1
    done
    echo "Open Image Denoise $version in .oidn/lib"
  fi
}

if [[ ${1:-} == --found ]]; then
  found >/dev/null
  exit
fi
if where=$(found); then
  echo "setup: $where" >&2
  exit 0
fi

echo "setup: fetching Open Image Denoise $version (Intel's build, from the pyoidn wheel, 88 MB)" >&2
work=$(mktemp -d "$root/.oidn-download.XXXXXX")
trap 'rm -rf "$work"' EXIT
python3 -m pip download --quiet --no-deps --only-binary=:all: \
  --dest "$work" "pyoidn==$version.0"
echo "$sha256  $work/$wheel" | sha256sum --check --quiet
# Unpacked beside the final folder and renamed over it, so an interrupted run leaves
# either no .oidn/lib or a complete one.
python3 - "$work/$wheel" "$work/lib" "${libs[@]}" <<'PY'
import os, sys, zipfile
wheel, out, names = sys.argv[1], sys.argv[2], sys.argv[3:]
os.makedirs(out)
with zipfile.ZipFile(wheel) as z:
    for name in names:
        with z.open("pyoidn/oidn/lib/" + name) as src, open(os.path.join(out, name), "wb") as dst:
            dst.write(src.read())
PY
# The linker wants libOpenImageDenoise.so, the loader its soname .so.2 (the wheel, a
# zip, holds copies instead of these links).
ln -s "libOpenImageDenoise.so.$version" "$work/lib/libOpenImageDenoise.so.2"
ln -s libOpenImageDenoise.so.2 "$work/lib/libOpenImageDenoise.so"
mkdir -p "$root/.oidn"
rm -rf "$dest"
mv "$work/lib" "$dest"
echo "setup: Open Image Denoise $version in .oidn/lib" >&2
