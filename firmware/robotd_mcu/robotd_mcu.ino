// robotd motor board: Arduino Uno (ATmega328P, 16 MHz) firmware for the robotd serial link.
//
// Speaks DESIGN.md "Serial link to the Arduino": CRC framing (`#SEQ PAYLOAD*CC`) and the
// seed's plain lines, detected per line. Drives an L298N-style H-bridge, the box servo and the
// LED eyes; counts two quadrature encoders; reads a Sharp IR range sensor and the battery;
// for docking reads the dock receivers' strength, the contact voltage, bumpers, a wall sensor
// and the bin level, and signals the station's suction (EVAC) (dock_io.h); sends telemetry at
// fixed rates; stops the motors 500 ms after the last MOTOR/HB. No heap: fixed buffers only.
// Documentation: docs/firmware.md.
#include <Arduino.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include "link.h"
#include "dock_io.h"

// ---- pin map (Arduino Uno) -----------------------------------------------------------------
const uint8_t PIN_ENC_L_A = 2;    // INT0
const uint8_t PIN_ENC_R_A = 3;    // INT1
const uint8_t PIN_ENC_L_B = 4;    // PD4, PCINT20
const uint8_t PIN_PWM_L = 5;      // L298N ENA, OC0B (Timer0 fast PWM, 976 Hz)
const uint8_t PIN_PWM_R = 6;      // L298N ENB, OC0A
const uint8_t PIN_ENC_R_B = 7;    // PD7, PCINT23
const uint8_t PIN_L_IN1 = 8;      // L298N IN1
const uint8_t PIN_SERVO = 9;      // OC1A: Timer1 makes the 50 Hz servo pulse in hardware
const uint8_t PIN_L_IN2 = 10;     // L298N IN2 (plain GPIO: OC1B stays disconnected)
const uint8_t PIN_R_IN1 = 11;     // L298N IN3
const uint8_t PIN_R_IN2 = 12;     // L298N IN4
const uint8_t PIN_LED_OK = 13;    // green status LED (on-board LED)
const uint8_t PIN_IR = A0;        // Sharp GP2Y0A02 analog output
const uint8_t PIN_BATTERY = A1;   // battery through a 20k/10k divider (1/3)
// A2-A5: the docking multiplexer and the shift register for the eyes, red LED and EVAC
// (dock_io.h). A2 was the dock contacts' digital input: they are now measured through the mux.

// ---- constants -----------------------------------------------------------------------------
#define FIRMWARE_ID "robotd-mcu-1.1.0"
const uint8_t PROTOCOL_VERSION = 1;
const uint32_t BAUD = 115200;
const uint8_t LINE_MAX = 64;                // bytes per line including '\n' (contract)
const uint32_t DEADMAN_US = 500000UL;      // motors stop this long after the last MOTOR/HB
const uint16_t ENCODER_PERIOD_MS = 50;      // 20 Hz
const uint16_t IR_PERIOD_MS = 200;          // 5 Hz
const uint16_t BAT_PERIOD_MS = 200;         // 5 Hz
const uint16_t IRS_PERIOD_MS = 50;          // 20 Hz; the bumpers are sampled with it
const uint16_t DOCK_PERIOD_MS = 200;        // 5 Hz
const uint16_t WALL_PERIOD_MS = 100;        // 10 Hz
const uint16_t BIN_PERIOD_MS = 1000;        // 1 Hz
const uint16_t BUMP_PERIOD_MS = 1000;       // 1 Hz, and at once on a change
const uint16_t SERVO_MIN_US = 544;          // 0 degrees (same span as Arduino's Servo library)
const uint16_t SERVO_MAX_US = 2400;         // 180 degrees
const uint16_t SERVO_PERIOD_TICKS = 40000;  // 20 ms at 16 MHz / 8
const uint32_t BAT_DIVIDER = 3;             // battery mV = A1 mV * 3
const uint16_t BAT_EMPTY_MV = 9600;         // 3S Li-ion pack: 0 %
const uint16_t BAT_FULL_MV = 12600;         // 100 %
const int32_t IR_K = 9462;                  // GP2Y0A02: cm = IR_K / (adc - IR_ADC_OFFSET)
const int16_t IR_ADC_OFFSET = 17;
const uint8_t IR_MIN_CM = 20;               // the sensor's rated span
const uint8_t IR_MAX_CM = 150;
const bool ENC_L_INVERT = false;            // set for a mirrored motor/encoder mount
const bool ENC_R_INVERT = false;

