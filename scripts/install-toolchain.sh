#!/usr/bin/env bash
# Idempotent installer for the ESAIR MIN PIC18F452 toolchain (issue 6).
#
#   * Debian packages: gputils, gpsim, tmux (the live view's tests) (+ build deps when SDCC has to be built);
#     iproute2 for the STD network-namespace tests (tests/support/netns.py, issue 12)
#   * the ATmega328P toolchain (issue 24), pinned to bookworm's versions: gcc-avr, binutils-avr,
#     avr-libc, and simavr's library (libsimavr-dev, libelf-dev) for esair_min/avr's simulator driver;
#     avrdude (esair flash) and arduino-core-avr (its bootloaders: the simulated Uno's, issue 32)
#   * SDCC 4.2.0+dfsg built from Debian's *source* package, pic16 port only
#   * device support generated from gputils' p18f452.inc:
#       $PREFIX/include/esair/p18f452_regs.h   (register declarations)
#       $PREFIX/lib/esair/libdev18f452.lib     (register definitions + EEPROM helpers)
#
# Environment: ESAIR_TOOLCHAIN (prefix, default /opt/esair-toolchain),
#              ESAIR_BUILD_DIR (scratch, default /var/tmp/esair-toolchain-build),
#              ESAIR_JOBS (make -j, default nproc), ESAIR_FORCE_BUILD=1 (rebuild SDCC),
#              ESAIR_KEEP_BUILD=1 (keep the SDCC source/build tree).
# Output goes to a log file; only a short status is printed.
set -Eeuo pipefail

PREFIX="${ESAIR_TOOLCHAIN:-/opt/esair-toolchain}"
BUILD_DIR="${ESAIR_BUILD_DIR:-/var/tmp/esair-toolchain-build}"
JOBS="${ESAIR_JOBS:-$(nproc)}"
SCRIPT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SDCC_UPSTREAM="4.2.0+dfsg"
RUNTIME_PKGS="gputils gpsim iproute2 tmux"
# ATmega328P (docs/toolchain.md, "ATmega328P"): exact versions, so every machine builds the same bytes
AVR_PKGS="gcc-avr=1:5.4.0+Atmel3.6.2-3 binutils-avr=2.26.20160125+Atmel3.6.2-4 avr-libc=1:2.0.0+Atmel3.6.2-3 libsimavr-dev=1.6+dfsg-3 libsimavr2=1.6+dfsg-3 libelf-dev avrdude=7.1+dfsg-3 arduino-core-avr"
BUILD_PKGS="bison flex libboost-dev zlib1g-dev make g++ gcc dpkg-dev"
DISABLED_PORTS="mcs51 z80 z180 r2k r2ka r3ka sm83 tlcs90 ez80_z80 z80n ds390 ds400 pic14 hc08 s08 stm8 pdk13 pdk14 pdk15 mos6502"

mkdir -p "$BUILD_DIR"
LOG="$BUILD_DIR/install.log"
: >"$LOG"
T0=$SECONDS

say() { printf '[install-toolchain] %s\n' "$*"; printf '== %s %s\n' "$(date -u +%H:%M:%S)" "$*" >>"$LOG"; }
die() {
    trap - ERR
    printf '[install-toolchain] ERROR: %s\n[install-toolchain] see log: %s\n' "$*" "$LOG" >&2
    tail -n 15 "$LOG" | sed 's/^/  | /' >&2
    exit 1
}
trap 'die "command failed (line $LINENO): $BASH_COMMAND"' ERR
log() { "$@" >>"$LOG" 2>&1; }        # run a command, output to the log only

if [ "$(id -u)" -eq 0 ]; then SUDO=""; elif command -v sudo >/dev/null; then SUDO="sudo"; else SUDO="none"; fi
as_root() {
    [ "$SUDO" != none ] || die "root is needed for: $*  (run this script as root)"
    log $SUDO env DEBIAN_FRONTEND=noninteractive "$@"
}

missing_pkgs() {
    local p
    for p in "$@"; do
        dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null | grep -qx installed || printf '%s ' "$p"
    done
}

