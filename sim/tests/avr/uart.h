/* What the AVR exercisers share: USART0 as the firmware sets it (115200 baud with U2X,
 * UBRR0 = 16, i.e. 117 647 baud; 8N1; the receive interrupt on) and blocking output. */
#ifndef CART2D_EXERCISER_UART_H
#define CART2D_EXERCISER_UART_H

#include <avr/io.h>
#include <stdint.h>

static inline void uart_init(void) {
  UBRR0 = 16;
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

static inline void put(char c) {
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = c;
}

static inline void put_hex(uint8_t v) {
  static const char digits[] = "0123456789ABCDEF";
  put(digits[v >> 4]);
  put(digits[v & 15]);
}

static inline void put_uint(uint32_t v) {
  char buf[11];
  uint8_t n = 0;
  do {
    buf[n++] = (char)('0' + v % 10);
    v /= 10;
  } while (v);
  while (n) put(buf[--n]);
}

static inline void put_int(int32_t v) {
  if (v < 0) {
    put('-');
    put_uint((uint32_t)0 - (uint32_t)v);
  } else {
    put_uint((uint32_t)v);
  }
}

#endif