// ---- state ---------------------------------------------------------------------------------
enum Framing : uint8_t { FRAMING_CRC, FRAMING_PLAIN };
enum Reply : uint8_t { REPLY_ACK, REPLY_HELLO, REPLY_NAK_PARSE, REPLY_NAK_RANGE };
enum Anim : uint8_t { ANIM_IDLE, ANIM_WAITING, ANIM_MOVING, ANIM_SUCCESS, ANIM_FAILURE };

static char line_buf[LINE_MAX];       // one line without '\n', NUL-terminated
static uint8_t line_len = 0;
static bool line_overlong = false;
static bool line_binary = false;       // a control or non-ASCII byte: never a valid command
static Framing framing = FRAMING_CRC;  // framing of telemetry: that of the last good command
static bool have_last = false;         // duplicate suppression: last executed SEQ and CRC
static uint8_t last_seq = 0;
static uint8_t last_crc = 0;
static uint32_t last_drive_us = 0;
static bool motors_on = false;
static Anim base_anim = ANIM_IDLE;     // animation to return to after a one-shot effect
static Anim anim = ANIM_IDLE;
static uint32_t anim_start_ms = 0;
static uint32_t next_encoder_ms = 0;
static uint32_t next_ir_ms = 20;
static uint32_t next_bat_ms = 120;
static uint32_t next_irs_ms = 10;
static uint32_t next_dock_ms = 70;
static uint32_t next_wall_ms = 30;
static uint32_t next_bin_ms = 170;
static uint32_t next_bump_ms = 90;
static uint8_t bumpers = 0;            // as last sampled (bit 0 left, bit 1 right)
static uint8_t bumpers_sent = 0xFF;    // as last sent: none yet
static uint8_t loop_marker = 0;

volatile int32_t enc_ticks[2] = {0, 0};
volatile uint8_t enc_state[2] = {0, 0};

// Quadrature decoding, indexed by (previous AB << 2) | current AB. A leading B counts up.
static const int8_t QUAD_STEP[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};

// ---- encoders ------------------------------------------------------------------------------
static inline uint8_t read_ab(uint8_t pind, uint8_t a_bit, uint8_t b_bit) {
  return (uint8_t)((((pind >> a_bit) & 1u) << 1) | ((pind >> b_bit) & 1u));
}

// Called from every encoder interrupt: reads both encoders at once, so an edge that another
// interrupt already accounted for adds nothing.
static void encoders_update() {
  uint8_t pind = PIND;
  uint8_t now[2] = {read_ab(pind, 2, 4), read_ab(pind, 3, 7)};
  for (uint8_t side = 0; side < 2; side++) {
    int8_t step = QUAD_STEP[(enc_state[side] << 2) | now[side]];
    bool invert = side == 0 ? ENC_L_INVERT : ENC_R_INVERT;
    enc_ticks[side] += invert ? -step : step;
    enc_state[side] = now[side];
  }
}

ISR(PCINT2_vect) { encoders_update(); }

static void encoders_begin() {
  pinMode(PIN_ENC_L_A, INPUT_PULLUP);
  pinMode(PIN_ENC_L_B, INPUT_PULLUP);
  pinMode(PIN_ENC_R_A, INPUT_PULLUP);
  pinMode(PIN_ENC_R_B, INPUT_PULLUP);
  uint8_t pind = PIND;
  enc_state[0] = read_ab(pind, 2, 4);
  enc_state[1] = read_ab(pind, 3, 7);
  attachInterrupt(digitalPinToInterrupt(PIN_ENC_L_A), encoders_update, CHANGE);
  attachInterrupt(digitalPinToInterrupt(PIN_ENC_R_A), encoders_update, CHANGE);
  PCMSK2 |= _BV(PCINT20) | _BV(PCINT23);
  PCICR |= _BV(PCIE2);
}

static void encoders_read(int32_t *left, int32_t *right) {
  uint8_t sreg = SREG;
  cli();
  *left = enc_ticks[0];
  *right = enc_ticks[1];
  SREG = sreg;
}

