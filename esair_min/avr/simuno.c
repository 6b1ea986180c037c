/* esair-avr-uno: one AVR chip (an Arduino Uno/Nano's ATmega328P, or another part simavr
 * knows) in simavr 1.6, run in real time, its USART0 bridged to a pseudo-terminal, so the
 * real avrdude and the real bootloader in the chip's flash talk through it
 * (esair_min/avr/uno.py starts it; docs/hardware.md says what is modelled).
 *
 *   esair-avr-uno MCU FLASH_FILE BOOT_ADDR FREQ LINK [DAMAGE_AT [EEPROM_FILE]]
 *
 * FLASH_FILE is the chip's flash, mapped shared: what the bootloader writes with SPM is in
 * the file at once, so it survives the process being killed (a cable pulled, a power
 * cut). BOOT_ADDR is where the chip starts after a reset (the BOOTRST fuse: the
 * bootloader's first byte; 0 for a chip without one). LINK becomes a symlink to the pty.
 *
 * A pty has no DTR line (TIOCMGET/TIOCMSET fail with ENOTTY), so the Uno's auto-reset
 * (DTR through a 100 nF capacitor to RESET) is modelled by what causes it: the port being
 * opened. The pty master sees its slave opened (POLLHUP ends), or the opener flush the
 * port's input (tcflush, which pySerial and avrdude do when they open a port: packet mode
 * reports it even when a close and an open fall between two polls), and the chip gets an
 * external reset (MCUSR.EXTRF), as a real board does when avrdude or a terminal opens it.
 * At start the chip gets a power-on reset (PORF).
 *
 * The line: the opener's baud is the slave's termios speed (the master reads it); a byte
 * from the host arrives at the chip when its stop bit ends at that baud, into the USART's
 * 2-byte FIFO and shift register (a fourth byte while three are held is lost, DOR set).
 * When the two bauds differ, each character is resampled at the receiver's bit time
 * (start bit at the falling edge, bits sampled mid-bit, FE when the stop bit reads 0),
 * both ways, so a wrong baud gives the garbage it gives on a wire. DAMAGE_AT (optional):
 * the host's byte of that number (1 = the first since start) has bit 0 flipped on the line
 * (0: none). EEPROM_FILE (optional): a 24LC256 at 0x50 on the TWI, its 32 KB a file
 * mapped shared (2 address bytes, MSB first; a write wraps inside its 64-byte page; reads
 * run on; its write cycle is not modelled: ACK polling succeeds at once). Nothing else
 * answers on the bus.
 *
 * Events on stdout: "ready PTY", "reset CYCLE open", "hangup CYCLE", "page CYCLE ADDR N"
 * (a page write armed by the code in flash, after N bytes from the host), "damaged CYCLE N", "crash CYCLE".
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
#include <simavr/avr_uart.h>
#include <simavr/avr_twi.h>

#define R_MCUSR 0x54
#define R_SPMCSR 0x57
#define R_UCSR0A 0xC0
#define R_UBRR0L 0xC4
#define R_UBRR0H 0xC5
#define R_UDR0 0xC6
#define B_FE0 0x10
#define B_DOR0 0x08
#define B_U2X0 0x02
#define EXTRF 0x02
#define PORF 0x01
#define QMAX 4096

static avr_t *avr;
static avr_uart_t *uart;
static int master = -1;
static unsigned long freq;
static avr_io_write_t spm_w;
static void *spm_p;
static long host_bytes, damage_at;

static unsigned long long now(void)
{
    return (unsigned long long)avr->cycle;
}

/* -- the line's two bauds ------------------------------------------------------------ */
static double host_baud(void)
{
    static const struct { speed_t s; double b; } map[] = {
        {B1200, 1200}, {B2400, 2400}, {B4800, 4800}, {B9600, 9600}, {B19200, 19200},
        {B38400, 38400}, {B57600, 57600}, {B115200, 115200}, {B230400, 230400},
        {B460800, 460800}, {B500000, 500000}, {B1000000, 1000000}};
    struct termios t;
    if (tcgetattr(master, &t) != 0) {
        return 0;
    }
    speed_t s = cfgetispeed(&t);
    for (size_t i = 0; i < sizeof map / sizeof map[0]; i++) {
        if (map[i].s == s) {
            return map[i].b;
        }
    }
    return 0;
}

