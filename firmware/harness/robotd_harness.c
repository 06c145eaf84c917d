/*
 * robotd_harness: runs the motor-board firmware in an emulated ATmega328P (libsimavr) at
 * 16 MHz, paced to the wall clock, with UART0 on a pseudo-terminal and the board's pins on a
 * line-based control channel (stdin/stdout).
 *
 *   robotd_harness FIRMWARE.elf [--link PATH] [--free-run]
 *
 * --link PATH keeps a symlink to the current pty at PATH (stable across UNPLUG/REPLUG, like a
 * udev name); --free-run runs as fast as it can instead of at wall-clock speed.
 *
 * stdout (control channel): "UART <path>" then "READY", then replies and events:
 *   EV t_us=.. pwm_l=.. pwm_r=.. in_l=.. in_r=.. servo_us=.. leds=.. evac=..
 *                     whenever a pin changes (leds and evac through the 74HC595, see below)
 * stdin commands (one a line), each answered with one line:
 *   STATE             -> "STATE t_us=.. <pin fields as in EV>"
 *   ENC <dl> <dr>     -> queue quadrature steps per wheel (signed ticks) -> "OK ENC"
 *   ENCSTAT           -> "ENCSTAT queued_l=.. queued_r=.. played_l=.. played_r=..
 *                         overridden_l=.. overridden_r=.." (signed totals since start)
 *   ADC <ch> <mV>     -> set analog input ch (0-7) in millivolts         -> "OK ADC"
 *   MUX <ch> <mV>     -> set input ch (0-7) of the 74HC4051 on A2       -> "OK MUX"
 *   DOCK <0|1>        -> a 16.8 V charger on the contacts, or none (MUX 0) -> "OK DOCK"
 *   LOOP              -> "LOOP n=.. period_p50_us=.. .. busy_p99_us=.. busy_max_us=.."
 *   LOOPRESET         -> "OK LOOPRESET"
 *   TIME              -> "TIME t_us=.. cycles=.. lag_us=.."
 *   CORRUPT <pct>     -> corrupt that % of UART bytes, both ways        -> "OK CORRUPT"
 *   DELAY <seconds>   -> hold every byte the MCU sends this long (wall)  -> "OK DELAY"
 *   UNPLUG / REPLUG   -> the USB cable: the pty vanishes / comes back    -> "OK UNPLUG"
 *   RESET             -> reset the MCU (as the reset button or DTR)      -> "OK RESET"
 *   QUIT              -> exits (so does EOF on stdin)
 *
 * Loop timing: the firmware writes GPIOR0 when loop() starts and GPIOR1 before it idles, so
 * "period" is start to start (it includes idle sleep) and "busy" is start to idle.
 *
 * The UART bridge is our own, not simavr's uart_pty part: uart_pty feeds the AVR from a second
 * thread (avr_raise_irq is not thread-safe); here everything runs on the one emulator thread.
 * Pin readings come from the registers that drive the pins (OCR/COM bits for PWM, PORT for
 * GPIO, OCR1A/ICR1 for the servo pulse). They are sampled when the firmware marks its outputs
 * consistent (a GPIOR2 write after each command and at the end of each loop), so a command is
 * never seen half-applied (left motor set, right not yet), and every 5 ms when no mark came
 * (a hung or resetting MCU).
 *
 * The docking I/O (firmware/robotd_mcu/dock_io.h) is emulated here too: a 74HC595 on A3 (SER),
 * A4 (SRCLK), A5 (RCLK) whose outputs are the eyes, the red LED, EVAC and the select lines of
 * a 74HC4051; the 4051 puts the voltage of the selected input (MUX) on A2's ADC channel as soon
 * as the register latches, before the firmware starts its conversion.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_adc.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"

#define F_CPU_HZ 16000000UL
#define TICK_CYCLES 800            /* 50 us: encoder edge spacing */
#define STALE_SAMPLE_CYCLES 80000  /* 5 ms: sample pins anyway when loop() has not ended */
#define SERVICE_TICKS 20           /* serve the pty and stdin, check the wall clock: 1 ms */
#define PTY_BACKLOG_MAX 1024       /* bytes unread by any client before we discard them */
#define LOOP_HIST_US 20000
#define CPU_US(c) ((c) / (F_CPU_HZ / 1000000UL))

