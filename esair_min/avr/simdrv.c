/* esair-avr-sim: runs ATmega328P firmware in simavr 1.6 (one board, or the central
 * board with its peers on one TWI bus, in lockstep) and drives its USART and TWI from a
 * command stream (esair_min/avr/simavr_harness.py writes it and reads the events).
 *
 * simavr executes the code cycle by cycle; this driver replaces two of its peripherals
 * where simavr 1.6 is not accurate enough for our timing claims:
 *   - the TWI: simavr times a bit as 1 us whatever TWBR says and calls peers at once;
 *     here a byte takes 9 SCL periods of 16 + 2*TWBR*4^TWPS cycles, START and STOP one
 *     period, and a slave holds SCL low (clock stretching) while its TWINT is set. On
 *     the bus: modelled devices (a 24LC256-class EEPROM, register-map slaves) or other
 *     nodes running their own firmware as TWI slaves;
 *   - the USART receiver: simavr queues input in a 64-byte FIFO and paces it with an
 *     11-bit character; here each byte arrives at the cycle the harness gives (its stop
 *     bit at line rate), into the USART's 2-byte FIFO and shift register, and a fourth
 *     byte while three are held is lost with DOR set, as on the chip.
 * simavr's transmitter is kept (its pacing set to 10 bits per 8N1 character), and EIFR
 * gets the chip's write-one-to-clear (simavr 1.6 stores the written value).
 *
 * Commands (one per line on stdin), node 0 is the TWI master (the central board):
 *   node ELF PINS [FREQ]           load a firmware; PINS to report, e.g. D2,B0 (or -)
 *   eeprom ADDR SIZE ABYTES FILE   a modelled EEPROM at 7-bit ADDR holding FILE's bytes
 *   regs ADDR N                    a modelled register-map slave (pointer first, wrapping)
 *   set ADDR REG B...              modelled register / EEPROM contents
 *   absent ADDR 0|1                a modelled device stops / starts answering
 *   wire N PIN M PIN               node N's output pin drives node M's input pin
 *   adc N CH VALUE                 node N's ADC channel CH reads VALUE (0..1023)
 *   mux N CH PINS SETTLE           an analog multiplexer (74HC4051 class) on node N: its output
 *                                  on ADC channel CH, its select inputs on PINS (S0 first,
 *                                  e.g. B0,B1,B2), settled SETTLE cycles after a select change
 *   muxin N IN VALUE               input IN of node N's mux reads VALUE (0..1023)
 *   isrs N                         report node N's interrupt entries and RETIs
 *   watch N ADDR                   report each time node N's PC reaches byte address ADDR
 *   rx CYCLE BYTE                  a byte to node 0's USART whose stop bit ends at CYCLE
 *   run CYCLE                      run every node to CYCLE, then print "at CYCLE"
 *   flow N S SCLK SDIO SRAD        an optical-flow sensor S on node N's pins (tSRAD in cycles)
 *   flowreg S REG VALUE            what sensor S's register REG reads (deltas: until read)
 *   flowfloor S -1|0|1             sensor S's SDIO pulled low / high (-1: the sensor answers)
 *   poke N ADDR B... / peek N ADDR COUNT   node N's data memory
 *   quit
 * Events (stdout): "tx C B", "rd C B", "lost C" (node 0's USART), "pin N C NAME LEVEL",
 * "i2c C start|restart|stop", "i2c C byte B ACK", "isr N C VECTOR|0", "pc N C ADDR", "sp N C MINSP",
 * "at C", "flow N S C REG DATA", "flowerr N S C", "mem N C ADDR B...",
 * "mux N C early IN" (a conversion of the mux's channel started before the
 * mux settled: it reads the input shown before the select change),
 * "crash N C STATE".
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
#include <simavr/avr_adc.h>
#include <simavr/avr_ioport.h>

#define R_EIFR 0x3C
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
#define MAXNODE 3
#define MAXRX 65536

typedef struct {
    avr_t *avr;
    avr_twi_t *twi;
    avr_uart_t *uart;
    int index;
    uint16_t min_sp;
    int addressed;                       /* a slave: the master addressed it */
    char pins[24][4];
    avr_io_write_t ubrr_w;
    void *ubrr_p;
} node_t;

