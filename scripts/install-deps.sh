#!/usr/bin/env bash
# Installs the Debian 12 packages scanbench needs to build, test and run.
# Does nothing when all are present; needs root (or sudo) otherwise.
set -euo pipefail

packages=(
  g++ cmake ninja-build pkg-config ccache git ca-certificates
  libeigen3-dev
  libopencv-dev
  libopencv-contrib-dev  # opencv_mcc: ColorChecker detection and colour correction (calibration/color_calibration.cc)
  libraw-dev
  libtiff-dev
  libopenimageio-dev openimageio-tools  # OpenImageIO's CMake config checks for its tools
  libssl-dev
  nlohmann-json3-dev
  libcli11-dev
  libgtest-dev libgmock-dev
  libbenchmark-dev
  gcc-avr binutils-avr avr-libc arduino-core-avr libsimavr-dev libelf-dev libserialport-dev clang libclang-rt-14-dev  # LED board: firmware (avr-gcc, Arduino core), simavr firmware-in-the-loop, serial port listing, libFuzzer
  libmatio-dev  # solver datasets: reads DiLiGenT's Normal_gt.mat (MATLAB v5/v7.3)
  qt6-base-dev xvfb xauth  # operator GUI (app/gui): Qt 6 Widgets; xvfb-run for scripts/gui-screenshots.sh
  chromium  # export's preview.html: tests/app/io/preview_page_test.cc renders it headless (WebGL via SwiftShader); skipped without it
  libgphoto2-dev libgphoto2-6 libgphoto2-port12 libusb-1.0-0-dev  # camera: libgphoto2 backend (libgphoto2-6 has the camera drivers incl. "Directory Browse" used by the tests, -port12 the usb and disk ports), libusb device discovery and hotplug
  libexpat1-dev  # export test: parses the MaterialX .mtlx as XML
  slurm-wlm munge  # batch test: docs/batch.md's Slurm job array on a single-node Slurm of its own (tests/app/cli/slurm_batch_test.sh); Debian's slurmctld and slurmd services do not start without /etc/slurm/slurm.conf
)
# Node and npm run the Khronos glTF-Validator of the export test (tests/web, npm
# gltf-validator); by command, as a Node from another source is as good as Debian's.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
echo "install-deps: installing ${missing[*]}"
$sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
$sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