static double chip_baud(void)
{
    unsigned ubrr = (unsigned)(avr->data[R_UBRR0L] | ((avr->data[R_UBRR0H] & 0x0F) << 8));
    return (double)freq / ((ubrr + 1.0) * ((avr->data[R_UCSR0A] & B_U2X0) ? 8.0 : 16.0));
}

/* A character sent at `from` baud as the receiver at `to` baud reads it: bit 8 is FE. */
static unsigned resample(unsigned b, double from, double to)
{
    if (from <= 0 || to <= 0 || (from / to < 1.045 && to / from < 1.045)) {
        return b;
    }
    unsigned out = 0;
    for (int k = 0; k <= 8; k++) {
        int j = (int)((k + 1.5) * from / to);          /* the sender's bit at that moment */
        int level = j == 0 ? 0 : (j <= 8 ? (int)((b >> (j - 1)) & 1u) : 1);
        if (k < 8) {
            out |= (unsigned)level << k;
        } else if (!level) {
            out |= 0x100;
        }
    }
    return out;
}

/* -- the USART receiver: bytes due at the cycle their stop bit ends --------------------- */
static struct { unsigned long long at; unsigned v; } q[QMAX];
static int q_head, q_n;
static unsigned long long last_due;
static unsigned held[3];
static int n_held;

static void set_fe(void)
{
    if (n_held > 0 && (held[0] & 0x100)) {
        avr->data[R_UCSR0A] |= B_FE0;
    } else {
        avr->data[R_UCSR0A] &= (uint8_t)~B_FE0;
    }
}

static uint8_t udr_read(struct avr_t *a, avr_io_addr_t addr, void *param)
{
    uint8_t b = 0;
    (void)param;
    (void)addr;
    if (n_held > 0) {
        b = (uint8_t)held[0];
        memmove(held, held + 1, 2 * sizeof held[0]);
        n_held--;
    }
    if (n_held == 0) {
        avr_clear_interrupt(a, &uart->rxc);
        avr_regbit_clear(a, uart->rxc.raised);
        a->data[R_UCSR0A] &= (uint8_t)~B_DOR0;
    }
    set_fe();
    a->data[R_UDR0] = b;
    return b;
}

static void rx_step(void)
{
    while (q_n > 0 && now() >= q[q_head].at) {
        if (n_held < 3) {
            held[n_held++] = q[q_head].v;
            set_fe();
            avr_raise_interrupt(avr, &uart->rxc);
        } else {
            avr->data[R_UCSR0A] |= B_DOR0;
        }
        q_head = (q_head + 1) % QMAX;
        q_n--;
    }
}

static void host_sent(const uint8_t *buf, int n)
{
    double hb = host_baud(), cb = chip_baud();
    unsigned long long byte = hb > 0 ? (unsigned long long)(10.0 * (double)freq / hb) : 1;
    for (int i = 0; i < n && q_n < QMAX; i++) {
        unsigned v = buf[i];
        if (++host_bytes == damage_at) {
            v ^= 1u;
            printf("damaged %llu %ld\n", now(), host_bytes);
        }
        last_due = (last_due > now() ? last_due : now()) + byte;
        q[(q_head + q_n) % QMAX].at = last_due;
        q[(q_head + q_n) % QMAX].v = resample(v, hb, cb);
        q_n++;
    }
}

static void on_tx(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    (void)param;
    uint8_t b = (uint8_t)resample(value & 0xFF, chip_baud(), host_baud());
    if (write(master, &b, 1) < 0) {
        return;                          /* nobody has the port open: the byte is lost */
    }
}

/* simavr counts 11 bits per 8N1 character: 10 here, as the transmitter's pacing. */
static avr_io_write_t ubrr_w;
static void *ubrr_p;
static void ubrr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    ubrr_w(a, addr, v, ubrr_p);
    unsigned ubrr = (unsigned)(a->data[R_UBRR0L] | ((a->data[R_UBRR0H] & 0x0F) << 8));
    uart->cycles_per_byte = 10u * (ubrr + 1u) * ((a->data[R_UCSR0A] & B_U2X0) ? 8u : 16u);
}

