/* esair-avr-sim: runs one ATmega328P firmware in simavr 1.6 and drives its USART and
 * TWI from a command stream (esair_min/avr/harness.py writes it, reads the events).
 *
 * simavr executes the code cycle by cycle; this driver replaces two of its peripherals
 * where simavr 1.6 is not accurate enough for our timing claims:
 *   - the TWI: simavr times a bit as 1 us whatever TWBR says and calls peers at once;
 *     here a master byte takes 9 SCL periods of 16 + 2*TWBR*4^TWPS cycles, START and
 *     STOP one period, and the devices on the bus (a 24LC256-class EEPROM, register-map
 *     slaves) answer from the driver;
 *   - the USART receiver: simavr queues input in a 64-byte FIFO and paces it with an
 *     11-bit character; here each byte arrives at the cycle the harness gives (its stop
 *     bit at line rate), into the USART's 2-byte FIFO and shift register, and a fourth
 *     byte while three are held is lost with DOR set, as on the chip.
 * simavr's transmitter is kept (its pacing is set to 10 bits per 8N1 character).
 *
 * Commands (one per line on stdin):
 *   eeprom ADDR SIZE ABYTES FILE   an EEPROM at 7-bit ADDR holding FILE's bytes
 *   regs ADDR N                    a register-map slave (pointer byte first, wrapping)
 *   set ADDR REG B...              register contents (the sensor readings)
 *   absent ADDR 0|1                a device stops / starts answering
 *   rx CYCLE BYTE                  a byte whose stop bit ends at CYCLE
 *   run CYCLE                      run to CYCLE, then print "at CYCLE"
 *   quit
 * Events (stdout, in cycle order): "tx C B", "pin C PORTBIT LEVEL", "rd C B" (UDR0
 * read), "i2c C start|restart|stop", "i2c C byte B ACK" (ACK 1/0), "lost C" (DOR),
 * "sp C MINSP" at the end (the lowest stack pointer seen), "at C".
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdint.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/avr_uart.h>
#include <simavr/avr_twi.h>
#include <simavr/avr_ioport.h>

#define R_TWBR 0xB8
#define R_TWSR 0xB9
#define R_TWAR 0xBA
#define R_TWDR 0xBB
#define R_TWCR 0xBC
#define R_UCSR0A 0xC0
#define R_UBRR0L 0xC4
#define R_UBRR0H 0xC5
#define R_UDR0 0xC6
#define B_TWINT 0x80
#define B_TWEA 0x40
#define B_TWSTA 0x20
#define B_TWSTO 0x10
#define B_TWEN 0x04
#define B_DOR0 0x08
#define B_U2X0 0x02
#define MAXDEV 8
#define MAXRX 65536

static avr_t *avr;
static avr_twi_t *twi;
static avr_uart_t *uart;

/* -- devices on the bus ----------------------------------------------------------- */
typedef struct {
    int addr, eeprom, absent, size, abytes, n_addr, pointer, first;
    uint8_t *mem;
} bus_dev_t;
static bus_dev_t devs[MAXDEV];
static int ndev;

static bus_dev_t *dev_at(int addr)
{
    for (int i = 0; i < ndev; i++) {
        if (devs[i].addr == addr && !devs[i].absent) {
            return &devs[i];
        }
    }
    return NULL;
}

static void dev_start(bus_dev_t *d)
{
    d->n_addr = 0;
    d->first = 1;
}

static void dev_write(bus_dev_t *d, uint8_t b)
{
    if (d->eeprom) {
        if (d->n_addr < d->abytes) {
            d->pointer = (d->n_addr == 0 && d->abytes == 2) ? (b << 8) : (d->pointer | b);
            if (d->abytes == 1) {
                d->pointer = b;
            }
            d->n_addr++;
            d->pointer %= d->size;
            return;
        }
        d->mem[d->pointer] = b;          /* (no page-write model: the firmware never writes) */
        d->pointer = (d->pointer + 1) % d->size;
        return;
    }
    if (d->first) {
        d->pointer = b % d->size;
        d->first = 0;
        return;
    }
    d->mem[d->pointer] = b;
    d->pointer = (d->pointer + 1) % d->size;
}