APT_UPDATED=0
apt_install() {
    local missing
    missing="$(missing_pkgs "$@")"
    [ -n "$missing" ] || return 0
    say "installing Debian packages: $missing"
    if [ "$APT_UPDATED" = 0 ]; then as_root apt-get update || die "apt-get update failed"; APT_UPDATED=1; fi
    # shellcheck disable=SC2086
    as_root apt-get install -y --no-install-recommends $missing || die "apt-get install $missing failed"
}

sdcc_works() {
    local d="$BUILD_DIR/probe"
    [ -x "$PREFIX/bin/sdcc" ] || return 1
    rm -rf "$d"; mkdir -p "$d"
    printf 'void main(void) { }\n' >"$d/probe.c"
    (cd "$d" && "$PREFIX/bin/sdcc" -mpic16 -p18f452 --no-warn-non-free -Wa,-w1 -c probe.c) >>"$LOG" 2>&1 \
        && [ -s "$d/probe.o" ]
}

add_deb_src() {
    if apt-cache showsrc sdcc 2>/dev/null | grep -q '^Package: sdcc'; then return 0; fi
    local codename uri src=/etc/apt/sources.list.d/esair-deb-src.sources
    codename="$(. /etc/os-release && echo "${VERSION_CODENAME:-bookworm}")"
    uri="$(awk '/^URIs:/ && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list.d/*.sources 2>/dev/null || true)"
    [ -n "$uri" ] || uri="$(awk '$1 == "deb" && $2 !~ /security/ {print $2; exit}' /etc/apt/sources.list 2>/dev/null || true)"
    [ -n "$uri" ] || uri="http://deb.debian.org/debian"
    if ! grep -qs '^Types:.*deb-src' "$src"; then
        say "adding deb-src entry ($uri $codename main) in $src"
        [ "$SUDO" != none ] || die "root is needed to add $src"
        printf 'Types: deb-src\nURIs: %s\nSuites: %s\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' \
            "$uri" "$codename" | $SUDO tee "$src" >/dev/null
    fi
    as_root apt-get update || die "apt-get update (deb-src) failed"
    apt-cache showsrc sdcc 2>/dev/null | grep -q '^Package: sdcc' || die "no source package 'sdcc' after adding $src"
}

build_sdcc() {
    local t src tree
    apt_install $BUILD_PKGS
    add_deb_src
    src="$BUILD_DIR/src"; rm -rf "$src"; mkdir -p "$src"
    say "downloading Debian source package sdcc"
    (cd "$src" && apt-get source --download-only sdcc) >>"$LOG" 2>&1 || die "apt-get source --download-only sdcc failed"
    local dsc; dsc="$(ls "$src"/sdcc_*.dsc | head -n1)"
    case "$dsc" in *"sdcc_${SDCC_UPSTREAM}"-*) ;; *) die "unexpected sdcc source version: $dsc (need $SDCC_UPSTREAM)";; esac
    tree="$src/sdcc"
    log dpkg-source -x "$dsc" "$tree" || die "dpkg-source -x failed"
    [ -d "$tree/src/pic16" ] && [ -d "$tree/device/lib/pic16" ] || die "source package lacks src/pic16 or device/lib/pic16"

    # Fix 1: sdcc-libs depends on sdcc-sdbinutils even with --disable-sdbinutils.
    sed -i 's/^\(sdcc-libs:.*\)sdcc-sdbinutils/\1$(SDCC_BINUTILS)/' "$tree/Makefile.in"
    grep -q '^sdcc-libs:.*\$(SDCC_BINUTILS)' "$tree/Makefile.in" || die "could not patch sdcc-libs target in Makefile.in"
    # Fix 2: stripped non-free .ac files would make make rerun aclocal/autoheader.
    mkdir -p "$tree/device/non-free/lib/pic16"
    for f in supported-devices.ac processors.ac; do
        [ -e "$tree/device/non-free/lib/pic16/$f" ] || : >"$tree/device/non-free/lib/pic16/$f"
        touch -d '2000-01-01 00:00:00' "$tree/device/non-free/lib/pic16/$f"
    done
    touch -r "$tree/device/lib/pic16/configure" "$tree/device/lib/pic16/config.h.in"

    local opts="--prefix=$PREFIX --enable-pic16-port --disable-ucsim --disable-sdcdb --disable-sdbinutils --disable-non-free"
    for p in $DISABLED_PORTS; do opts="$opts --disable-$p-port"; done
    t=$SECONDS; say "configuring SDCC (pic16 only)"
    # shellcheck disable=SC2086
    (cd "$tree" && ./configure $opts) >>"$LOG" 2>&1 || die "SDCC configure failed"
    say "configure took $((SECONDS - t)) s"
    t=$SECONDS; say "building SDCC with -j$JOBS (a few minutes)"
    (cd "$tree" && make -j"$JOBS") >>"$LOG" 2>&1 || die "SDCC build failed"
    say "build took $((SECONDS - t)) s"
    [ "$SUDO" = "" ] || [ -w "$(dirname "$PREFIX")" ] || as_root install -d -o "$(id -u)" "$PREFIX"
    (cd "$tree" && make install) >>"$LOG" 2>&1 || die "SDCC make install failed"
    sdcc_works || die "installed $PREFIX/bin/sdcc does not compile for -mpic16"
    [ "${ESAIR_KEEP_BUILD:-0}" = 1 ] || rm -rf "$src"    # ~210 MB of build tree
}