/* ATmega328P data-space register addresses. */
enum {
	R_PINB = 0x23, R_PORTB = 0x25, R_PINC = 0x26, R_PORTC = 0x28, R_PIND = 0x29, R_PORTD = 0x2B,
	R_GPIOR0 = 0x3E, R_GPIOR1 = 0x4A, R_GPIOR2 = 0x4B, R_TCCR0A = 0x44, R_OCR0A = 0x47, R_OCR0B = 0x48,
	R_TCCR1A = 0x80, R_TCCR1B = 0x81, R_ICR1L = 0x86, R_ICR1H = 0x87,
	R_OCR1AL = 0x88, R_OCR1AH = 0x89, R_UCSR0B = 0xC1,
};

typedef struct {
	int pwm_l, pwm_r;      /* duty 0-255 on ENA (D5) / ENB (D6) */
	int in_l, in_r;        /* IN1 IN2 as two bits: 10 forward, 01 reverse, 00 coast */
	int servo_us;          /* pulse width on D9, 0 when no pulse */
	int servo_period_us;
	int leds;              /* bit0 eye L, bit1 eye R, bit2 green, bit3 red */
	int evac;              /* the 595's EVAC output (Q3) */
} pins_t;

static avr_t *avr;
static FILE *ctl;
static int pty_master = -1, pty_slave = -1;
static int uart_xon = 1;
static uint8_t rx_buf[256];
static size_t rx_len, rx_done;
static uint8_t tx_buf[4096];
static int64_t tx_due_us[4096];    /* wall-clock time each byte may leave (DELAY) */
static size_t tx_len;
static int64_t delay_us;
static char cmd_buf[256];
static char pty_name[128];
static size_t cmd_len;
static int quit;
static int free_run;
static struct timespec wall_start;
static pins_t last_pins;
static int64_t enc_pending[2];
static int64_t enc_queued[2], enc_played[2];  /* signed totals: ENC asked, transitions made */
static int64_t enc_overridden[2];              /* steps that found a pin not at our level */
static int enc_phase[2];
static avr_irq_t *enc_a[2], *enc_b[2];
typedef struct {
	uint64_t n, sum, min, max;
	uint32_t hist[LOOP_HIST_US + 1];  /* by microsecond */
} span_stats_t;
static span_stats_t loop_period, loop_busy;
static uint64_t loop_start_cycle, last_sample_cycle;
static uint64_t tick_count;
static int64_t lag_us;
static uint64_t cycle_base;        /* keeps emulated time monotonic across RESET */
static double corrupt_pct;
static int unplugged, reset_pending;
static const char *link_path;
static uint32_t adc_mv[8];
/* 74HC595: shift stage, latched outputs, data pin level; 74HC4051: its inputs in mV. */
static uint8_t sr_shift, sr_out;
static int sr_data;
static uint32_t mux_mv[8];
#define SR_MUX(out) (((out) >> 4) & 7)
#define MUX_ADC 2            /* the 4051's common output is on A2 */
#define CHARGER_MV 16800     /* DOCK 1: a 4S charger's voltage on the contacts */
#define CONTACT_DIVIDER 6

static uint64_t now_cycles(void) { return avr->cycle + cycle_base; }

static int64_t wall_us(void) {
	struct timespec now;
	clock_gettime(CLOCK_MONOTONIC, &now);
	return (now.tv_sec - wall_start.tv_sec) * 1000000LL + (now.tv_nsec - wall_start.tv_nsec) / 1000;
}
static uint64_t now_us(void) { return CPU_US(now_cycles()); }

static int bit(uint8_t reg, int n) { return (avr->data[reg] >> n) & 1; }

static int timer0_duty(int com_bit, uint8_t ocr, uint8_t port, int port_bit) {
	if (bit(R_TCCR0A, com_bit)) return avr->data[ocr];
	return bit(port, port_bit) ? 255 : 0;
}