static uint8_t dev_read(bus_dev_t *d)
{
    uint8_t b = d->mem[d->pointer];
    d->pointer = (d->pointer + 1) % d->size;
    return b;
}

/* -- TWI master model ------------------------------------------------------------- */
enum { T_IDLE, T_START, T_ADDR, T_WRITE, T_READ };
static int t_state = T_IDLE;
static bus_dev_t *t_dev;
static avr_cycle_count_t t_due;          /* 0: nothing in progress */
static uint8_t t_status;                 /* TWSR status when t_due comes */
static int t_action;                     /* 1: TWINT, 2: STOP done */
static uint8_t t_readbyte;

static unsigned scl_cycles(void)
{
    unsigned twbr = avr->data[R_TWBR];
    unsigned twps = avr->data[R_TWSR] & 3u;
    return 16u + 2u * twbr * (1u << (2u * twps));
}

static void twi_set_status(uint8_t st)
{
    avr->data[R_TWSR] = (uint8_t)((avr->data[R_TWSR] & 0x07u) | st);
}

static void twcr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    uint8_t old = a->data[addr];
    uint8_t keep_int = (uint8_t)(old & B_TWINT);
    if (v & B_TWINT) {
        keep_int = 0;                        /* writing one clears TWINT */
        avr_clear_interrupt(a, &twi->twi);
    }
    a->data[addr] = (uint8_t)((v & (uint8_t)~B_TWINT) | keep_int);
    if (!(v & B_TWEN)) {
        t_state = T_IDLE;
        t_due = 0;
        return;
    }
    if (!(v & B_TWINT)) {
        return;                              /* only TWIE/TWEA changed */
    }
    unsigned scl = scl_cycles();
    if (v & B_TWSTO) {
        if (t_state != T_IDLE) {
            printf("i2c %llu stop\n", (unsigned long long)a->cycle);
        }
        t_state = T_IDLE;
        t_due = a->cycle + scl;
        t_action = 2;
        return;
    }
    if (v & B_TWSTA) {
        printf("i2c %llu %s\n", (unsigned long long)a->cycle, t_state == T_IDLE ? "start" : "restart");
        t_status = (t_state == T_IDLE) ? 0x08 : 0x10;
        t_state = T_START;
        t_due = a->cycle + scl;
        t_action = 1;
        return;
    }
    uint8_t b = a->data[R_TWDR];
    if (t_state == T_START) {                /* the address byte */
        t_dev = dev_at(b >> 1);
        if (t_dev) {
            dev_start(t_dev);
        }
        printf("i2c %llu byte %u %d\n", (unsigned long long)a->cycle, b, t_dev != NULL);
        if (b & 1) {
            t_status = t_dev ? 0x40 : 0x48;
            t_state = T_READ;
        } else {
            t_status = t_dev ? 0x18 : 0x20;
            t_state = T_WRITE;
        }
        if (!t_dev) {
            t_state = T_ADDR;                /* NACKed: only STOP/START make sense */
        }
    } else if (t_state == T_WRITE) {
        dev_write(t_dev, b);
        printf("i2c %llu byte %u 1\n", (unsigned long long)a->cycle, b);
        t_status = 0x28;
    } else if (t_state == T_READ) {
        int ack = (v & B_TWEA) != 0;
        t_readbyte = dev_read(t_dev);
        printf("i2c %llu byte %u %d\n", (unsigned long long)a->cycle, t_readbyte, ack);
        t_status = ack ? 0x50 : 0x58;
    } else {
        return;
    }
    t_due = a->cycle + 9u * scl;
    t_action = 1;
}

static void twi_step(void)
{
    if (!t_due || avr->cycle < t_due) {
        return;
    }
    t_due = 0;
    if (t_action == 2) {                     /* STOP on the bus */
        avr->data[R_TWCR] &= (uint8_t)~B_TWSTO;
        twi_set_status(0xF8);
        return;
    }
    if (t_state == T_READ && (t_status == 0x50 || t_status == 0x58)) {
        avr->data[R_TWDR] = t_readbyte;
    }
    twi_set_status(t_status);
    avr_raise_interrupt(avr, &twi->twi);     /* sets TWINT (and interrupts if TWIE) */
}