/* simavr erases and writes a flash page in 4 cycles; the chip takes up to 4.5 ms for
 * each (datasheet tWD_FLASH): SPMEN reads 1 until then, so the bootloader's busy wait
 * takes the chip's time. A page write armed (PGWRT|SPMEN) is reported with its Z. */
static unsigned long long spm_busy_until;
static int spm_forced;                   /* SPMEN read as 1 by us (simavr stores a read) */

static uint8_t spm_read(struct avr_t *a, avr_io_addr_t addr, void *param)
{
    (void)param;
    uint8_t v = a->data[addr];
    if (now() < spm_busy_until) {
        spm_forced = 1;
        return (uint8_t)(v | 0x01);
    }
    if (spm_forced) {
        spm_forced = 0;
        return (uint8_t)(v & ~0x01);
    }
    return v;
}

static void spm_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    spm_forced = 0;
    if ((v & 0x07) == 0x03 || (v & 0x07) == 0x05) {
        spm_busy_until = now() + (unsigned long long)(freq * 45 / 10000);
    }
    if ((v & 0x05) == 0x05 && !(v & 0x02)) {
        printf("page %llu %u %ld\n", now(), (unsigned)(a->data[30] | (a->data[31] << 8)),
               host_bytes);
        fflush(stdout);
    }
    spm_w(a, addr, v, spm_p);
}

/* -- a 24LC256 on the TWI ----------------------------------------------------------------
 * simavr 1.6's TWI master does not reach its peers here, so the chip's TWI is driven as in
 * simdrv.c (whose timing this is): TWCR/TWDR/TWSR owned by this driver, a START or STOP
 * takes one SCL period, a byte 9, of 16 + 2*TWBR*4^TWPS cycles. */
#define R_TWBR 0xB8
#define R_TWSR 0xB9
#define R_TWDR 0xBB
#define R_TWCR 0xBC
#define B_TWINT 0x80
#define B_TWEA 0x40
#define B_TWSTA 0x20
#define B_TWSTO 0x10
#define B_TWEN 0x04
#define EE_ADDR 0x50
#define EE_SIZE 32768u
#define EE_PAGE 64u
static uint8_t *ee_mem;
static unsigned ee_at;
static int ee_index;
static avr_twi_t *twi;
enum { T_IDLE, T_START, T_ADDR, T_WRITE, T_READ };
enum { A_NONE, A_START, A_ADDR, A_WRITE, A_READ, A_STOP };
static int t_state = T_IDLE, t_action = A_NONE, t_ack, t_sel;
static unsigned long long t_due;
static uint8_t t_byte;

static unsigned scl_cycles(void)
{
    return 16u + 2u * avr->data[R_TWBR] * (1u << (2u * (avr->data[R_TWSR] & 3u)));
}

static void twi_status(uint8_t st)
{
    avr->data[R_TWSR] = (uint8_t)((avr->data[R_TWSR] & 0x07u) | st);
    avr_raise_interrupt(avr, &twi->twi);
}

static void twi_schedule(int action, unsigned periods)
{
    t_action = action;
    t_due = now() + periods * scl_cycles();
}

static void twcr_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)param;
    uint8_t keep_int = (uint8_t)(a->data[addr] & B_TWINT);
    if (v & B_TWINT) {
        keep_int = 0;
        avr_clear_interrupt(a, &twi->twi);
        avr_regbit_clear(a, twi->twi.raised);
    }
    a->data[addr] = (uint8_t)((v & (uint8_t)~B_TWINT) | keep_int);
    if ((a->data[addr] & B_TWINT) && (a->data[addr] & 0x01u)) {
        avr_raise_interrupt(a, &twi->twi);
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
        t_state = T_IDLE;
        twi_schedule(A_STOP, 1);
    } else if (v & B_TWSTA) {
        t_byte = t_state == T_IDLE ? 0x08 : 0x10;
        t_state = T_START;
        twi_schedule(A_START, 1);
    } else {
        t_byte = a->data[R_TWDR];
        t_ack = (v & B_TWEA) != 0;
        twi_schedule(t_state == T_START ? A_ADDR : t_state == T_WRITE ? A_WRITE : A_READ, 9);
    }
}