static pins_t read_pins(void) {
	pins_t p;
	p.pwm_l = timer0_duty(5, R_OCR0B, R_PORTD, 5);  /* D5 = OC0B, COM0B1 */
	p.pwm_r = timer0_duty(7, R_OCR0A, R_PORTD, 6);  /* D6 = OC0A, COM0A1 */
	p.in_l = bit(R_PORTB, 0) * 10 + bit(R_PORTB, 2);  /* D8, D10 */
	p.in_r = bit(R_PORTB, 3) * 10 + bit(R_PORTB, 4);  /* D11, D12 */
	static const int prescale[8] = {0, 1, 8, 64, 256, 1024, 0, 0};
	int ps = prescale[avr->data[R_TCCR1B] & 7];
	unsigned ocr = avr->data[R_OCR1AL] | (avr->data[R_OCR1AH] << 8);
	unsigned icr = avr->data[R_ICR1L] | (avr->data[R_ICR1H] << 8);
	p.servo_us = (bit(R_TCCR1A, 7) && ps) ? (int)(ocr * ps / 16) : 0;
	p.servo_period_us = ps ? (int)((icr + 1) * ps / 16) : 0;
	p.leds = (sr_out & 1) | (sr_out & 2) | bit(R_PORTB, 5) << 2 | ((sr_out >> 2) & 1) << 3;
	p.evac = (sr_out >> 3) & 1;
	return p;
}

static void print_pins(const char *tag, const pins_t *p);

static void sample_pins(void) {
	pins_t p = read_pins();
	last_sample_cycle = avr->cycle;
	if (memcmp(&p, &last_pins, sizeof(p)) != 0) {
		last_pins = p;
		print_pins("EV", &p);
	}
}

static void print_pins(const char *tag, const pins_t *p) {
	fprintf(ctl, "%s t_us=%llu pwm_l=%d pwm_r=%d in_l=%02d in_r=%02d servo_us=%d "
	        "servo_period_us=%d leds=%d evac=%d\n", tag, (unsigned long long)now_us(), p->pwm_l,
	        p->pwm_r, p->in_l, p->in_r, p->servo_us, p->servo_period_us, p->leds, p->evac);
}

static void flush_tx(void);

/* ---- UART <-> pty ------------------------------------------------------------------------ */
static uint8_t maybe_corrupt(uint8_t byte) {
	if (corrupt_pct > 0 && (double)rand() / RAND_MAX * 100.0 < corrupt_pct)
		return byte ^ (uint8_t)(1 + rand() % 255);
	return byte;
}

static void uart_out_hook(avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq; (void)param;
	if (!unplugged && tx_len < sizeof(tx_buf)) {
		tx_due_us[tx_len] = wall_us() + delay_us;
		tx_buf[tx_len++] = maybe_corrupt((uint8_t)value);
	}
	if (value == '\n') flush_tx();  /* a whole line goes out at once, not at the next service */
}
static void uart_xon_hook(avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq; (void)value; (void)param; uart_xon = 1;
}
static void uart_xoff_hook(avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq; (void)value; (void)param; uart_xon = 0;
}

static void flush_tx(void) {
	if (pty_master < 0) {
		tx_len = 0;
		return;
	}
	if (tx_len) {
		int queued = 0;
		/* Nobody reading the pty: drop what piled up rather than block the UART. */
		if (ioctl(pty_slave, FIONREAD, &queued) == 0 && queued > PTY_BACKLOG_MAX)
			tcflush(pty_slave, TCIFLUSH);
		size_t due = 0;
		int64_t now = delay_us ? wall_us() : INT64_MAX;
		while (due < tx_len && tx_due_us[due] <= now) due++;
		if (!due) return;
		ssize_t w = write(pty_master, tx_buf, due);
		if (w > 0) {
			memmove(tx_buf, tx_buf + w, tx_len - (size_t)w);
			memmove(tx_due_us, tx_due_us + w, (tx_len - (size_t)w) * sizeof(tx_due_us[0]));
			tx_len -= (size_t)w;
		} else if (w < 0 && errno == EAGAIN) {
			tx_len = 0;
		}
	}
}

static void pty_service(void) {
	flush_tx();
	if (pty_master < 0) return;
	if (rx_done == rx_len) {
		ssize_t r = read(pty_master, rx_buf, sizeof(rx_buf));
		rx_len = r > 0 ? (size_t)r : 0;
		rx_done = 0;
	}
	/* Hold bytes until setup() has enabled the receiver (RXEN0), as a host waits for a boot. */
	if (!bit(R_UCSR0B, 4)) return;
	avr_irq_t *in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	while (uart_xon && rx_done < rx_len) avr_raise_irq(in, maybe_corrupt(rx_buf[rx_done++]));
}