/* -- USART receiver model ----------------------------------------------------------- */
static struct { avr_cycle_count_t at; uint8_t b; } rxq[MAXRX];
static int rx_n, rx_next;
static uint8_t held[3];
static int n_held, dor;

static uint8_t udr_read(struct avr_t *a, avr_io_addr_t addr, void *param)
{
    (void)param;
    (void)addr;
    uint8_t b = 0;
    if (n_held > 0) {
        b = held[0];
        memmove(held, held + 1, 2);
        n_held--;
        printf("rd %llu %u\n", (unsigned long long)a->cycle, b);
    }
    if (n_held == 0) {
        avr_clear_interrupt(a, &uart->rxc);
        avr_regbit_clear(a, uart->rxc.raised);      /* (simavr keeps RXC "sticky") */
        a->data[R_UCSR0A] &= (uint8_t)~B_DOR0;
        dor = 0;
    }
    a->data[R_UDR0] = b;
    return b;
}

static void rx_step(void)
{
    while (rx_next < rx_n && avr->cycle >= rxq[rx_next].at) {
        if (n_held < 3) {
            held[n_held++] = rxq[rx_next].b;
            avr_raise_interrupt(avr, &uart->rxc);
        } else {
            dor = 1;
            avr->data[R_UCSR0A] |= B_DOR0;
            printf("lost %llu\n", (unsigned long long)avr->cycle);
        }
        rx_next++;
    }
}

/* simavr counts 11 bits per character (a parity bit always): 10 for 8N1. */
static avr_io_write_t ubrr_orig_w;
static void *ubrr_orig_p;
static void ubrr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    ubrr_orig_w(a, addr, v, ubrr_orig_p);
    unsigned ubrr = (unsigned)(a->data[R_UBRR0L] | ((a->data[R_UBRR0H] & 0x0F) << 8));
    unsigned bit = (ubrr + 1u) * ((a->data[R_UCSR0A] & B_U2X0) ? 8u : 16u);
    uart->cycles_per_byte = 10u * bit;
}

/* -- events --------------------------------------------------------------------------- */
static void on_tx(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    printf("tx %llu %u\n", (unsigned long long)avr->cycle, value & 0xFF);
}

static void on_pin(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    printf("pin %llu %s %u\n", (unsigned long long)avr->cycle, (const char *)param, value);
}

static avr_io_t *find_io(const char *kind)
{
    for (avr_io_t *io = avr->io_port; io; io = io->next) {
        if (io->kind && strcmp(io->kind, kind) == 0) {
            return io;
        }
    }
    return NULL;
}