static node_t nodes[MAXNODE];
static int nnodes;
static int watch_node = -1;              /* "watch N ADDR": report node N reaching ADDR */
static uint32_t watch_pc[8];
static int nwatch;

static unsigned long long now(const node_t *n)
{
    return (unsigned long long)n->avr->cycle;
}

/* -- modelled devices on the bus ----------------------------------------------------- */
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
    if (d->eeprom && d->n_addr < d->abytes) {
        d->pointer = (d->abytes == 2 && d->n_addr == 0) ? (b << 8) : (d->pointer | b);
        if (d->abytes == 1) {
            d->pointer = b;
        }
        d->n_addr++;
        d->pointer %= d->size;
        return;
    }
    if (!d->eeprom && d->first) {
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

/* -- other nodes as TWI slaves ---------------------------------------------------------- */
static node_t *slave_at(int addr)
{
    for (int i = 1; i < nnodes; i++) {
        avr_t *a = nodes[i].avr;
        if ((a->data[R_TWCR] & B_TWEN) && (a->data[R_TWCR] & B_TWEA)
                && (a->data[R_TWAR] >> 1) == addr) {
            return &nodes[i];
        }
    }
    return NULL;
}

static int slave_holds(const node_t *s)
{
    return s && (s->avr->data[R_TWCR] & B_TWINT);
}

static void slave_event(node_t *s, uint8_t status)
{
    avr_t *a = s->avr;
    a->data[R_TWSR] = (uint8_t)((a->data[R_TWSR] & 0x07u) | status);
    avr_raise_interrupt(a, &s->twi->twi);
}

/* -- the master's TWI ----------------------------------------------------------------- */
enum { T_IDLE, T_START, T_ADDR, T_WRITE, T_READ };
enum { A_NONE, A_START, A_ADDR, A_WRITE, A_READ, A_STOP };
static int t_state = T_IDLE;
static bus_dev_t *t_dev;
static node_t *t_slave;
static int t_action = A_NONE;            /* what completes */
static int t_waiting;                    /* the action waits for the slave to release SCL */
static unsigned long long t_due;         /* when it completes (t_action != A_NONE, !t_waiting) */
static uint8_t t_byte;                   /* the byte on the wire */
static int t_ack;                        /* the master's ACK of a read byte */
static int t_read_sla;

static unsigned scl_cycles(avr_t *a)
{
    unsigned twbr = a->data[R_TWBR];
    unsigned twps = a->data[R_TWSR] & 3u;
    return 16u + 2u * twbr * (1u << (2u * twps));
}

static void master_status(uint8_t st)
{
    avr_t *a = nodes[0].avr;
    a->data[R_TWSR] = (uint8_t)((a->data[R_TWSR] & 0x07u) | st);
    avr_raise_interrupt(a, &nodes[0].twi->twi);
}

static void master_schedule(int action, unsigned periods)
{
    avr_t *a = nodes[0].avr;
    t_action = action;
    t_waiting = slave_holds(t_slave) && action != A_START && action != A_ADDR;
    t_due = now(&nodes[0]) + periods * scl_cycles(a);
}

/* TWCR written on any node: TWINT written 1 clears it. Node 0 is the master. */
static void twcr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    node_t *n = (node_t *)param;
    uint8_t old = a->data[addr];
    uint8_t keep_int = (uint8_t)(old & B_TWINT);
    if (v & B_TWINT) {
        keep_int = 0;
        avr_clear_interrupt(a, &n->twi->twi);
        avr_regbit_clear(a, n->twi->twi.raised);
    }
    a->data[addr] = (uint8_t)((v & (uint8_t)~(B_TWINT | B_TWSTA | B_TWSTO)) | keep_int
                              | (v & (n->index == 0 ? (B_TWSTA | B_TWSTO) : 0)));
    if ((a->data[addr] & B_TWINT) && (a->data[addr] & 0x01u)) {
        avr_raise_interrupt(a, &n->twi->twi);     /* TWIE set again while TWINT is set */
    }
    if (n->index != 0) {
        return;                          /* a slave: releasing SCL is all it does here */
    }
    if (!(v & B_TWEN)) {
        t_state = T_IDLE;
        t_action = A_NONE;
        return;
    }
    if (!(v & B_TWINT)) {
        return;
    }
    if (v & B_TWSTO) {
        if (t_state != T_IDLE) {
            printf("i2c %llu stop\n", now(n));
        }
        t_state = T_IDLE;
        master_schedule(A_STOP, 1);
        return;
    }
    if (v & B_TWSTA) {
        printf("i2c %llu %s\n", now(n), t_state == T_IDLE ? "start" : "restart");
        t_byte = t_state == T_IDLE ? 0x08 : 0x10;
        t_state = T_START;
        master_schedule(A_START, 1);
        return;
    }
    t_byte = a->data[R_TWDR];
    if (t_state == T_START) {
        master_schedule(A_ADDR, 9);
    } else if (t_state == T_WRITE) {
        master_schedule(A_WRITE, 9);
    } else if (t_state == T_READ) {
        t_ack = (v & B_TWEA) != 0;
        master_schedule(A_READ, 9);
    }
}