static void open_pty(void) {
	char name[128];
	if (openpty(&pty_master, &pty_slave, name, NULL, NULL) < 0) {
		fprintf(stderr, "robotd_harness: openpty: %s\n", strerror(errno));
		exit(1);
	}
	struct termios tio;
	tcgetattr(pty_slave, &tio);
	cfmakeraw(&tio);
	cfsetispeed(&tio, B115200);
	cfsetospeed(&tio, B115200);
	tcsetattr(pty_slave, TCSANOW, &tio);
	fcntl(pty_master, F_SETFL, fcntl(pty_master, F_GETFL) | O_NONBLOCK);
	/* pty_slave stays open so the master never sees EIO between clients. */
	if (link_path) {
		unlink(link_path);
		if (symlink(name, link_path) != 0) {
			fprintf(stderr, "robotd_harness: symlink %s: %s\n", link_path, strerror(errno));
			exit(1);
		}
	}
	snprintf(pty_name, sizeof(pty_name), "%s", name);
}

/* Unplugging: the device node goes away and the client's reads fail, as with USB serial. */
static void close_pty(void) {
	if (link_path) unlink(link_path);
	close(pty_master);
	close(pty_slave);
	pty_master = pty_slave = -1;
	rx_len = rx_done = tx_len = 0;
}

static void connect_uart(void) {
	uint32_t flags = 0;
	avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
	flags &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
	avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
	                        uart_out_hook, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
	                        uart_xon_hook, NULL);
	avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
	                        uart_xoff_hook, NULL);
}

/* ---- input pins driven from outside ---------------------------------------------------------
 * The encoders and the dock contacts drive their pins like real sensors do. simavr models an
 * input whose PORT bit is set (INPUT_PULLUP) as a floating pin that the pull-up holds high: on
 * every DDR or PORT write to that port (analogWrite() calls pinMode() on D5/D6 at each MOTOR)
 * it raises the pin to 1 again, unless the pin is declared externally driven. Without that,
 * each MOTOR forced the encoder lines to AB = 11 behind the harness's back, and the next
 * transitions were filtered as no-change or decoded from the wrong state: counts were lost. */
static uint8_t ext_mask[2], ext_value[2];  /* port C, port D */

static void drive_pin(char port, int pin, avr_irq_t *irq, int level) {
	int i = port == 'D';
	ext_mask[i] |= (uint8_t)(1u << pin);
	ext_value[i] = (uint8_t)((ext_value[i] & ~(1u << pin)) | ((unsigned)level << pin));
	avr_ioport_external_t ext = {.name = (unsigned char)port, .mask = ext_mask[i],
	                             .value = ext_value[i]};
	avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &ext);
	avr_raise_irq(irq, (uint32_t)level);
}

/* ---- 74HC595 (outputs) and 74HC4051 (docking sensors) ---------------------------------------
 * The pin irqs of PC3-PC5 fire when the firmware changes those outputs: SRCLK's rising edge
 * shifts SER in, RCLK's rising edge latches; the latch also selects the 4051's input. */
static void mux_update(void) {
	avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + MUX_ADC),
	              mux_mv[SR_MUX(sr_out)]);
}

static void sr_pin_hook(avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq;
	static uint32_t level[3];
	int pin = (int)(intptr_t)param;  /* 0 SER, 1 SRCLK, 2 RCLK */
	int rising = value && !level[pin];
	level[pin] = value;
	if (pin == 0) {
		sr_data = value ? 1 : 0;
	} else if (pin == 1 && rising) {
		sr_shift = (uint8_t)(sr_shift << 1 | sr_data);
	} else if (pin == 2 && rising) {
		sr_out = sr_shift;
		mux_update();
	}
}

static void connect_shift_register(void) {
	for (int pin = 0; pin < 3; pin++)
		avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('C'), 3 + pin),
		                        sr_pin_hook, (void *)(intptr_t)pin);
}

/* ---- encoders: one quadrature transition per wheel per tick -------------------------------- */
/* A leads B going forward: AB = 00, 10, 11, 01. */
static const int ENC_A[4] = {0, 1, 1, 0}, ENC_B[4] = {0, 0, 1, 1};  /* by phase */

