#!/usr/bin/env bash
# Installs the Debian/Ubuntu packages cart2d builds and runs with, if any is missing.
set -euo pipefail

packages=(
  gcc-avr avr-libc binutils-avr avrdude   # firmware
  libsimavr-dev simavr libelf-dev         # simulator
  libturbojpeg0-dev libssl-dev            # simulator: the camera's JPEG frames, base64 (OpenSSL) for its frame lines
  arduino-core-avr                        # simulator: Optiboot, the Nano's bootloader (avrdude flashes through it)
  ser2net                                 # tests: the network serial link (RFC 2217)
  cmake ninja-build pkg-config            # host build
  clang libclang-rt-14-dev                # host tests, libFuzzer, sanitizers
  googletest libgtest-dev                 # unit tests
  python3 python3-venv                    # generators, gateway
  mosquitto                               # the fleet's MQTT broker (cart2d fleet sim, tests/fleet/)
  chromium                                # control panel's browser tests (Playwright, headless)
)
# The control panel's build (Vite 7) needs Node >= 20.19 with npm. Debian 12's nodejs is 18:
# it is installed only when there is no node at all, and checked below.
command -v node >/dev/null || packages+=(nodejs npm)

check_node() {
  local version
  version=$(node -p 'process.versions.node' 2>/dev/null || echo 0)
  if ! node -e 'const [a, b] = process.versions.node.split(".").map(Number);
                process.exit(a > 20 || (a === 20 && b >= 19) ? 0 : 1)' 2>/dev/null ||
     ! command -v npm >/dev/null; then
    echo "cart2d: the control panel needs Node.js >= 20.19 with npm (found ${version});" \
         "install Node 20 or 22 (e.g. from NodeSource) and run make again" >&2
    exit 1
  fi
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  check_node
  exit 0
fi

echo "Installing: ${missing[*]}"
sudo=""
[ "$(id -u)" -ne 0 ] && sudo="sudo"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
check_node
