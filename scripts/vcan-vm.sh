#!/usr/bin/env bash
# Runs the CAN tests (tests/tests/can.rs, tests/tests/can_daemon.rs) over a real vcan interface and
# exits with their status.
#
# - Host mode: when the host has vcan0, or `ip link add dev vcan0 type vcan` works here, the
#   tests run directly on the host (cargo test) with INTERPD_VCAN=vcan0.
# - VM mode: otherwise (containers, CI: the kernel has no CAN support) the tests and the
#   binaries they start are built as static executables, packed into an initramfs with busybox
#   and the five CAN modules of a stock Debian 12 kernel, and run in a QEMU VM (TCG) that
#   brings up vcan0. The VM runs in virtual time (-icount shift=0,sleep=off): its clock
#   advances 1 ns per executed instruction, so no guest thread is ever late because the host
#   was busy, the 4 ms cycle holds, and a run is repeatable. It proves the behaviour and the
#   timing logic of daemon and drives, not the host's latency (docs/can.md). icount needs a
#   single virtual CPU. The VM's init prints "INTERPD-VCAN-RESULT=<exit status>" and powers
#   off; this script streams the console and exits with that status.
#
# Usage: scripts/vcan-vm.sh [TEST-BINARY-ARGS...]     e.g. scripts/vcan-vm.sh malformed
# (the arguments go to every test binary; a name filter that matches nothing in one runs none there)
#
# Environment (all optional):
#   INTERPD_VCAN_MODE        auto (default) | host | vm  -- force a mode (vm also works on hosts with vcan)
#   INTERPD_VCAN_TESTS       the test targets of the interpd-e2e package to run (default
#                            "can can_daemon can_boot can_python"; space-separated; can_python
#                            copies this host's python3 with `canopen` into the VM)
#   INTERPD_VCAN_EXTRA_BINS  workspace binaries the tests start, put into the VM's /bin
#                            (default "interpd sim-plant"; space-separated)
#   INTERPD_VCAN_TIMEOUT     seconds before the VM is killed (default 600)
#   INTERPD_VCAN_KERNEL_DEB  a linux-image-6.1.0-*-amd64 .deb to use instead of `apt-get download`
#   INTERPD_VCAN_KEEP_IFACE  host mode: 1 keeps a vcan0 this script created (default: deleted at exit)
#   CARGO_TARGET_DIR         respected; downloads and the initramfs are cached in $TARGET/vcan-vm/
#
# The tests see: INTERPD_VCAN (interface), INTERPD_BIN_DIR (where the extra binaries are, VM
# only; on the host they are found next to the test executable), INTERPD_VCAN_BINS (their names).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT="$PWD"

IFACE=vcan0
TRIPLE=x86_64-unknown-linux-gnu
TARGET_DIR="${CARGO_TARGET_DIR:-$ROOT/target}"
CACHE="$TARGET_DIR/vcan-vm"
MODE="${INTERPD_VCAN_MODE:-auto}"
TIMEOUT="${INTERPD_VCAN_TIMEOUT:-600}"
# Binaries the CAN tests start: the daemon (master) and the simulated drives.
EXTRA_BINS="${INTERPD_VCAN_EXTRA_BINS-interpd sim-plant}"
TESTS="${INTERPD_VCAN_TESTS-can can_daemon can_boot can_python}"
# Tests share one bus and lock it anyway; one thread keeps their output readable.
TEST_ARGS=(--test-threads=1 --nocapture "$@")
# can-bcm: python-can's periodic sends (the Python drives' heartbeat) use the broadcast manager.
MODULES=(net/can/can net/can/can-raw net/can/can-bcm drivers/net/can/dev/can-dev drivers/net/can/vcan)
START=$SECONDS

log() { printf '== vcan-vm: %s\n' "$*" >&2; }
die() {
    printf '== vcan-vm: ERROR: %s\n' "$*" >&2
    exit 1
}