static void encoders_step(void) {
	for (int side = 0; side < 2; side++) {
		if (!enc_pending[side]) continue;
		/* A pin level that is not the one we drove means the emulation moved it (see above). */
		if ((int)enc_a[side]->value != ENC_A[enc_phase[side]] ||
		    (int)enc_b[side]->value != ENC_B[enc_phase[side]])
			enc_overridden[side]++;
		int dir = enc_pending[side] > 0 ? 1 : -1;
		enc_pending[side] -= dir;
		enc_played[side] += dir;
		int next = (enc_phase[side] + dir + 4) & 3;
		if (ENC_A[next] != ENC_A[enc_phase[side]])
			drive_pin('D', side ? 3 : 2, enc_a[side], ENC_A[next]);
		else
			drive_pin('D', side ? 7 : 4, enc_b[side], ENC_B[next]);
		enc_phase[side] = next;
	}
}

/* ---- main-loop timing from the firmware's GPIOR0 / GPIOR1 markers -------------------------- */
static void span_add(span_stats_t *st, uint64_t cycles) {
	st->n++;
	st->sum += cycles;
	if (!st->min || cycles < st->min) st->min = cycles;
	if (cycles > st->max) st->max = cycles;
	uint64_t us = CPU_US(cycles);
	st->hist[us > LOOP_HIST_US ? LOOP_HIST_US : us]++;
}

static void loop_marker_write(avr_t *a, avr_io_addr_t addr, uint8_t v, void *param) {
	(void)param;
	a->data[addr] = v;
	uint64_t now = now_cycles();
	if (addr == R_GPIOR0) {
		if (loop_start_cycle) span_add(&loop_period, now - loop_start_cycle);
		loop_start_cycle = now;
	} else if (addr == R_GPIOR1) {
		if (loop_start_cycle) span_add(&loop_busy, now - loop_start_cycle);
	} else {
		sample_pins();  /* GPIOR2: the firmware's outputs are consistent now */
	}
}

static double span_percentile_us(const span_stats_t *st, double q) {
	uint64_t want = (uint64_t)(q * (double)st->n), seen = 0;
	for (int us = 0; us <= LOOP_HIST_US; us++) {
		seen += st->hist[us];
		if (seen > want) return us;
	}
	return LOOP_HIST_US;
}

static void print_span(const char *name, const span_stats_t *st) {
	fprintf(ctl, " %s_min_us=%.2f %s_p50_us=%.0f %s_p99_us=%.0f %s_max_us=%.2f %s_mean_us=%.2f",
	        name, st->min / 16.0, name, span_percentile_us(st, 0.5), name,
	        span_percentile_us(st, 0.99), name, st->max / 16.0, name,
	        st->n ? (double)st->sum / (double)st->n / 16.0 : 0.0);
}

static void reset_mcu(void);

