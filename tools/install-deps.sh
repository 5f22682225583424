#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages cart2d builds and runs with, if any is missing.
set -euo pipefail

packages=(
  gcc-avr avr-libc binutils-avr avrdude   # firmware
  libsimavr-dev simavr libelf-dev         # simulator
  cmake ninja-build pkg-config            # host build
  clang libclang-rt-14-dev                # host tests, libFuzzer, sanitizers
  googletest libgtest-dev                 # unit tests
  python3 python3-venv                    # generators, gateway
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "Installing: ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