// ---- motors and servo ----------------------------------------------------------------------
static void motor_side(uint8_t pwm_pin, uint8_t in1, uint8_t in2, uint8_t duty, bool forward) {
  if (duty == 0) {
    analogWrite(pwm_pin, 0);
    digitalWrite(in1, LOW);  // both low: the L298N lets the motor coast
    digitalWrite(in2, LOW);
    return;
  }
  digitalWrite(in1, forward ? HIGH : LOW);
  digitalWrite(in2, forward ? LOW : HIGH);
  analogWrite(pwm_pin, duty);
}

static void motors_set(uint8_t left, uint8_t right, bool left_fwd, bool right_fwd) {
  motor_side(PIN_PWM_L, PIN_L_IN1, PIN_L_IN2, left, left_fwd);
  motor_side(PIN_PWM_R, PIN_R_IN1, PIN_R_IN2, right, right_fwd);
  motors_on = left != 0 || right != 0;
}

static void motors_stop() { motors_set(0, 0, true, true); }

// Timer1 in fast PWM mode 14 (TOP = ICR1), prescaler 8: 0.5 us ticks, 20 ms period. OC1A
// (pin 9) is connected only once a SERVO command arrives, so the servo stays limp until then.
static void servo_begin() {
  pinMode(PIN_SERVO, OUTPUT);
  digitalWrite(PIN_SERVO, LOW);
  TCCR1B = 0;  // stopped while TOP and the compare value are set, then started
  TCCR1A = _BV(WGM11);
  ICR1 = SERVO_PERIOD_TICKS - 1;
  OCR1A = 0;
  TCNT1 = 0;
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
}

static void servo_write(uint8_t angle_deg) {
  uint32_t pulse_us = SERVO_MIN_US + (uint32_t)angle_deg * (SERVO_MAX_US - SERVO_MIN_US) / 180u;
  uint8_t sreg = SREG;
  cli();
  OCR1A = (uint16_t)(pulse_us * 2u);
  SREG = sreg;
  TCCR1A |= _BV(COM1A1);
}

// ---- LED eyes ------------------------------------------------------------------------------
// Bits: 0 left eye, 1 right eye, 2 green status, 3 red status.
static uint8_t anim_frame(Anim a, uint32_t t_ms) {
  switch (a) {
    case ANIM_IDLE:  // eyes open, a short blink every 4 s
      return (t_ms % 4000u) < 3850u ? 0x03 : 0x00;
    case ANIM_WAITING:  // eyes look left and right, 1 Hz
      return (t_ms % 1000u) < 500u ? 0x01 : 0x02;
    case ANIM_MOVING:  // eyes blink together, 4 Hz
      return (t_ms % 250u) < 125u ? 0x03 : 0x00;
    case ANIM_SUCCESS:  // green on, three slow eye flashes
      return (uint8_t)(0x04 | ((t_ms % 500u) < 250u ? 0x03 : 0x00));
    case ANIM_FAILURE:  // red on, fast eye flicker
      return (uint8_t)(0x08 | ((t_ms % 125u) < 62u ? 0x03 : 0x00));
  }
  return 0;
}

const uint16_t EFFECT_MS = 1500;  // SUCCESS_SCAN / FAILURE_SCAN last this long

static void anim_start(Anim a, uint32_t now_ms) {
  if (a != ANIM_SUCCESS && a != ANIM_FAILURE) base_anim = a;
  anim = a;
  anim_start_ms = now_ms;
}

const uint8_t LED_REFRESH_MS = 10;

static void leds_update(uint32_t now_ms) {
  static uint32_t refreshed_ms = 0;
  if (now_ms - refreshed_ms < LED_REFRESH_MS) return;
  refreshed_ms = now_ms;
  uint32_t t_ms = now_ms - anim_start_ms;
  if ((anim == ANIM_SUCCESS || anim == ANIM_FAILURE) && t_ms >= EFFECT_MS) {
    anim = base_anim;
    anim_start_ms = now_ms;
    t_ms = 0;
  }
  uint8_t bits = anim_frame(anim, t_ms);
  sr_set(SR_EYE_L | SR_EYE_R | SR_LED_FAIL,
         (uint8_t)((bits & 0x01 ? SR_EYE_L : 0) | (bits & 0x02 ? SR_EYE_R : 0) |
                   (bits & 0x08 ? SR_LED_FAIL : 0)));
  digitalWrite(PIN_LED_OK, (bits & 0x04) ? HIGH : LOW);
}