static void master_complete(void)
{
    avr_t *a = nodes[0].avr;
    unsigned long long c = now(&nodes[0]);
    int action = t_action;
    t_action = A_NONE;
    switch (action) {
    case A_START:
        master_status(t_byte);
        break;
    case A_ADDR: {
        int addr = t_byte >> 1;
        t_read_sla = t_byte & 1;
        t_dev = dev_at(addr);
        t_slave = t_dev ? NULL : slave_at(addr);
        if (t_dev) {
            dev_start(t_dev);
        }
        int ack = t_dev != NULL || t_slave != NULL;
        printf("i2c %llu byte %u %d\n", c, t_byte, ack);
        if (t_slave) {
            t_slave->addressed = 1;
            slave_event(t_slave, t_read_sla ? 0xA8 : 0x60);
        }
        t_state = !ack ? T_ADDR : (t_read_sla ? T_READ : T_WRITE);
        master_status(t_read_sla ? (ack ? 0x40 : 0x48) : (ack ? 0x18 : 0x20));
        break;
    }
    case A_WRITE: {
        int ack = 1;
        if (t_dev) {
            dev_write(t_dev, t_byte);
        } else if (t_slave) {
            ack = (t_slave->avr->data[R_TWCR] & B_TWEA) != 0;
            t_slave->avr->data[R_TWDR] = t_byte;
            slave_event(t_slave, ack ? 0x80 : 0x88);
        }
        printf("i2c %llu byte %u %d\n", c, t_byte, ack);
        master_status(ack ? 0x28 : 0x30);
        break;
    }
    case A_READ: {
        uint8_t b = 0xFF;
        if (t_dev) {
            b = dev_read(t_dev);
        } else if (t_slave) {
            b = t_slave->avr->data[R_TWDR];
            slave_event(t_slave, t_ack ? 0xB8 : 0xC0);
        }
        printf("i2c %llu byte %u %d\n", c, b, t_ack);
        a->data[R_TWDR] = b;
        master_status(t_ack ? 0x50 : 0x58);
        break;
    }
    case A_STOP:
        a->data[R_TWCR] &= (uint8_t)~B_TWSTO;
        a->data[R_TWSR] = (uint8_t)((a->data[R_TWSR] & 0x07u) | 0xF8u);
        if (t_slave && t_slave->addressed) {
            t_slave->addressed = 0;
            slave_event(t_slave, 0xA0);
        }
        t_slave = NULL;
        t_dev = NULL;
        break;
    default:
        break;
    }
}

static void twi_step(void)
{
    if (t_action == A_NONE) {
        return;
    }
    if (t_waiting) {                     /* the byte starts when the slave lets SCL go */
        if (slave_holds(t_slave)) {
            return;
        }
        t_waiting = 0;
        t_due = now(&nodes[0]) + (t_action == A_STOP ? 1u : 9u) * scl_cycles(nodes[0].avr);
    }
    if (now(&nodes[0]) >= t_due) {
        master_complete();
    }
}

/* -- node 0's USART receiver ------------------------------------------------------------ */
static struct { unsigned long long at; uint8_t b; } rxq[MAXRX];
static int rx_n, rx_next;
static uint8_t held[3];
static int n_held;