/* ---- control channel ---------------------------------------------------------------------- */
static void handle_command(char *line) {
	long a = 0, b = 0;
	double pct = 0;
	if (strcmp(line, "STATE") == 0) {
		pins_t p = read_pins();
		print_pins("STATE", &p);
	} else if (sscanf(line, "ENC %ld %ld", &a, &b) == 2) {
		enc_pending[0] += a;
		enc_pending[1] += b;
		enc_queued[0] += a;
		enc_queued[1] += b;
		fprintf(ctl, "OK ENC\n");
	} else if (strcmp(line, "ENCSTAT") == 0) {
		fprintf(ctl, "ENCSTAT queued_l=%lld queued_r=%lld played_l=%lld played_r=%lld "
		        "overridden_l=%lld overridden_r=%lld\n",
		        (long long)enc_queued[0], (long long)enc_queued[1],
		        (long long)enc_played[0], (long long)enc_played[1],
		        (long long)enc_overridden[0], (long long)enc_overridden[1]);
	} else if (sscanf(line, "ADC %ld %ld", &a, &b) == 2 && a >= 0 && a < 8) {
		adc_mv[a] = (uint32_t)(b < 0 ? 0 : b);
		avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + (int)a), adc_mv[a]);
		fprintf(ctl, "OK ADC\n");
	} else if (sscanf(line, "MUX %ld %ld", &a, &b) == 2 && a >= 0 && a < 8) {
		mux_mv[a] = (uint32_t)(b < 0 ? 0 : b);
		mux_update();
		fprintf(ctl, "OK MUX\n");
	} else if (sscanf(line, "DOCK %ld", &a) == 1) {
		mux_mv[0] = a ? CHARGER_MV / CONTACT_DIVIDER : 0;
		mux_update();
		fprintf(ctl, "OK DOCK\n");
	} else if (strcmp(line, "LOOP") == 0) {
		fprintf(ctl, "LOOP n=%llu", (unsigned long long)loop_period.n);
		print_span("period", &loop_period);
		print_span("busy", &loop_busy);
		fprintf(ctl, "\n");
	} else if (strcmp(line, "LOOPRESET") == 0) {
		memset(&loop_period, 0, sizeof(loop_period));
		memset(&loop_busy, 0, sizeof(loop_busy));
		fprintf(ctl, "OK LOOPRESET\n");
	} else if (sscanf(line, "CORRUPT %lf", &pct) == 1) {
		corrupt_pct = pct;
		fprintf(ctl, "OK CORRUPT\n");
	} else if (sscanf(line, "DELAY %lf", &pct) == 1) {
		delay_us = pct > 0 ? (int64_t)(pct * 1e6) : 0;
		fprintf(ctl, "OK DELAY\n");
	} else if (strcmp(line, "UNPLUG") == 0) {
		if (!unplugged) close_pty();
		unplugged = 1;
		fprintf(ctl, "OK UNPLUG\n");
	} else if (strcmp(line, "REPLUG") == 0) {
		if (unplugged) open_pty();
		unplugged = 0;
		fprintf(ctl, "OK REPLUG\n");
	} else if (strcmp(line, "RESET") == 0) {
		reset_pending = 1;  /* not from inside a cycle timer: avr_reset frees them all */
		fprintf(ctl, "OK RESET\n");
	} else if (strcmp(line, "TIME") == 0) {
		fprintf(ctl, "TIME t_us=%llu cycles=%llu lag_us=%lld\n", (unsigned long long)now_us(),
		        (unsigned long long)avr->cycle, (long long)lag_us);
	} else if (strcmp(line, "QUIT") == 0) {
		quit = 1;
	} else {
		fprintf(ctl, "ERR unknown command: %s\n", line);
	}
}

static void control_service(void) {
	struct pollfd pfd = {.fd = 0, .events = POLLIN};
	while (poll(&pfd, 1, 0) > 0) {
		char ch;
		ssize_t r = read(0, &ch, 1);
		if (r <= 0) { quit = 1; return; }
		if (ch == '\n') {
			cmd_buf[cmd_len] = '\0';
			if (cmd_len) handle_command(cmd_buf);
			cmd_len = 0;
		} else if (cmd_len < sizeof(cmd_buf) - 1) {
			cmd_buf[cmd_len++] = ch;
		}
	}
	fflush(ctl);
}

/* Waits while the emulated clock is ahead of the wall clock; returns 1 when pty or stdin input
 * cut the wait short (the caller serves it at once). */
static int pace(void) {
	int64_t ahead_us = (int64_t)now_us() - wall_us();
	lag_us = -ahead_us;
	if (ahead_us > 100) {
		struct pollfd pfd[2] = {{.fd = 0, .events = POLLIN},
		                        {.fd = rx_done == rx_len ? pty_master : -1, .events = POLLIN}};
		struct timespec ts = {.tv_sec = 0, .tv_nsec = ahead_us * 1000};
		return ppoll(pfd, 2, &ts, NULL) > 0;
	}
	return 0;
}

static void service(void) {
	pty_service();
	control_service();
}

/* The harness paces time itself; simavr's default would usleep while the AVR sleeps. */
static void no_sleep(avr_t *a, avr_cycle_count_t how_long) { (void)a; (void)how_long; }

static void drive_inputs(void) {
	for (int side = 0; side < 2; side++) {
		drive_pin('D', side ? 3 : 2, enc_a[side], ENC_A[enc_phase[side]]);
		drive_pin('D', side ? 7 : 4, enc_b[side], ENC_B[enc_phase[side]]);
	}
	for (int ch = 0; ch < 8; ch++)
		avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch), adc_mv[ch]);
	mux_update();
}