case "$MODE" in auto | host | vm) ;; *) die "INTERPD_VCAN_MODE must be auto, host or vm, not '$MODE'" ;; esac
case "$TIMEOUT" in '' | *[!0-9]*) die "INTERPD_VCAN_TIMEOUT must be a number of seconds, not '$TIMEOUT'" ;; esac
for old in INTERPD_VCAN_CYCLE_MS INTERPD_VCAN_SMP; do
    # Settings of the former real-time VM: the virtual-time VM runs at 4 ms on one vCPU.
    [ -z "${!old:-}" ] || die "$old is no longer used: the VM runs in virtual time at the machine's 4 ms cycle on one vCPU (docs/can.md)"
done
[ -n "$TESTS" ] || die "INTERPD_VCAN_TESTS names no test target"
TEST_FLAGS=()
for t in $TESTS; do TEST_FLAGS+=(--test "$t"); done

# ------------------------------------------------------------------------------------------
# Host mode
# ------------------------------------------------------------------------------------------

CREATED_IFACE=0
# shellcheck disable=SC2317  # called from the EXIT trap
cleanup_host() {
    if [ "$CREATED_IFACE" = 1 ] && [ "${INTERPD_VCAN_KEEP_IFACE:-0}" != 1 ]; then
        ip link delete dev "$IFACE" 2>/dev/null || true
    fi
}

# True when $IFACE exists or can be created (and is then brought up).
host_has_vcan() {
    command -v ip >/dev/null 2>&1 || return 1
    if ip link show dev "$IFACE" >/dev/null 2>&1; then
        ip link show dev "$IFACE" | grep -q 'link/can' || return 1
    elif ip link add dev "$IFACE" type vcan 2>/dev/null; then
        CREATED_IFACE=1
        trap cleanup_host EXIT
    else
        return 1
    fi
    # An existing but down interface is brought up when we may; otherwise the tests will say.
    ip link set up "$IFACE" 2>/dev/null || true
    return 0
}

run_on_host() {
    log "running the CAN tests on the host's $IFACE"
    local bin
    for bin in $EXTRA_BINS; do
        cargo build --release --bin "$bin" || die "building $bin failed (compiler output above)"
    done
    local rc=0
    INTERPD_VCAN="$IFACE" INTERPD_VCAN_BINS="$EXTRA_BINS" \
        cargo test --release -p interpd-e2e "${TEST_FLAGS[@]}" -- "${TEST_ARGS[@]}" || rc=$?
    log "host run finished with status $rc after $((SECONDS - START)) s"
    exit "$rc"
}

if [ "$MODE" != vm ]; then
    if host_has_vcan; then
        run_on_host
    elif [ "$MODE" = host ]; then
        die "INTERPD_VCAN_MODE=host but $IFACE neither exists nor can be created here"
    fi
    log "no vcan on this host (creating $IFACE failed): running the CAN tests in a QEMU VM"
fi

# ------------------------------------------------------------------------------------------
# VM mode
# ------------------------------------------------------------------------------------------

# ldd fails on static executables (that is the answer we want), so read its text, not its status.
is_static() {
    local out
    out="$(ldd "$1" 2>&1 || true)"
    case "$out" in *'not a dynamic executable'* | *'statically linked'*) return 0 ;; *) return 1 ;; esac
}

missing=()
for tool in qemu-system-x86_64:qemu-system-x86 cpio:cpio gzip:gzip xz:xz-utils dpkg:dpkg timeout:coreutils; do
    command -v "${tool%%:*}" >/dev/null 2>&1 || missing+=("${tool#*:}")
done
BUSYBOX="$(command -v busybox || true)"
if [ -z "$BUSYBOX" ] || ! is_static "$BUSYBOX"; then
    missing+=(busybox-static)
fi
if [ "${#missing[@]}" -gt 0 ]; then
    die "VM mode needs these Debian packages: ${missing[*]} (apt-get install ${missing[*]}; CI installs .ci/apt-packages)"
fi

mkdir -p "$CACHE"
# Concurrent runs share the cache; the second one waits rather than corrupting it.
if command -v flock >/dev/null 2>&1; then
    exec 9>"$CACHE/lock"
    flock 9
fi

# --- static test binaries -----------------------------------------------------------------