static uint8_t udr_read(struct avr_t *a, avr_io_addr_t addr, void *param)
{
    node_t *n = (node_t *)param;
    uint8_t b = 0;
    (void)addr;
    if (n_held > 0) {
        b = held[0];
        memmove(held, held + 1, 2);
        n_held--;
        printf("rd %llu %u\n", now(n), b);
    }
    if (n_held == 0) {
        avr_clear_interrupt(a, &n->uart->rxc);
        avr_regbit_clear(a, n->uart->rxc.raised);   /* (simavr keeps RXC "sticky") */
        a->data[R_UCSR0A] &= (uint8_t)~B_DOR0;
    }
    a->data[R_UDR0] = b;
    return b;
}

static void rx_step(void)
{
    node_t *n = &nodes[0];
    while (rx_next < rx_n && now(n) >= rxq[rx_next].at) {
        if (n_held < 3) {
            held[n_held++] = rxq[rx_next].b;
            avr_raise_interrupt(n->avr, &n->uart->rxc);
        } else {
            n->avr->data[R_UCSR0A] |= B_DOR0;
            printf("lost %llu\n", now(n));
        }
        rx_next++;
    }
}

/* simavr counts 11 bits per character (a parity bit always): 10 for 8N1. */
static void ubrr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    node_t *n = (node_t *)param;
    n->ubrr_w(a, addr, v, n->ubrr_p);
    unsigned ubrr = (unsigned)(a->data[R_UBRR0L] | ((a->data[R_UBRR0H] & 0x0F) << 8));
    unsigned bit = (ubrr + 1u) * ((a->data[R_UCSR0A] & B_U2X0) ? 8u : 16u);
    n->uart->cycles_per_byte = 10u * bit;
}

/* simavr 1.6 has no write handler on EIFR: writing a flag 1 must clear it, not set it
 * (the actuator polls INTF0 and clears it so). */
static void eifr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    a->data[addr] = (uint8_t)(a->data[addr] & (uint8_t)~v);
}

/* -- an analog multiplexer on a node's ADC channel ------------------------------------ */
/* The select pins are read as the firmware drives them; each conversion of the mux's
 * channel reads the selected input's value if the select pins last changed SETTLE cycles
 * or more before the conversion started (ADSC written 1), else the value of the input
 * the output showed before (the mux had not settled: reported as "mux N C early IN").
 * The chip samples 1.5 ADC clocks after ADSC; the model takes the start: stricter. */
#define R_ADCSRA 0x7A
#define B_ADSC 0x40
#define MUXIN 8
typedef struct {
    node_t *node;
    int channel, nsel;
    unsigned settle;
    uint8_t level[3];                    /* the select pins' levels */
    int selected;                        /* the input the select pins name */
    int shown;                           /* the input the output shows until it settles */
    unsigned long long changed_at;       /* the last select change */
    unsigned long long adsc_at;          /* the last conversion start */
    uint32_t value[MUXIN];
    avr_io_write_t adcsra_w;
    void *adcsra_p;
} mux_t;
typedef struct { mux_t *mux; int s; } mux_pin_t;
static avr_irq_t *pin_irq(avr_t *a, const char *pin);
static mux_t muxes[MAXNODE];
static mux_pin_t mux_pins[MAXNODE * 3];
static int nmux;

static mux_t *mux_of(int node)
{
    for (int i = 0; i < nmux; i++) {
        if (muxes[i].node->index == node) {
            return &muxes[i];
        }
    }
    return NULL;
}

static void on_mux_select(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    mux_pin_t *p = (mux_pin_t *)param;
    mux_t *m = p->mux;
    uint8_t level = (uint8_t)(value & 1u);
    if (m->level[p->s] == level) {
        return;
    }
    unsigned long long c = now(m->node);
    if (c - m->changed_at >= m->settle) {
        m->shown = m->selected;          /* it had settled: the transition starts from here */
    }
    m->level[p->s] = level;
    m->selected = 0;
    for (int i = 0; i < m->nsel; i++) {
        m->selected |= m->level[i] << i;
    }
    m->changed_at = c;
}

static void mux_adcsra_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    mux_t *m = (mux_t *)param;
    if ((v & B_ADSC) && !(a->data[addr] & B_ADSC)) {
        m->adsc_at = now(m->node);       /* before simavr's handler: it may sample at once */
    }
    m->adcsra_w(a, addr, v, m->adcsra_p);
}