// ---- sensors -------------------------------------------------------------------------------
static uint16_t adc_average(uint8_t pin) {
  uint16_t sum = 0;
  for (uint8_t i = 0; i < 4; i++) sum += (uint16_t)analogRead(pin);
  return (uint16_t)(sum / 4u);
}

static uint8_t ir_distance_cm() {
  int16_t adc = (int16_t)adc_average(PIN_IR);
  if (adc - IR_ADC_OFFSET <= 0) return IR_MAX_CM;
  int32_t cm = IR_K / (adc - IR_ADC_OFFSET);
  if (cm < IR_MIN_CM) cm = IR_MIN_CM;
  if (cm > IR_MAX_CM) cm = IR_MAX_CM;
  return (uint8_t)cm;
}

static uint16_t battery_mv() {
  return (uint16_t)((uint32_t)adc_average(PIN_BATTERY) * 5000u * BAT_DIVIDER / 1023u);
}

static uint8_t battery_pct(uint16_t mv) {
  if (mv <= BAT_EMPTY_MV) return 0;
  if (mv >= BAT_FULL_MV) return 100;
  return (uint8_t)((uint32_t)(mv - BAT_EMPTY_MV) * 100u / (BAT_FULL_MV - BAT_EMPTY_MV));
}

// ---- output --------------------------------------------------------------------------------
// Sends body (with room for 4 more bytes in buf) as one line in the current framing.
static void send_line(char *buf, uint8_t len, Framing f) {
  if (f == FRAMING_CRC) {
    uint8_t crc = crc8(buf, len);
    buf[len++] = '*';
    buf[len++] = HEX_DIGITS[crc >> 4];
    buf[len++] = HEX_DIGITS[crc & 0x0F];
  }
  buf[len++] = '\n';
  Serial.write((const uint8_t *)buf, len);
}

static uint8_t put_str(char *dst, const char *s) {
  uint8_t n = 0;
  while (s[n] != '\0') {
    dst[n] = s[n];
    n++;
  }
  return n;
}

static void send_reply(Framing f, int16_t seq, Reply reply) {
  char buf[LINE_MAX];
  uint8_t n = 0;
  if (seq >= 0) {
    buf[n++] = '#';
    n += put_int(buf + n, seq);
    buf[n++] = ' ';
  }
  switch (reply) {
    case REPLY_ACK: n += put_str(buf + n, "ACK"); break;
    case REPLY_NAK_PARSE: n += put_str(buf + n, "NAK:PARSE"); break;
    case REPLY_NAK_RANGE: n += put_str(buf + n, "NAK:RANGE"); break;
    case REPLY_HELLO:
      n += put_str(buf + n, "HELLO:" FIRMWARE_ID ",");
      n += put_int(buf + n, PROTOCOL_VERSION);
      break;
  }
  send_line(buf, n, f);
}

static void send_nak_crc(uint8_t seq) {
  char buf[LINE_MAX];
  uint8_t n = 0;
  buf[n++] = '#';
  n += put_int(buf + n, seq);
  n += put_str(buf + n, " NAK:CRC");
  send_line(buf, n, FRAMING_CRC);
}

static uint8_t put_pair(char *dst, int32_t a, int32_t b) {
  uint8_t n = put_int(dst, a);
  dst[n++] = ',';
  return (uint8_t)(n + put_int(dst + n, b));
}

// The docking lines, one per call like the others: IRS (and a bumper sample) 20 Hz, BUMP on a
// change and 1 Hz, DOCK 5 Hz, WALL 10 Hz, BIN 1 Hz.
static void send_dock_telemetry(uint32_t now_ms) {
  char buf[LINE_MAX];
  uint8_t n = 0;
  if ((int32_t)(now_ms - next_irs_ms) >= 0) {
    next_irs_ms += IRS_PERIOD_MS;
    uint16_t left = mux_read(MUX_IRS_L);
    uint16_t right = mux_read(MUX_IRS_R);
    bumpers = bumpers_read();
    n = put_str(buf, "IRS:");
    n += put_pair(buf + n, left, right);
  } else if (bumpers != bumpers_sent || (int32_t)(now_ms - next_bump_ms) >= 0) {
    next_bump_ms = now_ms + BUMP_PERIOD_MS;
    bumpers_sent = bumpers;
    n = put_str(buf, "BUMP:");
    n += put_pair(buf + n, bumpers & 1, (bumpers >> 1) & 1);
  } else if ((int32_t)(now_ms - next_dock_ms) >= 0) {
    next_dock_ms += DOCK_PERIOD_MS;
    n = put_str(buf, "DOCK:");
    n += put_int(buf + n, contact_mv());
  } else if ((int32_t)(now_ms - next_wall_ms) >= 0) {
    next_wall_ms += WALL_PERIOD_MS;
    n = put_str(buf, "WALL:");
    n += put_int(buf + n, wall_cm());
  } else if ((int32_t)(now_ms - next_bin_ms) >= 0) {
    next_bin_ms += BIN_PERIOD_MS;
    n = put_str(buf, "BIN:");
    n += put_int(buf + n, bin_pct());
  } else {
    return;
  }
  send_line(buf, n, framing);
}