# The explicit --target keeps these +crt-static artefacts apart from the normal build (and keeps
# RUSTFLAGS away from build scripts and proc macros, which must stay dynamic).
STATIC_FLAGS="${RUSTFLAGS:+$RUSTFLAGS }-C target-feature=+crt-static"
log "building the static CAN test binaries ($TESTS)${EXTRA_BINS:+ and: $EXTRA_BINS}"
build_json="$CACHE/build.json"
RUSTFLAGS="$STATIC_FLAGS" cargo test --release --target "$TRIPLE" -p interpd-e2e "${TEST_FLAGS[@]}" --no-run \
    --message-format=json-render-diagnostics >"$build_json" ||
    die "building the static CAN test binaries failed (compiler output above)"
# One JSON object per line; a test artefact is the one whose target has the test's name and kind "test".
TEST_EXES=()
for t in $TESTS; do
    exe="$(grep '"reason":"compiler-artifact"' "$build_json" | grep '"kind":\["test"\]' |
        grep "\"name\":\"$t\"" | sed -n 's/.*"executable":"\([^"]*\)".*/\1/p' | tail -n 1)"
    if [ -z "$exe" ] || [ ! -x "$exe" ]; then
        die "could not find the built test executable of '$t' in cargo's output ($build_json)"
    fi
    TEST_EXES+=("$exe")
done
bins=("${TEST_EXES[@]}")
for bin in $EXTRA_BINS; do
    RUSTFLAGS="$STATIC_FLAGS" cargo build --release --target "$TRIPLE" --bin "$bin" ||
        die "building the static binary $bin failed (compiler output above)"
    bins+=("$TARGET_DIR/$TRIPLE/release/$bin")
done
for exe in "${bins[@]}"; do
    [ -x "$exe" ] || die "$exe was not built"
    # A dynamic executable would die in the VM with a confusing "not found".
    is_static "$exe" ||
        die "$exe is dynamically linked; it cannot run in the VM (is glibc's static libc.a installed? libc6-dev)"
done

# --- kernel and CAN modules (cached) ------------------------------------------------------

KDIR="$CACHE/kernel"
# A cache from a run with fewer modules is extracted again.
for m in "${MODULES[@]}"; do
    [ -f "$KDIR/$(basename "$m").ko" ] || rm -f "$KDIR/ok"
