/* A firmware that does not speak the protocol: it drives both motors forward at 50 % duty from
 * reset on and answers nothing. Built by tests/link/conftest.py with avr-gcc, uploaded as
 * an Intel HEX: it passes every check of the file (a real ATmega328P program below the
 * bootloader), and only the protocol check after flashing can tell it from a good firmware.
 *
 * Pins as in config/robot.toml: PWM on OC1A (D9, right) and OC1B (D10, left), Timer1 mode 8
 * (phase and frequency correct, TOP = ICR1 = 160: 50 kHz); DIRECTION D4/D5 low = forward. */
#include <avr/io.h>
#include <avr/wdt.h>

int main(void) {
  MCUSR = 0;
  wdt_disable(); /* a watchdog left on by the previous program would restart this one */
  DDRD |= _BV(PD4) | _BV(PD5);
  PORTD &= (uint8_t)~(_BV(PD4) | _BV(PD5));
  DDRB |= _BV(PB1) | _BV(PB2);
  ICR1 = 160;
  OCR1A = 80;
  OCR1B = 80;
  TCCR1A = _BV(COM1A1) | _BV(COM1B1);
  TCCR1B = _BV(WGM13) | _BV(CS10);
  for (;;) {
  }
}
