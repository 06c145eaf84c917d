// Serial-link helpers for the robotd motor board: CRC-8 and small bounded text parsers.
// Pure functions over char buffers (no heap, no String), shared by the sketch's command parser
// and telemetry writer. Contract: DESIGN.md "Serial link to the Arduino".
#ifndef ROBOTD_LINK_H
#define ROBOTD_LINK_H

#include <stdint.h>
#include <stddef.h>
#include <string.h>

// CRC-8, polynomial 0x07, init 0x00, not reflected, no final xor ("123456789" -> 0xF4).
static inline uint8_t crc8_update(uint8_t crc, uint8_t byte) {
  crc ^= byte;
  for (uint8_t bit = 0; bit < 8; bit++) {
    crc = (crc & 0x80) ? (uint8_t)((crc << 1) ^ 0x07) : (uint8_t)(crc << 1);
  }
  return crc;
}

static inline uint8_t crc8(const char *data, size_t len) {
  uint8_t crc = 0;
  for (size_t i = 0; i < len; i++) crc = crc8_update(crc, (uint8_t)data[i]);
  return crc;
}

static inline int8_t hex_value(char c) {
  if (c >= '0' && c <= '9') return (int8_t)(c - '0');
  if (c >= 'A' && c <= 'F') return (int8_t)(c - 'A' + 10);
  if (c >= 'a' && c <= 'f') return (int8_t)(c - 'a' + 10);
  return -1;
}

static const char HEX_DIGITS[] = "0123456789ABCDEF";

// Outcome of parsing a number field: OK, syntax error (PARSE) or out of range (RANGE).
enum FieldStatus { FIELD_OK = 0, FIELD_PARSE = 1, FIELD_RANGE = 2 };

// Parses a decimal integer at *p (optional '-', 1..6 digits) and checks lo <= value <= hi.
// Advances *p past the digits. More than 6 digits counts as out of range, not garbage.
static inline uint8_t parse_int(const char **p, int32_t lo, int32_t hi, int32_t *out) {
  const char *s = *p;
  bool negative = false;
  if (*s == '-') {
    negative = true;
    s++;
  }
  if (*s < '0' || *s > '9') return FIELD_PARSE;
  int32_t value = 0;
  uint8_t digits = 0;
  bool too_long = false;
  while (*s >= '0' && *s <= '9') {
    if (digits < 6) {
      value = value * 10 + (*s - '0');
    } else {
      too_long = true;
    }
    digits++;
    s++;
  }
  *p = s;
  if (negative) value = -value;
  if (too_long || value < lo || value > hi) return FIELD_RANGE;
  *out = value;
  return FIELD_OK;
}

// Writes the decimal text of value at dst; returns the number of chars written (no NUL).
static inline uint8_t put_int(char *dst, int32_t value) {
  char tmp[12];
  uint8_t n = 0;
  uint32_t mag = value < 0 ? (uint32_t)(-(value + 1)) + 1u : (uint32_t)value;
  do {
    tmp[n++] = (char)('0' + (mag % 10u));
    mag /= 10u;
  } while (mag != 0u);
  uint8_t len = 0;
  if (value < 0) dst[len++] = '-';
  while (n > 0) dst[len++] = tmp[--n];
  return len;
}

#endif  // ROBOTD_LINK_H