done
if [ ! -f "$KDIR/ok" ]; then
    rm -rf "$KDIR" "$CACHE/extract"
    mkdir -p "$KDIR" "$CACHE/extract"
    deb="${INTERPD_VCAN_KERNEL_DEB:-}"
    if [ -z "$deb" ]; then
        # The generic flavour: the cloud flavour is built without CAN.
        pkg="$(apt-cache search --names-only '^linux-image-6\.1\.0-[0-9]+-amd64$' | awk '{print $1}' | sort -V | tail -n 1)"
        [ -n "$pkg" ] || die "apt-cache offers no linux-image-6.1.0-*-amd64: run 'apt-get update' with a Debian 12 (bookworm) source, or set INTERPD_VCAN_KERNEL_DEB"
        log "downloading $pkg (once; cached in $KDIR)"
        # As root, apt drops to the _apt user, which cannot write into a root-owned cache.
        apt_opts=()
        if [ "$(id -u)" = 0 ]; then apt_opts=(-o APT::Sandbox::User=root); fi
        (cd "$CACHE/extract" && apt-get download -q "${apt_opts[@]}" "$pkg") || die "apt-get download $pkg failed (network? apt sources?)"
        debs=("$CACHE"/extract/"$pkg"_*.deb)
        deb="${debs[0]}"
    fi
    [ -f "$deb" ] || die "kernel package $deb not found"
    dpkg -x "$deb" "$CACHE/extract/root"
    shopt -s nullglob
    found=("$CACHE"/extract/root/boot/vmlinuz-*)
    [ "${#found[@]}" -gt 0 ] || die "no boot/vmlinuz-* in $deb"
    cp "${found[0]}" "$KDIR/vmlinuz"
    found=("$CACHE"/extract/root/lib/modules/*/kernel)
    [ "${#found[@]}" -gt 0 ] || die "no lib/modules/*/kernel in $deb"
    moddir="${found[0]}"
    shopt -u nullglob
    for m in "${MODULES[@]}"; do
        name="$(basename "$m")"
        # Newer Debian kernels compress modules; busybox insmod may not read xz/zstd, so
        # decompress here.
        if [ -f "$moddir/$m.ko" ]; then
            cp "$moddir/$m.ko" "$KDIR/$name.ko"
        elif [ -f "$moddir/$m.ko.xz" ]; then
            xz -dc "$moddir/$m.ko.xz" >"$KDIR/$name.ko"
        elif [ -f "$moddir/$m.ko.zst" ] && command -v zstd >/dev/null 2>&1; then
            zstd -qdc "$moddir/$m.ko.zst" >"$KDIR/$name.ko"
        else
            die "module $m.ko(.xz|.zst) not in $deb (the cloud flavour has no CAN; use the generic -amd64 one)"
        fi
    done
    basename "$deb" >"$KDIR/ok"
    rm -rf "$CACHE/extract"
fi
log "kernel: $(cat "$KDIR/ok")"

# --- initramfs ----------------------------------------------------------------------------

# Single-quotes a word for the init script (POSIX sh).
shquote() { printf "'%s'" "${1//\'/\'\\\'\'}"; }

STAGE="$CACHE/initramfs"
rm -rf "$STAGE"
mkdir -p "$STAGE"/{bin,dev,proc,sys,tmp,lib/modules}
cp "$BUSYBOX" "$STAGE/bin/busybox"
cp "$KDIR"/*.ko "$STAGE/lib/modules/"
i=0
for t in $TESTS; do
    cp "${TEST_EXES[$i]}" "$STAGE/bin/test-$t"
    i=$((i + 1))
done
for bin in $EXTRA_BINS; do
    cp "$TARGET_DIR/$TRIPLE/release/$bin" "$STAGE/bin/$bin"
done
# Without their debug info (panics keep their file and line): the initramfs is unpacked into
# the guest's RAM, and six static executables with line tables and Python would not fit.
if command -v strip >/dev/null 2>&1; then
    for f in "$STAGE"/bin/*; do
        [ -L "$f" ] || [ "$(basename "$f")" = busybox ] || strip --strip-debug "$f"
    done
fi
# The Python drives of tests/tests/can_python.rs: this host's python3 with `canopen` and `can`
# (pip install -r .ci/python-requirements.txt), copied with what it loads
# (scripts/vcan-vm-python.py), and the drive script and the EDS it serves.
case " $TESTS " in
*" can_python "*)
    python3 -c 'import canopen, can' 2>/dev/null ||
        die "the test can_python needs python3 with the canopen package (python3 -m pip install -r .ci/python-requirements.txt)"
    log "$(python3 scripts/vcan-vm-python.py "$STAGE")"
    mkdir -p "$STAGE/share"
    cp tests/python/canopen_drive.py sim-plant/eds/interpd-sim-drive.eds "$STAGE/share/"
    ;;
esac
args=""
for a in "${TEST_ARGS[@]}"; do args="$args $(shquote "$a")"; done
insmods=""
for m in "${MODULES[@]}"; do insmods="$insmods $(basename "$m")"; done

cat >"$STAGE/init" <<EOF
#!/bin/busybox sh
# Generated by scripts/vcan-vm.sh: bring up $IFACE, run the CAN tests, report, power off.
/bin/busybox --install -s /bin
export PATH=/bin
fail() {
    echo "INTERPD-VCAN-SETUP-FAILED: \$*"
    echo "INTERPD-VCAN-RESULT=125"
    poweroff -f
}
mount -t proc proc /proc || fail "mount /proc"
mount -t sysfs sysfs /sys || fail "mount /sys"
mount -t devtmpfs devtmpfs /dev || fail "mount /dev"
mount -t tmpfs tmpfs /tmp || fail "mount /tmp"
mkdir -p /dev/shm && mount -t tmpfs tmpfs /dev/shm || fail "mount /dev/shm"
for m in$insmods; do
    insmod /lib/modules/\$m.ko || fail "insmod \$m.ko"
done
ip link set up dev lo
ip link add dev $IFACE type vcan || fail "ip link add dev $IFACE type vcan"
ip link set up dev $IFACE || fail "ip link set up $IFACE"
echo "INTERPD-VCAN-READY uptime=\$(cut -d' ' -f1 /proc/uptime)s"
export INTERPD_VCAN_SHARE=/share
export INTERPD_VCAN=$IFACE INTERPD_BIN_DIR=/bin INTERPD_VCAN_BINS=$(shquote "$EXTRA_BINS") INTERPD_VCAN_VIRTUAL_TIME=1
export HOME=/tmp TMPDIR=/tmp RUST_BACKTRACE=1
cd /tmp
rc=0
for t in $TESTS; do
    echo "INTERPD-VCAN-TEST \$t uptime=\$(cut -d' ' -f1 /proc/uptime)s"
    /bin/test-\$t$args || { r=\$?; [ "\$rc" = 0 ] && rc=\$r; }
done
echo "INTERPD-VCAN-DONE uptime=\$(cut -d' ' -f1 /proc/uptime)s"
echo "INTERPD-VCAN-RESULT=\$rc"
poweroff -f
EOF
chmod +x "$STAGE/init"
(cd "$STAGE" && find . -print0 | LC_ALL=C sort -z | cpio --null -o -H newc --quiet | gzip -1 >"$CACHE/initrd.gz")
log "initramfs: $(du -h "$CACHE/initrd.gz" | cut -f1) (${#bins[@]} executables)"

# --- boot ---------------------------------------------------------------------------------

CONSOLE="$CACHE/console.log"
log "booting QEMU (TCG in virtual time, timeout ${TIMEOUT}s); console follows"
boot_start=$SECONDS
qemu_rc=0
# stdin from /dev/null: QEMU then leaves the terminal alone (no raw mode left behind on a kill).
# -icount shift=0: 1 ns of guest time per instruction; sleep=off: an idle guest's clock jumps to
# its next timer instead of waiting for the host's; align=off: the guest clock is not held back
# to the host's. With icount QEMU emulates one vCPU (-smp 2 hangs while starting the second).
# The guest kernel: preempt=full lets the real-time threads preempt kernel work of other
# processes (process start and exit, page faults), as on a PREEMPT_RT host; mitigations=off
# spares every system call the page-table switch, which costs guest time under emulation;
# transparent_hugepage=never, as docs/realtime.md asks of a real-time host: with THP on, the
# daemon's real-time thread woke up to 190 µs late once in 11 of 31 runs, past the 50 µs the
# SYNC test allows in virtual time; with THP off, in none of 14.
timeout -k 10 "$TIMEOUT" qemu-system-x86_64 -accel tcg -icount shift=0,sleep=off,align=off -m 1024 -smp 1 \
    -display none -monitor none -serial stdio -no-reboot -nic none \
    -kernel "$KDIR/vmlinuz" -initrd "$CACHE/initrd.gz" \
    -append "console=ttyS0 panic=-1 loglevel=4 preempt=full mitigations=off transparent_hugepage=never" </dev/null | tee "$CONSOLE" || qemu_rc=$?
boot_secs=$((SECONDS - boot_start))

if [ "$qemu_rc" = 124 ] || [ "$qemu_rc" = 137 ]; then
    die "the VM did not finish within ${TIMEOUT}s (INTERPD_VCAN_TIMEOUT); console saved in $CONSOLE"
fi
result="$(tr -d '\r' <"$CONSOLE" | sed -n 's/^INTERPD-VCAN-RESULT=\([0-9][0-9]*\)$/\1/p' | tail -n 1)"
if [ -z "$result" ]; then
    die "the VM exited (QEMU status $qemu_rc) without reporting a test result: boot failure? console saved in $CONSOLE"
fi
if grep -q '^INTERPD-VCAN-SETUP-FAILED' "$CONSOLE"; then
    die "VM setup failed: $(tr -d '\r' <"$CONSOLE" | grep '^INTERPD-VCAN-SETUP-FAILED' | head -n 1)"
fi
log "VM boot to result: ${boot_secs}s; total $((SECONDS - START))s; CAN tests exit status $result"
exit "$result"