say "prefix $PREFIX (log $LOG)"
apt_install $RUNTIME_PKGS python3
# the HMI's browser tests (tests/hmi): Playwright drives Debian's chromium headless
# (`playwright install` downloads a browser of its own, which cannot work offline)
apt_install chromium
avr_install() {      # the pinned AVR packages (apt_install checks names, not versions)
    local want="" spec name ver have
    for spec in $AVR_PKGS; do
        name="${spec%%=*}"; ver="${spec#*=}"
        have="$(dpkg-query -W -f='${db:Status-Status} ${Version}' "$name" 2>/dev/null || true)"
        if [ "$name" = "$ver" ]; then [ "${have%% *}" = installed ] || want="$want $spec"
        elif [ "$have" != "installed $ver" ]; then want="$want $spec"; fi
    done
    [ -n "$want" ] || return 0
    say "installing AVR packages:$want"
    if [ "$APT_UPDATED" = 0 ]; then as_root apt-get update || die "apt-get update failed"; APT_UPDATED=1; fi
    # shellcheck disable=SC2086
    as_root apt-get install -y --no-install-recommends $want || die "apt-get install$want failed"
}
avr_install
command -v avr-gcc >/dev/null && [ -f /usr/include/simavr/sim_avr.h ] || die "avr-gcc or simavr's headers missing"
command -v avrdude >/dev/null && [ -f /usr/share/arduino/hardware/arduino/avr/bootloaders/optiboot/optiboot.c ] \
    || die "avrdude or arduino-core-avr's bootloaders missing"
[ -f /usr/share/gputils/header/p18f452.inc ] || die "gputils' p18f452.inc not found"

if [ "${ESAIR_FORCE_BUILD:-0}" != 1 ] && sdcc_works; then
    say "SDCC already installed and working for -mpic16: skipping build"
else
    T_SDCC=$SECONDS
    build_sdcc
    say "SDCC built and installed in $((SECONDS - T_SDCC)) s"
fi

say "generating device support for PIC18F452"
python3 "$SCRIPT_DIR/gen_pic18_device.py" --inc /usr/share/gputils/header/p18f452.inc \
    --prefix "$PREFIX" --workdir "$BUILD_DIR/libdev" >>"$LOG" 2>&1 \
    || die "device support generation failed"
[ -s "$PREFIX/include/esair/p18f452_regs.h" ] && [ -s "$PREFIX/lib/esair/libdev18f452.lib" ] \
    || die "device support files missing after generation"
say "done in $((SECONDS - T0)) s: sdcc=$PREFIX/bin/sdcc lib=$PREFIX/lib/esair include=$PREFIX/include/esair"
cp "$LOG" "$PREFIX/install.log" 2>/dev/null || true
