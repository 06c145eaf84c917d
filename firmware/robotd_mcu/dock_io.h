// Docking I/O of the robotd motor board: a 74HC595 shift register for outputs and a 74HC4051
// analog multiplexer for the docking sensors, on the three analog pins the Uno had left.
//
// The Uno's 20 I/O pins were all taken (docs/firmware.md), so the board gains two chips:
//   74HC595 on A3 (SER), A4 (SRCLK), A5 (RCLK): Q0 left eye, Q1 right eye, Q2 red status LED
//     (they were on A3-A5 directly), Q3 EVAC, Q4-Q6 the 4051's S0-S2, Q7 unused.
//   74HC4051 common (Z) on A2 (ADC2), selected by Q4-Q6:
//     0 charging contacts through a 100k/20k divider (1/6: 30 V full scale; 14-19 V on a dock)
//     1 front-left dock receiver strength, 2 front-right: the receivers' envelope detector
//       (0-5 V, stronger beam = higher), read as raw 10-bit counts
//     3 right-side wall sensor, Sharp GP2Y0A41SK0F (4-30 cm)
//     4 dust bin fill sensor: 0.5 V empty to 4.5 V full, linear
//     5 / 6 left / right bumper switch to 5 V, 10k pull-down (pressed: 5 V)
//     7 tied to GND
// EVAC (Q3) drives a logic-level MOSFET that puts a 1 kOhm signalling load across the
// charging contacts; the station sees the current step and runs its suction while it lasts.
// The 4051 (about 100 Ohm on) and low-impedance sources need no dummy conversion after a
// switch; the 595's outputs hold through an MCU reset until setup() writes them.
#ifndef ROBOTD_DOCK_IO_H
#define ROBOTD_DOCK_IO_H

#include <Arduino.h>

const uint8_t PIN_MUX = A2;        // 74HC4051 common Z
const uint8_t SR_DATA_BIT = PC3;   // A3: 74HC595 SER
const uint8_t SR_CLOCK_BIT = PC4;  // A4: 74HC595 SRCLK (shifts on the rising edge)
const uint8_t SR_LATCH_BIT = PC5;  // A5: 74HC595 RCLK (outputs follow on the rising edge)
const uint8_t SR_EYE_L = 0x01;
const uint8_t SR_EYE_R = 0x02;
const uint8_t SR_LED_FAIL = 0x04;
const uint8_t SR_EVAC = 0x08;
const uint8_t SR_MUX_SHIFT = 4;
const uint8_t SR_MUX_MASK = 0x70;

enum MuxChannel : uint8_t { MUX_CONTACTS = 0, MUX_IRS_L = 1, MUX_IRS_R = 2, MUX_WALL = 3,
                            MUX_BIN = 4, MUX_BUMP_L = 5, MUX_BUMP_R = 6 };

const uint32_t CONTACT_DIVIDER = 6;    // contact mV = Z mV x 6
const uint16_t DOCK_PRESENT_MV = 5000;  // BAT's dock flag: something powers the contacts
const int16_t WALL_K = 2076;           // GP2Y0A41SK0F: cm = WALL_K / (adc - WALL_ADC_OFFSET)
const int16_t WALL_ADC_OFFSET = 11;
const uint8_t WALL_MIN_CM = 4;          // the sensor's rated span; 30 means "30 or more"
const uint8_t WALL_MAX_CM = 30;
const uint16_t BIN_EMPTY_MV = 500;
const uint16_t BIN_FULL_MV = 4500;

static uint8_t sr_bits = 0;

// Shifts bits out MSB first (bit i lands on Qi) and latches them. Direct port writes (sbi/cbi,
// atomic; nothing else writes PORTC from an interrupt): about 3 us for the byte.
static void sr_write(uint8_t bits) {
  for (int8_t i = 7; i >= 0; i--) {
    if (bits & (uint8_t)(1u << i)) PORTC |= _BV(SR_DATA_BIT); else PORTC &= ~_BV(SR_DATA_BIT);
    PORTC |= _BV(SR_CLOCK_BIT);
    PORTC &= ~_BV(SR_CLOCK_BIT);
  }
  PORTC |= _BV(SR_LATCH_BIT);
  PORTC &= ~_BV(SR_LATCH_BIT);
  sr_bits = bits;
}

static void sr_set(uint8_t mask, uint8_t value) {
  uint8_t bits = (uint8_t)((sr_bits & ~mask) | (value & mask));
  if (bits != sr_bits) sr_write(bits);
}

static void dock_io_begin() {
  DDRC |= _BV(SR_DATA_BIT) | _BV(SR_CLOCK_BIT) | _BV(SR_LATCH_BIT);
  pinMode(PIN_MUX, INPUT);
  sr_write(0);  // eyes and red off, EVAC off, mux on the contacts
}

static uint16_t mux_read(MuxChannel channel) {
  sr_set(SR_MUX_MASK, (uint8_t)(channel << SR_MUX_SHIFT));
  uint16_t sum = (uint16_t)analogRead(PIN_MUX);
  sum += (uint16_t)analogRead(PIN_MUX);
  return (uint16_t)(sum / 2u);
}

static uint16_t adc_to_mv(uint16_t adc) { return (uint16_t)((uint32_t)adc * 5000u / 1023u); }

static uint16_t contact_mv() {
  return (uint16_t)((uint32_t)mux_read(MUX_CONTACTS) * 5000u * CONTACT_DIVIDER / 1023u);
}

static uint8_t wall_cm() {
  int16_t adc = (int16_t)mux_read(MUX_WALL);
  if (adc - WALL_ADC_OFFSET <= 0) return WALL_MAX_CM;
  int16_t cm = (int16_t)(WALL_K / (adc - WALL_ADC_OFFSET));
  if (cm < WALL_MIN_CM) cm = WALL_MIN_CM;
  if (cm > WALL_MAX_CM) cm = WALL_MAX_CM;
  return (uint8_t)cm;
}

static uint8_t bin_pct() {
  uint16_t mv = adc_to_mv(mux_read(MUX_BIN));
  if (mv <= BIN_EMPTY_MV) return 0;
  if (mv >= BIN_FULL_MV) return 100;
  return (uint8_t)((uint32_t)(mv - BIN_EMPTY_MV) * 100u / (BIN_FULL_MV - BIN_EMPTY_MV));
}

// Bit 0 left, bit 1 right: pressed when the switch pulls Z above half the supply.
static uint8_t bumpers_read() {
  return (uint8_t)((mux_read(MUX_BUMP_L) > 511 ? 1 : 0) | (mux_read(MUX_BUMP_R) > 511 ? 2 : 0));
}

#endif  // ROBOTD_DOCK_IO_H
