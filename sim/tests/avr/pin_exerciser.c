/* A throwaway ATmega328P program that exercises every pin the simulator drives or reads, in the
 * firmware's own way, so the simavr parts can be tested before (and independently of) the real
 * firmware. Built by sim/CMakeLists.txt with avr-gcc; driven by sim/tests/test_rig.cpp.
 *
 *  - Encoders: INT0/INT1 on ANY edge of A, B read in the ISR (robot.toml conventions:
 *    left forward when A != B after the edge, right forward when A == B).
 *  - Timer1 mode 8, ICR1 = 160: right (OC1A) duty 40/160 forward, left (OC1B) 120/160 backward.
 *  - Timer2 CTC at 125 Hz; its ISR burns exactly BURN_CYCLES cycles (CPU meter check).
 *  - Front switches D7/D8 with internal pull-ups.
 *  - USART0 115200 baud (U2X, UBRR0 = 16). Commands: 'c' report counts, 'x' echo 'X' from the RX
 *    ISR, 'o' PWM outputs off (COM bits cleared, pins low), 'w' write EEPROM byte 0 = 0x5A.
 *  - Idle sleep between interrupts.
 */
#include <avr/eeprom.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include <stdint.h>

#include "uart.h"

#define BURN_CYCLES 12800UL /* 10 % of the 128000-cycle tick */

static volatile int32_t left_count, right_count;
static volatile uint8_t report_pending, outputs_off, eeprom_pending;

ISR(INT0_vect) {
  const uint8_t a = (PIND >> PD2) & 1, b = (PINB >> PB3) & 1;
  if (a != b) ++left_count; else --left_count;
}

ISR(INT1_vect) {
  const uint8_t a = (PIND >> PD3) & 1, b = (PINB >> PB4) & 1;
  if (a == b) ++right_count; else --right_count;
}

/* Interrupts stay enabled while it burns, as a real control tick must allow: an ISR that blocks
 * for 0.8 ms would lose encoder edges (INTF0 holds one pending edge, not several). */
ISR(TIMER2_COMPA_vect, ISR_NOBLOCK) { __builtin_avr_delay_cycles(BURN_CYCLES); }

ISR(USART_RX_vect) {
  const uint8_t c = UDR0;
  if (c == 'x') UDR0 = 'X';
  else if (c == 'c') report_pending = 1;
  else if (c == 'o') outputs_off = 1;
  else if (c == 'w') eeprom_pending = 1;
}

int main(void) {
  /* H-bridges: PWM pins and direction pins as outputs; left backward (D4 high). */
  DDRB |= _BV(PB1) | _BV(PB2);
  DDRD |= _BV(PD4) | _BV(PD5);
  PORTD |= _BV(PD4);
  ICR1 = 160;
  OCR1A = 40;
  OCR1B = 120;
  TCCR1A = _BV(COM1A1) | _BV(COM1B1);
  TCCR1B = _BV(WGM13) | _BV(CS10);

  /* Switches: inputs with pull-ups. */
  PORTD |= _BV(PD7);
  PORTB |= _BV(PB0);

  /* Encoders: any edge on INT0/INT1. */
  EICRA = _BV(ISC00) | _BV(ISC10);
  EIMSK = _BV(INT0) | _BV(INT1);

  /* 125 Hz tick: 16 MHz / 1024 / 125. */
  OCR2A = 124;
  TCCR2A = _BV(WGM21);
  TCCR2B = _BV(CS22) | _BV(CS21) | _BV(CS20);
  TIMSK2 = _BV(OCIE2A);

  uart_init();

  set_sleep_mode(SLEEP_MODE_IDLE);
  sei();
  for (;;) {
    if (report_pending) {
      report_pending = 0;
      cli();
      const int32_t l = left_count, r = right_count;
      sei();
      put('L'); put('='); put_int(l);
      put(' '); put('R'); put('='); put_int(r);
      put(' '); put('S'); put('=');
      put((PIND & _BV(PD7)) ? '0' : '1');
      put((PINB & _BV(PB0)) ? '0' : '1');
      put('\n');
    }
    if (outputs_off) {
      outputs_off = 0;
      TCCR1A = 0;
      PORTB &= (uint8_t)~(_BV(PB1) | _BV(PB2));
    }
    if (eeprom_pending) {
      eeprom_pending = 0;
      eeprom_write_byte((uint8_t*)0, 0x5A);
    }
    sleep_mode();
  }
}