static void send_telemetry(uint32_t now_ms) {
  char buf[LINE_MAX];
  uint8_t n = 0;
  if ((int32_t)(now_ms - next_encoder_ms) >= 0) {
    next_encoder_ms += ENCODER_PERIOD_MS;
    int32_t left, right;
    encoders_read(&left, &right);
    n = put_str(buf, "ENCODER:");
    n += put_int(buf + n, left);
    buf[n++] = ',';
    n += put_int(buf + n, right);
    send_line(buf, n, framing);
  } else if ((int32_t)(now_ms - next_ir_ms) >= 0) {
    next_ir_ms += IR_PERIOD_MS;
    n = put_str(buf, "IR:");
    n += put_int(buf + n, ir_distance_cm());
    send_line(buf, n, framing);
  } else if ((int32_t)(now_ms - next_bat_ms) >= 0) {
    next_bat_ms += BAT_PERIOD_MS;
    uint16_t mv = battery_mv();
    n = put_str(buf, "BAT:");
    n += put_int(buf + n, mv);
    buf[n++] = ',';
    n += put_int(buf + n, battery_pct(mv));
    buf[n++] = ',';
    buf[n++] = contact_mv() >= DOCK_PRESENT_MV ? '1' : '0';
    send_line(buf, n, framing);
  } else {
    send_dock_telemetry(now_ms);
  }
}

// ---- commands ------------------------------------------------------------------------------
enum Cmd : uint8_t { CMD_MOTOR, CMD_SERVO, CMD_EVAC, CMD_LED_IDLE, CMD_LED_WAITING, CMD_LED_MOVING,
                     CMD_SUCCESS, CMD_FAILURE, CMD_STOP, CMD_HB, CMD_HELLO };

struct Command {
  Cmd cmd;
  int32_t args[4];
};

static bool starts_with(const char *s, const char *prefix, const char **rest) {
  size_t n = strlen(prefix);
  if (strncmp(s, prefix, n) != 0) return false;
  *rest = s + n;
  return true;
}

// Parses "a,b,...": count integers each within [lo[i], hi[i]], then the end of the payload.
static uint8_t parse_args(const char *p, uint8_t count, const int32_t *lo, const int32_t *hi,
                          int32_t *out) {
  uint8_t status = FIELD_OK;
  for (uint8_t i = 0; i < count; i++) {
    if (i > 0 && *p++ != ',') return FIELD_PARSE;
    uint8_t field = parse_int(&p, lo[i], hi[i], &out[i]);
    if (field == FIELD_PARSE) return FIELD_PARSE;
    if (field == FIELD_RANGE) status = FIELD_RANGE;
  }
  return *p == '\0' ? status : (uint8_t)FIELD_PARSE;
}

