/* A throwaway ATmega328P program that shows what its USART0 receiver saw, for the simulator's
 * UART tests (sim/tests/test_usart.cpp). USART0 at 115200 baud as the firmware sets it (U2X,
 * UBRR0 = 16: 117 647 baud), 8N1.
 *
 * The RX Complete interrupt logs every byte with the error flags read from UCSR0A before it
 * (datasheet §19.7.1: status first, then UDR0). The main loop reads the log as commands (a
 * byte logged with FE0 or UPE0 is noise, not a command):
 *  - 'b' then a digit N: interrupts off for N frame times (N · 10 · 136 cycles), then on again;
 *  - 'r': report every entry logged since the last report, this 'r' included, as
 *    "\nR <hex>[f][o][p] ... \n" (f: FE0, o: DOR0, p: UPE0);
 *  - 'x' is echoed as 'X' from the interrupt itself (round-trip timing);
 *  - 't': send the 100 bytes 0x20, 0x21, ... 0x83 back to back.
 * At start it sends "HELLO\n". Other bytes are only logged.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "uart.h"

#define FRAME_CYCLES 1360UL /* 10 bits of (16 + 1) · 8 cycles */

static volatile uint8_t log_data[256], log_flags[256];
static volatile uint8_t log_head; /* written by the interrupt only */

ISR(USART_RX_vect) {
  const uint8_t status = UCSR0A;
  const uint8_t c = UDR0;
  if (c == 'x') UDR0 = 'X';
  log_flags[log_head] = status & (_BV(FE0) | _BV(DOR0) | _BV(UPE0));
  log_data[log_head] = c;
  ++log_head;
}

static void report(uint8_t from, uint8_t to_inclusive) {
  put('\n');
  put('R');
  for (uint8_t i = from;; ++i) {
    put(' ');
    put_hex(log_data[i]);
    if (log_flags[i] & _BV(FE0)) put('f');
    if (log_flags[i] & _BV(DOR0)) put('o');
    if (log_flags[i] & _BV(UPE0)) put('p');
    if (i == to_inclusive) break;
  }
  put('\n');
}

static void block_interrupts(uint8_t frames) {
  cli();
  for (uint8_t i = 0; i < frames; ++i) __builtin_avr_delay_cycles(FRAME_CYCLES);
  sei();
}

int main(void) {
  uart_init();
  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
  for (const char* s = "HELLO\n"; *s; ++s) put(*s);

  uint8_t next = 0, report_from = 0;
  for (;;) {
    while (next != log_head) {
      const uint8_t c = (log_flags[next] & (_BV(FE0) | _BV(UPE0))) ? 0 : log_data[next];
      if (c == 'b') {
        while ((uint8_t)(next + 1) == log_head) {
        }
        block_interrupts((uint8_t)(log_data[(uint8_t)(next + 1)] - '0'));
        next += 2;
        continue;
      }
      if (c == 'r') {
        report(report_from, next);
        report_from = next + 1;
      } else if (c == 't') {
        for (uint8_t i = 0; i < 100; ++i) put((char)(0x20 + i));
      }
      ++next;
    }
    cli();
    if (next == log_head) {
      sleep_enable();
      sei();
      sleep_cpu();
      sleep_disable();
    }
    sei();
  }
}