/* simavr asks for the inputs' voltages (ADC_IRQ_OUT_TRIGGER) before it takes a value. */
static void on_mux_trigger(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)value;
    mux_t *m = (mux_t *)param;
    int in = m->selected;
    if (m->adsc_at < m->changed_at || m->adsc_at - m->changed_at < m->settle) {
        in = m->shown;
        printf("mux %d %llu early %d\n", m->node->index, m->adsc_at, m->selected);
    }
    avr_raise_irq(avr_io_getirq(m->node->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + m->channel),
                  m->value[in]);
}

static int add_mux(int node, int channel, char *pins, unsigned settle)
{
    if (node < 0 || node >= nnodes || channel < 0 || channel > 7 || mux_of(node)) {
        return -1;
    }
    mux_t *m = &muxes[nmux];
    memset(m, 0, sizeof *m);
    m->node = &nodes[node];
    m->channel = channel;
    m->settle = settle;
    avr_t *a = m->node->avr;
    for (char *tok = strtok(pins, ","); tok && m->nsel < 3; tok = strtok(NULL, ",")) {
        mux_pin_t *p = &mux_pins[nmux * 3 + m->nsel];
        p->mux = m;
        p->s = m->nsel++;
        avr_irq_register_notify(pin_irq(a, tok), on_mux_select, p);
    }
    m->adcsra_w = a->io[AVR_DATA_TO_IO(R_ADCSRA)].w.c;
    m->adcsra_p = a->io[AVR_DATA_TO_IO(R_ADCSRA)].w.param;
    a->io[AVR_DATA_TO_IO(R_ADCSRA)].w.c = mux_adcsra_write;
    a->io[AVR_DATA_TO_IO(R_ADCSRA)].w.param = m;
    avr_irq_register_notify(avr_io_getirq(a, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER),
                            on_mux_trigger, m);
    nmux++;
    return 0;
}

/* -- events and wiring ---------------------------------------------------------------- */
static void on_tx(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    printf("tx %llu %u\n", now((node_t *)param), value & 0xFF);
}

typedef struct { node_t *node; const char *name; } pin_ref_t;
static pin_ref_t pin_refs[MAXNODE * 24];
static int npin_refs;

static void on_pin(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    pin_ref_t *r = (pin_ref_t *)param;
    printf("pin %d %llu %s %u\n", r->node->index, now(r->node), r->name, value);
}

typedef struct { avr_irq_t *to; } wire_t;
static wire_t wires[8];
static int nwires;

static void on_wire(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    avr_raise_irq(((wire_t *)param)->to, value);
}

/* Interrupt entries (the vector) and RETIs (0) of a node, when asked for ("isrs N"). */
static void on_isr(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    node_t *n = (node_t *)param;
    printf("isr %d %llu %u\n", n->index, now(n), value);
}

static avr_io_t *find_io(avr_t *a, const char *kind)
{
    for (avr_io_t *io = a->io_port; io; io = io->next) {
        if (io->kind && strcmp(io->kind, kind) == 0) {
            return io;
        }
    }
    return NULL;
}

static avr_irq_t *pin_irq(avr_t *a, const char *pin)
{
    return avr_io_getirq(a, AVR_IOCTL_IOPORT_GETIRQ(pin[0]), pin[1] - '0');
}

