# The ATmega328P image, built with Debian's gcc-avr and avr-libc (no Arduino core).
# Included from the top-level Makefile; paths are relative to the repository root.

AVR_MCU      := atmega328p
AVR_F_CPU    := 16000000UL
AVR_BUILD    := build/firmware
AVR_GEN      := build/gen
AVR_ELF      := $(AVR_BUILD)/cart2d-nano.elf
AVR_HEX      := $(AVR_BUILD)/cart2d-nano.hex
AVR_SOURCES  := $(wildcard firmware/core/*.cpp) $(wildcard firmware/board/*.cpp) firmware/main.cpp
AVR_OBJECTS  := $(patsubst firmware/%.cpp,$(AVR_BUILD)/obj/%.o,$(AVR_SOURCES))
AVR_HEADERS  := $(AVR_GEN)/robot_params.hpp $(AVR_GEN)/protocol_table.hpp

AVR_CXXFLAGS := -mmcu=$(AVR_MCU) -DF_CPU=$(AVR_F_CPU) -std=gnu++14 -Os -g \
                -Wall -Wextra -Werror -fno-exceptions -fno-rtti -fno-threadsafe-statics \
                -ffunction-sections -fdata-sections -flto -mcall-prologues -mrelax -fno-split-wide-types -fno-move-loop-invariants -mstrict-X \
                '-DCORE_FLASH=__attribute__((__progmem__))' \
                -Ifirmware -Ifirmware/core -I$(AVR_GEN) -MMD -MP $(AVR_EXTRA_FLAGS)
AVR_LDFLAGS  := -mmcu=$(AVR_MCU) -Os -flto -mrelax -Wl,--gc-sections -Wl,-Map,$(AVR_BUILD)/cart2d-nano.map

$(AVR_GEN)/robot_params.hpp: config/robot.toml tools/gen_params.py cart2d/spec.py
	python3 tools/gen_params.py $< $@

$(AVR_GEN)/protocol_table.hpp: docs/protocol.md tools/gen_protocol.py cart2d/spec.py
	python3 tools/gen_protocol.py $< $@

$(AVR_BUILD)/obj/%.o: firmware/%.cpp $(AVR_HEADERS)
	@mkdir -p $(dir $@)
	avr-g++ $(AVR_CXXFLAGS) -c $< -o $@

$(AVR_ELF): $(AVR_OBJECTS)
	avr-g++ $(AVR_LDFLAGS) $^ -o $@ -lm

$(AVR_HEX): $(AVR_ELF)
	avr-objcopy -O ihex -R .eeprom $< $@

-include $(AVR_OBJECTS:.o=.d)
