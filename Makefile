# cart2d — top-level build. `make run` and `make test` are the two commands a user needs.
SHELL := /bin/bash
.DEFAULT_GOAL := help

PORT ?= /dev/ttyUSB0
FLASH_BAUD ?= 115200   # Nano with the new (Optiboot) bootloader; 57600 for the old one
FUZZ_SECONDS ?= 300

include firmware/avr.mk

HOST_BUILD := build/host
SIM_BUILD := build/sim
SIM_BIN := $(SIM_BUILD)/cart2d-sim
VENV := build/venv
PY := $(VENV)/bin/python
PANEL := cart2d/panel/index.html
PANEL_SOURCES := $(shell find web/src -type f 2>/dev/null) web/index.html web/vite.config.ts web/tsconfig.json docs/protocol.md

.PHONY: help deps firmware flash host-tests fuzz fuzz-quick sim sim-tests python-env python-checks python-tests panel panel-tests test bench-firmware bench-sim profile-firmware bench bench-quick run clean

help:
	@echo "make run             install what is missing, build, start cart2d"
	@echo "make test            build everything and run all tests"
	@echo "make firmware        build $(AVR_HEX) and print its size"
	@echo "make sim             build the simulator ($(SIM_BIN))"
	@echo "make flash PORT=...  flash the Nano with avrdude"
	@echo "make bench-firmware  flash, RAM and CPU per control tick against the budgets"
	@echo "make bench-sim       the simulator's speed, API round trip, telemetry latency, 50 viewers"
	@echo "make profile-firmware  cycles per control tick by function (simavr)"
	@echo "make bench           every benchmark (~7 min): bench/results/REPORT.md with plots"
	@echo "make bench-quick     the benchmarks' CI subset, into build/bench-quick/"
	@echo "make panel           build the control panel (web/) into cart2d/panel/"
	@echo "make panel-tests     the panel in headless Chromium against the simulator"
	@echo "make fuzz            fuzz the packet parser and dispatcher for $(FUZZ_SECONDS) s"

deps:
	@tools/install-deps.sh

firmware: $(AVR_HEX)
	@avr-size $(AVR_ELF)

flash: $(AVR_HEX)
	avrdude -p m328p -c arduino -P $(PORT) -b $(FLASH_BAUD) -D -U flash:w:$(AVR_HEX):i

$(HOST_BUILD)/build.ninja: firmware/CMakeLists.txt
	cmake -S firmware -B $(HOST_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Debug \
	      -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang

host-tests: $(HOST_BUILD)/build.ninja
	cmake --build $(HOST_BUILD)
	ctest --test-dir $(HOST_BUILD) --output-on-failure

$(SIM_BUILD)/build.ninja: sim/CMakeLists.txt
	cmake -S sim -B $(SIM_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release

sim: $(SIM_BUILD)/build.ninja
	cmake --build $(SIM_BUILD)

sim-tests: sim firmware
	ctest --test-dir $(SIM_BUILD) --output-on-failure

$(VENV)/.installed: pyproject.toml
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $@

python-env: $(VENV)/.installed

python-checks: python-env
	$(VENV)/bin/ruff check cart2d tests bench tools
	$(VENV)/bin/ruff format --check cart2d tests bench tools
	$(VENV)/bin/mypy
	$(VENV)/bin/lint-imports

python-tests: python-env firmware sim panel
	$(PY) -m pytest -q

# The control panel: npm ci (exact versions from web/package-lock.json; browsers are never
# downloaded: the tests use Debian's /usr/bin/chromium), a type check and the Vite build.
web/node_modules/.installed: web/package.json web/package-lock.json
	cd web && PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1 npm ci --no-audit --no-fund
	touch $@

$(PANEL): web/node_modules/.installed $(PANEL_SOURCES)
	cd web && npm run build

panel: $(PANEL)

panel-tests: panel python-env firmware sim
	cd web && npx playwright test

fuzz-quick: host-tests
	tools/run-fuzz.sh $(HOST_BUILD)/fuzz_packets 30

fuzz: host-tests
	tools/run-fuzz.sh $(HOST_BUILD)/fuzz_packets $(FUZZ_SECONDS)

test: deps firmware host-tests sim-tests python-checks python-tests panel-tests fuzz-quick bench-quick

bench-firmware: $(AVR_ELF) sim python-env
	@$(PY) -m bench.firmware --quick --out build/bench-firmware

bench-sim: $(AVR_ELF) sim python-env panel
	@$(PY) -m bench.system --quick --out build/bench-system

bench: $(AVR_ELF) sim python-env panel
	$(PY) -m bench.report --out bench/results

bench-quick: $(AVR_ELF) sim python-env panel
	$(PY) -m bench.report --quick --out build/bench-quick

profile-firmware: $(AVR_ELF) sim python-env
	@$(PY) -m bench.firmware_profile

run: deps firmware sim python-env panel
	@$(VENV)/bin/cart2d sim

clean:
	rm -rf build