static avr_cycle_count_t tick(avr_t *a, avr_cycle_count_t when, void *param);

static void reset_mcu(void) {
	uint64_t before = now_cycles();
	avr_reset(avr);  /* also clears the cycle timers */
	cycle_base = before - avr->cycle;
	loop_start_cycle = 0;
	uart_xon = 1;
	drive_inputs();
	avr_cycle_timer_register(avr, TICK_CYCLES, tick, NULL);
}

static avr_cycle_count_t tick(avr_t *a, avr_cycle_count_t when, void *param) {
	(void)a; (void)param;
	encoders_step();
	if (avr->cycle - last_sample_cycle > STALE_SAMPLE_CYCLES) sample_pins();
	if (++tick_count % SERVICE_TICKS == 0) {
		service();
		if (!free_run && pace()) service();
	}
	return when + TICK_CYCLES;
}

int main(int argc, char **argv) {
	if (argc < 2) {
		fprintf(stderr, "usage: %s FIRMWARE.elf [--link PATH] [--free-run]\n", argv[0]);
		return 2;
	}
	for (int i = 2; i < argc; i++) {
		if (strcmp(argv[i], "--free-run") == 0) free_run = 1;
		else if (strcmp(argv[i], "--link") == 0 && i + 1 < argc) link_path = argv[++i];
		else {
			fprintf(stderr, "robotd_harness: unknown option %s\n", argv[i]);
			return 2;
		}
	}
	/* Keep the real stdout for the control channel; anything libsimavr prints goes to stderr. */
	ctl = fdopen(dup(1), "w");
	dup2(2, 1);
	setvbuf(ctl, NULL, _IOLBF, 0);

	elf_firmware_t fw;
	memset(&fw, 0, sizeof(fw));
	if (elf_read_firmware(argv[1], &fw) != 0) {
		fprintf(stderr, "robotd_harness: cannot read %s\n", argv[1]);
		return 1;
	}
	avr = avr_make_mcu_by_name("atmega328p");
	if (!avr) {
		fprintf(stderr, "robotd_harness: simavr has no atmega328p\n");
		return 1;
	}
	avr_init(avr);
	fw.frequency = F_CPU_HZ;
	avr_load_firmware(avr, &fw);
	avr->frequency = F_CPU_HZ;
	avr->vcc = avr->avcc = avr->aref = 5000;

	connect_uart();
	/* Encoders: left A/B on D2/D4, right A/B on D3/D7. They idle at AB = 11 (phase 2), the
	 * level the firmware's pull-ups give, so enabling them makes no edge. */
	for (int side = 0; side < 2; side++) {
		enc_a[side] = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), side ? 3 : 2);
		enc_b[side] = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('D'), side ? 7 : 4);
		enc_phase[side] = 2;
	}
	connect_shift_register();
	/* Power-on defaults: nothing in front (150 cm), a full 12.6 V battery (4.2 V at A1); off
	 * the dock, no beam, no wall within 30 cm (0.4 V), an empty bin (0.5 V), bumpers free. */
	adc_mv[0] = 391;
	adc_mv[1] = 4200;
	mux_mv[3] = 400;
	mux_mv[4] = 500;
	drive_inputs();
	avr->sleep = no_sleep;
	avr_register_io_write(avr, R_GPIOR0, loop_marker_write, NULL);
	avr_register_io_write(avr, R_GPIOR1, loop_marker_write, NULL);
	avr_register_io_write(avr, R_GPIOR2, loop_marker_write, NULL);
	open_pty();
	fprintf(ctl, "UART %s\n", link_path ? link_path : pty_name);
	avr_cycle_timer_register(avr, TICK_CYCLES, tick, NULL);

	clock_gettime(CLOCK_MONOTONIC, &wall_start);
	fprintf(ctl, "READY\n");
	while (!quit) {
		if (reset_pending) {
			reset_pending = 0;
			reset_mcu();
		}
		int state = avr_run(avr);
		if (state == cpu_Done || state == cpu_Crashed) {
			fprintf(ctl, "HALTED state=%d\n", state);
			break;
		}
	}
	if (link_path) unlink(link_path);
	fflush(ctl);
	return 0;
}
