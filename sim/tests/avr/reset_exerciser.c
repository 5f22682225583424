/* A throwaway ATmega328P program for the simulator's reset, EEPROM and hang models, driven by
 * sim/tests/test_resets.cpp over the UART (115200 baud, U2X, UBRR0 = 16). Built by
 * sim/CMakeLists.txt with avr-gcc.
 *
 * At boot (.init3) it keeps MCUSR in .noinit and clears it only when WDRF is set (the watchdog
 * cannot be stopped otherwise), and counts boots in .noinit behind a magic word, so the test sees
 * which resets keep the SRAM. Timer1 mode 8 drives both bridges forward at 40/160.
 * Commands (answered from the main loop unless said otherwise):
 *  'r'  report "M=<MCUSR at boot, hex> N=<boots since the SRAM was lost> E=<EE_READY count>\n"
 *  'x'  echo 'X' from the RX interrupt (works even when the main loop hangs)
 *  'c'  clear MCUSR
 *  'w'  watchdog reset: wdt_enable(15 ms) and wait with interrupts off (the firmware's REBOOT)
 *  'e'  start writing 0x5A to EEPROM address 0x10 (avr-libc: returns once the write started)
 *  'b'  write 0x11 0x22 0x33 0x44 to addresses 0x20-0x23, each after polling EEPE
 *  'p'  start a write to 0x30, then at once try to read address 0x10 (EERE while busy)
 *  's'  EEPE 6 cycles after EEMPE (too late): no write
 *  'o'  write-only mode (EEPM = 10) of 0x0F at 0x10
 *  'i'  enable EERIE with the EEPROM idle: a level interrupt fires until its handler (third
 *       time) clears EERIE
 */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <avr/wdt.h>
#include <stdint.h>

#include "uart.h"

#define MAGIC 0xC0FFEE42UL

static uint8_t boot_mcusr __attribute__((section(".noinit")));
static uint32_t magic __attribute__((section(".noinit")));
static uint16_t boots __attribute__((section(".noinit")));

static volatile uint8_t command;
static volatile uint8_t ee_ready_count;

void keep_mcusr(void) __attribute__((naked, used, section(".init3")));
void keep_mcusr(void) {
  boot_mcusr = MCUSR;
  if (MCUSR & _BV(WDRF)) {
    MCUSR &= (uint8_t)~_BV(WDRF);
    wdt_disable();
  }
}

ISR(USART_RX_vect) {
  const uint8_t c = UDR0;
  if (c == 'x') UDR0 = 'X';
  else command = c;
}

ISR(EE_READY_vect) {
  if (++ee_ready_count == 3) EECR &= (uint8_t)~_BV(EERIE);
}

static void report(void) {
  put('M'); put('='); put_hex(boot_mcusr);
  put(' '); put('N'); put('='); put_uint(boots);
  put(' '); put('E'); put('='); put_uint(ee_ready_count);
  put('\n');
}

static void read_while_busy(void) {
  eeprom_write_byte((uint8_t*)0x30, 0x77);
  EEAR = 0x10;  /* ignored while programming */
  EECR |= _BV(EERE);
}

static void strobe_too_late(void) {
  EEAR = 0x12;
  EEDR = 0x99;
  cli();
  EECR |= _BV(EEMPE);
  __builtin_avr_delay_cycles(6);
  EECR |= _BV(EEPE);
  sei();
}

static void write_only(void) {
  eeprom_busy_wait();
  EEAR = 0x10;
  EEDR = 0x0F;
  cli();
  EECR = _BV(EEPM1) | _BV(EEMPE);
  EECR |= _BV(EEPE);
  sei();
}

static void run(uint8_t c) {
  static const uint8_t block[4] = {0x11, 0x22, 0x33, 0x44};
  switch (c) {
    case 'r': report(); break;
    case 'c': MCUSR = 0; break;
    case 'w': cli(); wdt_enable(WDTO_15MS); for (;;) {} break;
    case 'e': eeprom_write_byte((uint8_t*)0x10, 0x5A); break;
    case 'b': eeprom_write_block(block, (void*)0x20, sizeof block); break;
    case 'p': read_while_busy(); break;
    case 's': strobe_too_late(); break;
    case 'o': write_only(); break;
    case 'i': EECR |= _BV(EERIE); break;
    default: break;
  }
}

int main(void) {
  if (magic != MAGIC) {  /* the SRAM was lost (power-on, brown-out) */
    magic = MAGIC;
    boots = 0;
  }
  ++boots;

  DDRB |= _BV(PB1) | _BV(PB2);  /* PWM: right OC1A, left OC1B */
  DDRD |= _BV(PD4) | _BV(PD5);  /* DIRECTION, low = forward */
  ICR1 = 160;
  OCR1A = 40;
  OCR1B = 40;
  TCCR1A = _BV(COM1A1) | _BV(COM1B1);
  TCCR1B = _BV(WGM13) | _BV(CS10);

  uart_init();

  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
  for (;;) {
    cli();
    const uint8_t c = command;
    command = 0;
    sei();
    if (c) run(c);
    sleep_mode();
  }
}