static int add_node(const char *elf, char *pins, unsigned freq)
{
    static elf_firmware_t fw[MAXNODE];
    node_t *n = &nodes[nnodes];
    memset(&fw[nnodes], 0, sizeof fw[nnodes]);
    if (elf_read_firmware(elf, &fw[nnodes]) != 0) {
        fprintf(stderr, "cannot read %s\n", elf);
        return -1;
    }
    n->avr = avr_make_mcu_by_name("atmega328p");
    if (!n->avr) {
        fprintf(stderr, "simavr has no atmega328p\n");
        return -1;
    }
    avr_init(n->avr);
    n->avr->log = LOG_NONE;
    avr_load_firmware(n->avr, &fw[nnodes]);
    n->avr->frequency = freq;
    n->avr->avcc = 1023;                 /* an ADC input of v "millivolts" reads v */
    n->index = nnodes;
    n->min_sp = 0xFFFF;
    n->twi = (avr_twi_t *)find_io(n->avr, "twi");
    n->uart = (avr_uart_t *)find_io(n->avr, "uart");
    if (!n->twi || !n->uart) {
        fprintf(stderr, "no twi/uart io in simavr\n");
        return -1;
    }
    avr_t *a = n->avr;
    a->io[AVR_DATA_TO_IO(R_TWCR)].w.c = twcr_write;
    a->io[AVR_DATA_TO_IO(R_TWCR)].w.param = n;
    a->io[AVR_DATA_TO_IO(R_TWDR)].w.c = NULL;        /* plain memory */
    a->io[AVR_DATA_TO_IO(R_TWDR)].r.c = NULL;
    a->io[AVR_DATA_TO_IO(R_TWSR)].w.c = NULL;
    a->io[AVR_DATA_TO_IO(R_TWAR)].w.c = NULL;
    a->data[R_TWSR] = 0xF8;
    a->io[AVR_DATA_TO_IO(R_EIFR)].w.c = eifr_write;
    a->io[AVR_DATA_TO_IO(R_EIFR)].w.param = NULL;
    if (nnodes == 0) {
        a->io[AVR_DATA_TO_IO(R_UDR0)].r.c = udr_read;
        a->io[AVR_DATA_TO_IO(R_UDR0)].r.param = n;
        n->ubrr_w = a->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c;
        n->ubrr_p = a->io[AVR_DATA_TO_IO(R_UBRR0L)].w.param;
        a->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c = ubrr_write;
        a->io[AVR_DATA_TO_IO(R_UBRR0L)].w.param = n;
        avr_irq_register_notify(avr_io_getirq(a, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                                on_tx, n);
    }
    int np = 0;
    if (strcmp(pins, "-") != 0) {
        for (char *tok = strtok(pins, ","); tok && np < 24; tok = strtok(NULL, ",")) {
            snprintf(n->pins[np], sizeof n->pins[np], "%s", tok);
            pin_refs[npin_refs].node = n;
            pin_refs[npin_refs].name = n->pins[np];
            avr_irq_register_notify(pin_irq(a, tok), on_pin, &pin_refs[npin_refs]);
            npin_refs++;
            np++;
        }
    }
    nnodes++;
    return 0;
}

/* -- optical-flow sensors (ADNS-2610-class) on a node's bit-banged two-wire port -------
 * SCLK idles high. The sensor samples SDIO on each rising SCLK edge: 8 address bits
 * (MSB first, bit 7 = 0: a read), then it drives the register's 8 data bits, each from
 * the falling edge before the rising edge the MCU samples it on, and lets SDIO go after
 * the last one. Its first data bit is driven at the first falling edge after the
 * address; sooner than tSRAD after the address's last rising edge is reported
 * ("flowerr"). The registers hold what "flowreg" set; reading Delta_Y (2) or Delta_X
 * (3) clears it, as on the chip. "flowfloor S 0|1" pulls SDIO to a level instead (every
 * register reads 0x00 / 0xFF: a missing sensor; -1 ends it). Each read prints
 * "flow N S CYCLE REG DATA". */
#define MAXFLOW 4
typedef struct {
    node_t *node;
    int index;
    char sclk[4], sdio[4];
    avr_irq_t *sdio_irq;
    unsigned long long srad, addr_end;
    int nbits, sclk_level, floor;
    uint8_t addr, data;
    uint8_t regs[128];
} flow_t;
static flow_t flows[MAXFLOW];
static int nflows;

static int port_out(const node_t *n, const char *pin)
{
    int port = 0x25 + 3 * (pin[0] - 'B');              /* PORTB 0x25, PORTC 0x28, PORTD 0x2B */
    return (n->avr->data[port] >> (pin[1] - '0')) & 1;
}

static void on_flow_sclk(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    flow_t *f = (flow_t *)param;
    int level = value ? 1 : 0;
    unsigned long long c = now(f->node);
    if (level == f->sclk_level) {
        return;
    }
    f->sclk_level = level;
    if (!level) {                                       /* falling: drive the next data bit */
        if (f->nbits >= 8) {
            if (f->nbits == 8 && c - f->addr_end < f->srad) {
                printf("flowerr %d %d %llu\n", f->node->index, f->index, c);
            }
            avr_raise_irq(f->sdio_irq, (uint32_t)((f->data >> (15 - f->nbits)) & 1));
        }
        return;
    }
    if (f->nbits < 8) {                                 /* rising: an address bit in */
        f->addr = (uint8_t)((f->addr << 1) | port_out(f->node, f->sdio));
        if (++f->nbits == 8) {
            f->addr_end = c;
            f->data = f->regs[f->addr & 0x7F];
            if (f->floor >= 0) {
                f->data = f->floor ? 0xFF : 0x00;
            } else if ((f->addr & 0x7F) == 2 || (f->addr & 0x7F) == 3) {
                f->regs[f->addr & 0x7F] = 0;                /* a delta clears when read */
            }
        }
    } else if (++f->nbits == 16) {                      /* the MCU took the last data bit */
        printf("flow %d %d %llu %u %u\n", f->node->index, f->index, c, f->addr, f->data);
        f->nbits = 0;
        f->addr = 0;
    }
}

/* Data memory of a node: "poke N ADDR B..." writes, "peek N ADDR COUNT" prints
 * "mem N CYCLE ADDR B..." (ADDR: the data space, as avr-nm's 0x800000 + ADDR). */
static void mem_command(const char *cmd, const char *line)
{
    int n, addr, off, v;
    const char *p = line;
    if (sscanf(p, "%*s %d %i%n", &n, &addr, &off) != 2 || n < 0 || n >= nnodes) {
        return;
    }
    p += off;
    avr_t *a = nodes[n].avr;
    if (cmd[1] == 'o') {                                /* poke */
        while (sscanf(p, "%i%n", &v, &off) == 1 && addr <= (int)a->ramend) {
            a->data[addr++] = (uint8_t)v;
            p += off;
        }
        return;
    }
    int count = 0;
    sscanf(p, "%i", &count);
    printf("mem %d %llu %d", n, now(&nodes[n]), addr);
    for (int i = 0; i < count && addr + i <= (int)a->ramend; i++) {
        printf(" %u", a->data[addr + i]);
    }
    printf("\n");
}

/* The commands of this part: 1 if `cmd` was one of them. */
static int flow_mem_command(const char *cmd, const char *line)
{
    if (strcmp(cmd, "flow") == 0 && nflows < MAXFLOW) {
        flow_t *f = &flows[nflows];
        int n;
        memset(f, 0, sizeof *f);
        if (sscanf(line, "%*s %d %d %3s %3s %llu", &n, &f->index, f->sclk, f->sdio,
                   &f->srad) == 5 && n >= 0 && n < nnodes) {
            f->node = &nodes[n];
            f->sclk_level = 1;
            f->floor = -1;
            f->sdio_irq = pin_irq(f->node->avr, f->sdio);
            avr_irq_register_notify(pin_irq(f->node->avr, f->sclk), on_flow_sclk, f);
            nflows++;
        }
        return 1;
    }
    if (strcmp(cmd, "flowreg") == 0 || strcmp(cmd, "flowfloor") == 0) {
        int s, reg, v = 0;
        int got = sscanf(line, "%*s %d %i %i", &s, &reg, &v);
        for (int i = 0; i < nflows; i++) {
            if (flows[i].index == s && cmd[4] == 'f') {
                flows[i].floor = reg;
            } else if (flows[i].index == s && got == 3) {
                flows[i].regs[reg & 0x7F] = (uint8_t)v;
            }
        }
        return 1;
    }
    if (strcmp(cmd, "poke") == 0 || strcmp(cmd, "peek") == 0) {
        mem_command(cmd, line);
        return 1;
    }
    return 0;
}

/* Run every node to cycle `to`, in lockstep: the node furthest behind goes next. */
static int run_to(unsigned long long to)
{
    for (;;) {
        node_t *n = NULL;
        for (int i = 0; i < nnodes; i++) {
            if (now(&nodes[i]) < to && (!n || now(&nodes[i]) < now(n))) {
                n = &nodes[i];
            }
        }
        if (!n) {
            return 0;
        }
        if (n->index == 0) {
            rx_step();
            twi_step();
        }
        int st = avr_run(n->avr);
        if (n->index == watch_node) {
            for (int w = 0; w < nwatch; w++) {
                if (n->avr->pc == watch_pc[w]) {
                    printf("pc %d %llu %u\n", n->index, now(n), (unsigned)watch_pc[w]);
                }
            }
        }
        if (st == cpu_Done || st == cpu_Crashed) {
            printf("crash %d %llu %d\n", n->index, now(n), st);
            return -1;
        }
        uint16_t sp = (uint16_t)(n->avr->data[0x5D] | (n->avr->data[0x5E] << 8));
        if (sp < n->min_sp) {
            n->min_sp = sp;
        }
    }
}

int main(void)
{
    char line[4096];
    while (fgets(line, sizeof line, stdin)) {
        char cmd[16];
        if (sscanf(line, "%15s", cmd) != 1) {
            continue;
        }
        if (strcmp(cmd, "node") == 0) {
            char elf[2048], pins[512];
            unsigned freq = 16000000;
            if (sscanf(line, "%*s %2047s %511s %u", elf, pins, &freq) < 2 || nnodes == MAXNODE
                    || add_node(elf, pins, freq) != 0) {
                fprintf(stderr, "bad node line: %s", line);
                return 2;
            }
        } else if (strcmp(cmd, "eeprom") == 0 || strcmp(cmd, "regs") == 0) {
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
                size_t got = fread(d->mem, 1, (size_t)d->size, f);
                (void)got;
                fclose(f);
            }
        } else if (strcmp(cmd, "set") == 0) {
            int addr, reg, off, v;
            char *p = line;
            sscanf(p, "%*s %i %i%n", &addr, &reg, &off);
            p += off;
            for (int i = 0; i < ndev; i++) {
                if (devs[i].addr == addr) {
                    int r = reg;
                    char *q = p;
                    while (sscanf(q, "%i%n", &v, &off) == 1) {
                        devs[i].mem[r++ % devs[i].size] = (uint8_t)v;
                        q += off;
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
        } else if (strcmp(cmd, "wire") == 0) {
            int a, b;
            char pa[4], pb[4];
            sscanf(line, "%*s %d %3s %d %3s", &a, pa, &b, pb);
            wires[nwires].to = pin_irq(nodes[b].avr, pb);
            avr_irq_register_notify(pin_irq(nodes[a].avr, pa), on_wire, &wires[nwires]);
            avr_raise_irq(wires[nwires].to, 1);         /* idle high until driven */
            nwires++;
        } else if (strcmp(cmd, "watch") == 0) {
            unsigned addr;
            if (sscanf(line, "%*s %d %i", &watch_node, &addr) == 2 && nwatch < 8) {
                watch_pc[nwatch++] = addr;
            }
        } else if (strcmp(cmd, "isrs") == 0) {
            int n;
            sscanf(line, "%*s %d", &n);
            avr_irq_register_notify(nodes[n].avr->interrupts.irq + AVR_INT_IRQ_RUNNING, on_isr,
                                    &nodes[n]);
        } else if (strcmp(cmd, "adc") == 0) {
            int n, ch, v;
            sscanf(line, "%*s %d %d %d", &n, &ch, &v);
            avr_raise_irq(avr_io_getirq(nodes[n].avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + ch),
                          (uint32_t)v);
        } else if (strcmp(cmd, "mux") == 0) {
            int n, ch;
            unsigned settle;
            char pins[64];
            if (sscanf(line, "%*s %d %d %63s %u", &n, &ch, pins, &settle) != 4
                    || add_mux(n, ch, pins, settle) != 0) {
                fprintf(stderr, "bad mux line: %s", line);
                return 2;
            }
        } else if (strcmp(cmd, "muxin") == 0) {
            int n, in, v;
            mux_t *m;
            if (sscanf(line, "%*s %d %d %d", &n, &in, &v) != 3 || !(m = mux_of(n))
                    || in < 0 || in >= MUXIN) {
                fprintf(stderr, "bad muxin line: %s", line);
                return 2;
            }
            m->value[in] = (uint32_t)v;
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
            int r = run_to(to);
            for (int i = 0; i < nnodes; i++) {
                printf("sp %d %llu %u\n", i, now(&nodes[i]), nodes[i].min_sp);
            }
            printf("at %llu\n", now(&nodes[0]));
            fflush(stdout);
            if (r != 0) {
                return 3;
            }
        } else if (strcmp(cmd, "quit") == 0) {
            break;
        } else if (flow_mem_command(cmd, line)) {
            fflush(stdout);
        }
    }
    return 0;
}