static void twi_step(void)
{
    if (t_action == A_NONE || now() < t_due) {
        return;
    }
    int action = t_action;
    t_action = A_NONE;
    if (action == A_START) {
        twi_status(t_byte);
    } else if (action == A_ADDR) {
        int read = t_byte & 1;
        t_sel = ee_mem != NULL && (t_byte >> 1) == EE_ADDR;
        ee_index = 0;
        t_state = !t_sel ? T_ADDR : (read ? T_READ : T_WRITE);
        twi_status(read ? (t_sel ? 0x40 : 0x48) : (t_sel ? 0x18 : 0x20));
    } else if (action == A_WRITE) {
        if (t_sel) {
            if (ee_index == 0) {
                ee_at = ((unsigned)t_byte << 8) & (EE_SIZE - 1);
            } else if (ee_index == 1) {
                ee_at |= t_byte;
            } else {
                ee_mem[ee_at] = t_byte;
                ee_at = (ee_at & ~(EE_PAGE - 1)) | ((ee_at + 1) & (EE_PAGE - 1));
            }
            ee_index++;
        }
        twi_status(t_sel ? 0x28 : 0x30);
    } else if (action == A_READ) {
        uint8_t b = 0xFF;
        if (t_sel) {
            b = ee_mem[ee_at];
            ee_at = (ee_at + 1) & (EE_SIZE - 1);
        }
        avr->data[R_TWDR] = b;
        twi_status(t_ack ? 0x50 : 0x58);
    } else if (action == A_STOP) {
        avr->data[R_TWCR] &= (uint8_t)~B_TWSTO;
        avr->data[R_TWSR] = (uint8_t)((avr->data[R_TWSR] & 0x07u) | 0xF8u);
        t_sel = 0;
    }
}