// Returns FIELD_OK with *c filled, or FIELD_PARSE / FIELD_RANGE.
static uint8_t parse_command(const char *payload, Command *c) {
  static const int32_t MOTOR_LO[4] = {0, 0, 0, 0};
  static const int32_t MOTOR_HI[4] = {255, 255, 1, 1};
  static const int32_t SERVO_LO[1] = {0};
  static const int32_t SERVO_HI[1] = {180};
  static const int32_t EVAC_LO[1] = {0};
  static const int32_t EVAC_HI[1] = {1};
  const char *rest;
  if (starts_with(payload, "MOTOR:", &rest)) {
    c->cmd = CMD_MOTOR;
    return parse_args(rest, 4, MOTOR_LO, MOTOR_HI, c->args);
  }
  if (starts_with(payload, "SERVO:", &rest)) {
    c->cmd = CMD_SERVO;
    return parse_args(rest, 1, SERVO_LO, SERVO_HI, c->args);
  }
  if (starts_with(payload, "EVAC:", &rest)) {
    c->cmd = CMD_EVAC;
    return parse_args(rest, 1, EVAC_LO, EVAC_HI, c->args);
  }
  static const struct { const char *name; Cmd cmd; } WORDS[] = {
    {"LED_IDLE", CMD_LED_IDLE}, {"LED_WAITING", CMD_LED_WAITING},
    {"LED_MOVING", CMD_LED_MOVING}, {"SUCCESS_SCAN", CMD_SUCCESS},
    {"FAILURE_SCAN", CMD_FAILURE}, {"STOP", CMD_STOP}, {"HB", CMD_HB}, {"HELLO", CMD_HELLO},
  };
  for (uint8_t i = 0; i < sizeof(WORDS) / sizeof(WORDS[0]); i++) {
    if (strcmp(payload, WORDS[i].name) == 0) {
      c->cmd = WORDS[i].cmd;
      return FIELD_OK;
    }
  }
  return FIELD_PARSE;
}

// micros(), not millis(): millis() steps by 2 now and then, which would cut the 500 ms short.
static void feed_deadman() { last_drive_us = micros(); }

// GPIOR2 is written whenever the outputs are consistent (after a command, at the end of a
// loop): the emulator samples the pins then, so it never sees a half-applied command.
static inline void outputs_settled() { GPIOR2 = loop_marker; }

static Reply execute(const Command *c, uint32_t now_ms) {
  Reply reply = REPLY_ACK;
  switch (c->cmd) {
    case CMD_MOTOR:
      motors_set((uint8_t)c->args[0], (uint8_t)c->args[1], c->args[2] == 1, c->args[3] == 1);
      feed_deadman();
      break;
    case CMD_SERVO: servo_write((uint8_t)c->args[0]); break;
    case CMD_EVAC: sr_set(SR_EVAC, c->args[0] == 1 ? SR_EVAC : 0); break;
    case CMD_LED_IDLE: anim_start(ANIM_IDLE, now_ms); break;
    case CMD_LED_WAITING: anim_start(ANIM_WAITING, now_ms); break;
    case CMD_LED_MOVING: anim_start(ANIM_MOVING, now_ms); break;
    case CMD_SUCCESS: anim_start(ANIM_SUCCESS, now_ms); break;
    case CMD_FAILURE: anim_start(ANIM_FAILURE, now_ms); break;
    case CMD_STOP: motors_stop(); break;
    case CMD_HB: feed_deadman(); break;
    case CMD_HELLO: reply = REPLY_HELLO; break;
  }
  outputs_settled();
  return reply;
}

static Reply reply_for(uint8_t status) {
  return status == FIELD_RANGE ? REPLY_NAK_RANGE : REPLY_NAK_PARSE;
}

// Reads "#SEQ " at the start of s: 1-3 digits, 0-255, then one space. -1 when unreadable.
static int16_t read_seq(const char *s, uint8_t len) {
  if (len < 2 || s[0] != '#') return -1;
  int16_t seq = 0;
  uint8_t i = 1;
  while (i < len && i <= 3 && s[i] >= '0' && s[i] <= '9') {
    seq = (int16_t)(seq * 10 + (s[i] - '0'));
    i++;
  }
  if (i == 1 || i >= len || s[i] != ' ' || seq > 255) return -1;
  return seq;
}

static void handle_crc_line(char *s, uint8_t len, uint32_t now_ms) {
  int16_t seq = read_seq(s, len);
  if (seq < 0) return;  // unreadable SEQ: dropped, the host resends
  if (line_overlong) {
    send_reply(FRAMING_CRC, seq, REPLY_NAK_PARSE);
    return;
  }
  if (len < 3 || s[len - 3] != '*') {
    send_nak_crc((uint8_t)seq);
    return;
  }
  int8_t hi = hex_value(s[len - 2]);
  int8_t lo = hex_value(s[len - 1]);
  uint8_t body_len = (uint8_t)(len - 3);
  uint8_t crc = crc8(s, body_len);
  if (hi < 0 || lo < 0 || (uint8_t)((hi << 4) | lo) != crc) {
    send_nak_crc((uint8_t)seq);
    return;
  }
  framing = FRAMING_CRC;
  s[body_len] = '\0';
  const char *payload = strchr(s, ' ') + 1;
  Command c;
  uint8_t status = line_binary ? (uint8_t)FIELD_PARSE : parse_command(payload, &c);
  if (status != FIELD_OK) {
    send_reply(FRAMING_CRC, seq, reply_for(status));
    return;
  }
  if (have_last && last_seq == (uint8_t)seq && last_crc == crc) {
    // A resend of the command executed last: acknowledge, do not execute again.
    if (c.cmd == CMD_MOTOR || c.cmd == CMD_HB) feed_deadman();
    send_reply(FRAMING_CRC, seq, c.cmd == CMD_HELLO ? REPLY_HELLO : REPLY_ACK);
    return;
  }
  Reply reply = execute(&c, now_ms);
  have_last = true;
  last_seq = (uint8_t)seq;
  last_crc = crc;
  send_reply(FRAMING_CRC, seq, reply);
}