static char pin_names[24][4];

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: esair-avr-sim firmware.elf PINS (e.g. D2,B0)\n");
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw) != 0) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 2;
    }
    avr = avr_make_mcu_by_name("atmega328p");
    if (!avr) {
        fprintf(stderr, "simavr has no atmega328p\n");
        return 2;
    }
    avr_init(avr);
    avr->frequency = 16000000;
    avr->log = LOG_NONE;
    avr_load_firmware(avr, &fw);
    if (argc > 3) {
        avr->frequency = (uint32_t)strtoul(argv[3], NULL, 10);
    }
    twi = (avr_twi_t *)find_io("twi");
    uart = (avr_uart_t *)find_io("uart");
    if (!twi || !uart) {
        fprintf(stderr, "no twi/uart io in simavr\n");
        return 2;
    }
    avr->io[AVR_DATA_TO_IO(R_TWCR)].w.c = twcr_write;
    avr->io[AVR_DATA_TO_IO(R_TWCR)].w.param = NULL;
    avr->io[AVR_DATA_TO_IO(R_TWDR)].w.c = NULL;      /* plain memory */
    avr->io[AVR_DATA_TO_IO(R_TWDR)].r.c = NULL;
    avr->io[AVR_DATA_TO_IO(R_TWSR)].w.c = NULL;
    avr->data[R_TWSR] = 0xF8;
    avr->io[AVR_DATA_TO_IO(R_UDR0)].r.c = udr_read;
    avr->io[AVR_DATA_TO_IO(R_UDR0)].r.param = NULL;
    ubrr_orig_w = avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c;
    ubrr_orig_p = avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.param;
    avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c = ubrr_write;
    avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.param = NULL;
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            on_tx, NULL);
    /* pins to watch: "D2,B0,..." */
    int np = 0;
    for (char *tok = strtok(argv[2], ","); tok && np < 24; tok = strtok(NULL, ",")) {
        snprintf(pin_names[np], sizeof pin_names[np], "%s", tok);
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(tok[0]), tok[1] - '0'),
                                on_pin, pin_names[np]);
        np++;
    }
    char line[4096];
    uint16_t min_sp = 0xFFFF;
    while (fgets(line, sizeof line, stdin)) {
        char cmd[16];
        if (sscanf(line, "%15s", cmd) != 1) {
            continue;
        }
        if (strcmp(cmd, "eeprom") == 0 || strcmp(cmd, "regs") == 0) {
            bus_dev_t *d = &devs[ndev++];
            memset(d, 0, sizeof *d);
            char path[2048] = "";
            if (cmd[0] == 'e') {
                sscanf(line, "%*s %i %i %i %2047s", &d->addr, &d->size, &d->abytes, path);
                d->eeprom = 1;
            } else {
                sscanf(line, "%*s %i %i", &d->addr, &d->size);
            }
            d->mem = calloc((size_t)d->size, 1);
            if (path[0]) {
                FILE *f = fopen(path, "rb");
                if (!f) {
                    fprintf(stderr, "cannot open %s\n", path);
                    return 2;
                }
                size_t n = fread(d->mem, 1, (size_t)d->size, f);
                (void)n;
                fclose(f);
            }
        } else if (strcmp(cmd, "set") == 0) {
            int addr, reg, off;
            char *p = line;
            sscanf(p, "%*s %i %i%n", &addr, &reg, &off);
            p += off;
            for (int i = 0; i < ndev; i++) {
                if (devs[i].addr == addr) {
                    int v;
                    while (sscanf(p, "%i%n", &v, &off) == 1) {
                        devs[i].mem[reg++ % devs[i].size] = (uint8_t)v;
                        p += off;
                    }
                }
            }
        } else if (strcmp(cmd, "absent") == 0) {
            int addr, on;
            sscanf(line, "%*s %i %i", &addr, &on);
            for (int i = 0; i < ndev; i++) {
                if (devs[i].addr == addr) {
                    devs[i].absent = on;
                }
            }
        } else if (strcmp(cmd, "rx") == 0) {
            unsigned long long at;
            unsigned b;
            sscanf(line, "%*s %llu %u", &at, &b);
            if (rx_n < MAXRX) {
                rxq[rx_n].at = at;
                rxq[rx_n].b = (uint8_t)b;
                rx_n++;
            }
        } else if (strcmp(cmd, "run") == 0) {
            unsigned long long to;
            sscanf(line, "%*s %llu", &to);
            while (avr->cycle < to) {
                rx_step();
                twi_step();
                int st = avr_run(avr);
                if (st == cpu_Done || st == cpu_Crashed) {
                    printf("crash %llu %d\n", (unsigned long long)avr->cycle, st);
                    fflush(stdout);
                    return 3;
                }
                uint16_t sp = (uint16_t)(avr->data[0x5D] | (avr->data[0x5E] << 8));
                if (sp < min_sp) {
                    min_sp = sp;
                }
            }
            printf("pc %llu %u %u\n", (unsigned long long)avr->cycle, (unsigned)avr->pc, (unsigned)avr->sreg[7]);
            printf("sp %llu %u\nat %llu\n", (unsigned long long)avr->cycle, min_sp,
                   (unsigned long long)avr->cycle);
            fflush(stdout);
        } else if (strcmp(cmd, "quit") == 0) {
            break;
        }
    }
    return 0;
}