static int ee_attach(const char *path)
{
    int fd = open(path, O_RDWR);
    void *m = fd < 0 ? MAP_FAILED : mmap(NULL, EE_SIZE, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (m == MAP_FAILED) {
        fprintf(stderr, "cannot map %s (%u bytes)\n", path, EE_SIZE);
        return -1;
    }
    ee_mem = m;
    return 0;
}

static void twi_take(void)
{
    for (avr_io_t *io = avr->io_port; io; io = io->next) {
        if (io->kind && strcmp(io->kind, "twi") == 0) {
            twi = (avr_twi_t *)io;
        }
    }
    if (!twi) {
        return;
    }
    avr->io[AVR_DATA_TO_IO(R_TWCR)].w.c = twcr_write;
    avr->io[AVR_DATA_TO_IO(R_TWDR)].w.c = NULL;          /* plain memory */
    avr->io[AVR_DATA_TO_IO(R_TWDR)].r.c = NULL;
    avr->io[AVR_DATA_TO_IO(R_TWSR)].w.c = NULL;
    avr->data[R_TWSR] = 0xF8;
}

static void reset(uint8_t cause)
{
    avr_reset(avr);
    avr->data[R_MCUSR] = cause;
    avr->data[R_TWSR] = 0xF8;
    t_state = T_IDLE;
    t_action = A_NONE;
    q_n = 0;
    n_held = 0;
    last_due = 0;
}

static void no_sleep(avr_t *a, avr_cycle_count_t how_long)
{
    (void)a;
    (void)how_long;                      /* real time is kept by main's loop */
}

static double wall(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

static int open_pty(const char *link)
{
    master = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0) {
        perror("posix_openpt");
        return -1;
    }
    int one = 1;
    if (ioctl(master, TIOCPKT, &one) != 0) {
        perror("TIOCPKT");
        return -1;
    }
    const char *name = ptsname(master);
    int s = open(name, O_RDWR | O_NOCTTY);      /* raw mode, as a USB-serial port starts */
    struct termios t;
    if (s < 0 || tcgetattr(s, &t) != 0) {
        perror("pty");
        return -1;
    }
    cfmakeraw(&t);
    tcsetattr(s, TCSANOW, &t);
    close(s);
    unlink(link);
    if (symlink(name, link) != 0) {
        perror("symlink");
        return -1;
    }
    printf("ready %s\n", name);
    fflush(stdout);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 6) {
        fprintf(stderr, "usage: %s MCU FLASH_FILE BOOT_ADDR FREQ LINK [DAMAGE_AT [EEPROM]]\n",
                argv[0]);
        return 2;
    }
    avr = avr_make_mcu_by_name(argv[1]);
    if (!avr) {
        fprintf(stderr, "simavr has no %s\n", argv[1]);
        return 2;
    }
    avr_init(avr);
    avr->log = LOG_NONE;
    freq = strtoul(argv[4], NULL, 0);
    avr->frequency = (uint32_t)freq;
    avr->sleep = no_sleep;
    damage_at = argc > 6 ? strtol(argv[6], NULL, 0) : 0;
    int fd = open(argv[2], O_RDWR);
    size_t size = (size_t)avr->flashend + 1;
    void *flash = fd < 0 ? MAP_FAILED : mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    if (flash == MAP_FAILED) {
        fprintf(stderr, "cannot map %s (%zu bytes)\n", argv[2], size);
        return 2;
    }
    avr->flash = flash;
    avr->codeend = avr->flashend;
    avr->reset_pc = (avr_flashaddr_t)strtoul(argv[3], NULL, 0);
    for (avr_io_t *io = avr->io_port; io; io = io->next) {
        if (io->kind && strcmp(io->kind, "uart") == 0 && !uart) {
            uart = (avr_uart_t *)io;
        }
    }
    if (!uart) {
        fprintf(stderr, "no uart in simavr's %s\n", argv[1]);
        return 2;
    }
    uart->flags = 0;                     /* no usleep in status polls, no stdio echo */
    avr->io[AVR_DATA_TO_IO(R_UDR0)].r.c = udr_read;
    ubrr_w = avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c;
    ubrr_p = avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.param;
    avr->io[AVR_DATA_TO_IO(R_UBRR0L)].w.c = ubrr_write;
    spm_w = avr->io[AVR_DATA_TO_IO(R_SPMCSR)].w.c;
    spm_p = avr->io[AVR_DATA_TO_IO(R_SPMCSR)].w.param;
    if (spm_w) {
        avr->io[AVR_DATA_TO_IO(R_SPMCSR)].w.c = spm_write;
        avr->io[AVR_DATA_TO_IO(R_SPMCSR)].r.c = spm_read;
    }
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            on_tx, NULL);
    if (argc > 7 && ee_attach(argv[7]) != 0) {
        return 2;
    }
    twi_take();
    if (open_pty(argv[5]) != 0) {
        return 2;
    }
    reset(PORF);
    int opened = 0, crashed = 0;
    unsigned long long slice = freq / 2000;          /* 0.5 ms of the chip's time */
    unsigned long long next = slice;
    double t0 = wall();
    for (;;) {
        if (!crashed) {
            rx_step();
            twi_step();
            int st = avr_run(avr);
            if (st == cpu_Done || st == cpu_Crashed) {
                printf("crash %llu\n", now());
                fflush(stdout);
                crashed = 1;
            }
            if (now() < next) {
                continue;
            }
        } else {
            avr->cycle += slice;         /* a crashed chip: time goes on, nothing runs */
        }
        next = now() + slice;
        /* real time: never ahead of the wall clock; a late chip owes at most 20 ms */
        double ahead = (double)now() / (double)freq - (wall() - t0);
        if (ahead > 0.001) {
            usleep((useconds_t)(ahead * 1e6));
        } else if (ahead < -0.02) {
            t0 += -ahead - 0.02;
        }
        struct pollfd p = {master, POLLIN | POLLPRI, 0};
        if (poll(&p, 1, 0) < 0) {
            continue;
        }
        int open_now = !(p.revents & POLLHUP);
        if (open_now && !opened) {
            reset(EXTRF);
            crashed = 0;
            printf("reset %llu open\n", now());
            fflush(stdout);
        } else if (!open_now && opened) {
            printf("hangup %llu\n", now());
            fflush(stdout);
        }
        opened = open_now;
        if (open_now && (p.revents & (POLLIN | POLLPRI))) {
            uint8_t buf[257];
            ssize_t n = read(master, buf, sizeof buf);
            if (n > 1 && buf[0] == TIOCPKT_DATA) {
                host_sent(buf + 1, (int)n - 1);
            } else if (n == 1 && (buf[0] & TIOCPKT_FLUSHREAD)) {
                reset(EXTRF);
                crashed = 0;
                printf("reset %llu flush\n", now());
                fflush(stdout);
            }
        }
        if (damage_at) {
            fflush(stdout);
        }
    }
}