static void handle_plain_line(const char *s, uint32_t now_ms) {
  if (line_overlong) return;  // no SEQ to answer to
  Command c;
  uint8_t status = line_binary ? (uint8_t)FIELD_PARSE : parse_command(s, &c);
  if (status != FIELD_OK) {
    send_reply(FRAMING_PLAIN, -1, reply_for(status));
    return;
  }
  framing = FRAMING_PLAIN;
  send_reply(FRAMING_PLAIN, -1, execute(&c, now_ms));
}

static void handle_line(uint32_t now_ms) {
  line_buf[line_len] = '\0';
  if (line_len > 0 && line_buf[0] == '#') {
    handle_crc_line(line_buf, line_len, now_ms);
  } else if (line_len > 0) {
    handle_plain_line(line_buf, now_ms);
  }
  line_len = 0;
  line_overlong = false;
  line_binary = false;
}

static void serial_poll(uint32_t now_ms) {
  while (Serial.available() > 0) {
    char ch = (char)Serial.read();
    if (ch == '\n') {
      handle_line(now_ms);
    } else if (ch == '\r') {
      // tolerated line ending
    } else if (line_len < LINE_MAX - 1) {
      if ((uint8_t)ch < 0x20 || (uint8_t)ch > 0x7E) line_binary = true;
      line_buf[line_len++] = ch;
    } else {
      line_overlong = true;  // keep the start (for the SEQ), drop the rest until '\n'
    }
  }
}

// ---- main ----------------------------------------------------------------------------------
void setup() {
  pinMode(PIN_PWM_L, OUTPUT);
  pinMode(PIN_PWM_R, OUTPUT);
  pinMode(PIN_L_IN1, OUTPUT);
  pinMode(PIN_L_IN2, OUTPUT);
  pinMode(PIN_R_IN1, OUTPUT);
  pinMode(PIN_R_IN2, OUTPUT);
  motors_stop();
  pinMode(PIN_LED_OK, OUTPUT);
  dock_io_begin();
  servo_begin();
  encoders_begin();
  Serial.begin(BAUD);
  uint32_t now_ms = millis();
  anim_start(ANIM_IDLE, now_ms);
  next_encoder_ms = now_ms + ENCODER_PERIOD_MS;
  next_ir_ms = now_ms + 20;
  next_bat_ms = now_ms + 120;
  next_irs_ms = now_ms + 10;
  next_dock_ms = now_ms + 70;
  next_wall_ms = now_ms + 30;
  next_bin_ms = now_ms + 170;
  next_bump_ms = now_ms + 90;
}

// Idle sleep until the next interrupt: Timer0 (millis, every 1.024 ms), a received byte, a
// transmitted byte or an encoder edge. All work is driven by millis() or by input, so nothing
// waits longer than 1 ms; timers, UART and PWM keep running in idle mode.
static void idle_until_interrupt() {
  set_sleep_mode(SLEEP_MODE_IDLE);
  cli();
  if (Serial.available() == 0) {
    sleep_enable();
    sei();  // the instruction after SEI runs before any pending interrupt: no lost wake-up
    sleep_cpu();
    sleep_disable();
  }
  sei();
}

void loop() {
  GPIOR0 = ++loop_marker;  // loop start and end markers: the emulator times the loop in cycles
  uint32_t now_ms = millis();
  serial_poll(now_ms);
  if (motors_on && micros() - last_drive_us >= DEADMAN_US) motors_stop();
  leds_update(now_ms);
  send_telemetry(now_ms);
  outputs_settled();
  GPIOR1 = loop_marker;
  idle_until_interrupt();
}
