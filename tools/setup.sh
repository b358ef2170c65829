#!/usr/bin/env bash
# Installs what dynaguide needs from Debian 12's packages and builds it into build/.
# Idempotent and non-interactive: packages already present are not touched, and
# a build that is up to date finishes at once.
#   bash tools/setup.sh            # install + configure + build (Release, -march=native)
#   DG_BUILD_DIR=out bash tools/setup.sh   # another build directory
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${DG_BUILD_DIR:-$root/build}"

packages=(
  build-essential clang-14 cmake ninja-build pkg-config
  libeigen3-dev libtbb-dev libspdlog-dev libfmt-dev
  libopencv-dev opencv-doc libceres-dev
  libhdf5-dev hdf5-tools libyaml-cpp-dev libcli11-dev nlohmann-json3-dev catch2
  libgmsh-dev
  libinsighttoolkit5-dev libgdcm-tools libvtk9-dev python3-pydicom python3-nibabel python3-numpy
)

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if ((${#missing[@]})); then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo_cmd=()
  if [[ $(id -u) -ne 0 ]]; then
    command -v sudo >/dev/null || { echo "setup: run as root or install sudo" >&2; exit 1; }
    sudo_cmd=(sudo)
  fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: all ${#packages[@]} Debian packages present"
fi

jobs="$(nproc)"
cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build_dir" -j "$jobs"
echo "setup: built $build_dir/tools/dynaguide"
