#!/bin/sh
# The Debian package on a booted Debian 12 (the package's first target: installed and started to
# READY on a fresh system): cpack builds
# hmdnode_<version>_amd64.deb; qemu boots Debian's kernel (TCG) into a throwaway system whose root
# is an overlay of the host's root (9p, read-only) under a tmpfs, with the host's systemd as PID 1;
# there guest.sh runs `dpkg -i` for real (maintainer scripts included), `systemd-analyze verify`
# on the installed unit, `systemctl start hmdnoded` on the installed config (READY=1), and checks
# StatusText, the service user, `hmdnode ctl status` and a clean `systemctl stop`. The guest's
# result marker on the serial console becomes the exit status: 0 pass, 1 fail, 77 skipped (no
# qemu, kernel image, busybox-static, cpio, modprobe, systemd or dpkg-deb, or hmdnode or its user
# already on this machine: the reason is printed).
# docs/daemon.md, "The package on a booted system".
#
# usage: run.sh BUILD_DIR WORK_DIR VERSION
set -u
here=$(cd "$(dirname "$0")" && pwd)
usage="usage: run.sh BUILD_DIR WORK_DIR VERSION"
build=${1:?$usage}
work=${2:?$usage}
version=${3:?$usage}

skip() {
    echo "package boot SKIPPED: $*"
    exit 77
}
. "$here/../kernel_lane/lib.sh"
kernel_lane_host || skip "$kernel_lane_missing"
command -v dpkg-deb >/dev/null 2>&1 || skip "dpkg-deb not installed"
[ -x /lib/systemd/systemd ] && command -v systemd-analyze >/dev/null 2>&1 || skip "systemd not installed"
modprobe -S "$kver" --show-depends overlay >/dev/null 2>&1 || skip "no overlay module in /lib/modules/$kver"
# The guest's root is this machine's: a fresh install there needs the package and its user absent here.
! dpkg-query -W -f='${Status}' hmdnode 2>/dev/null | grep -q 'ok installed' ||
    skip "hmdnode is installed on this machine: the guest, an overlay of its root, would not start fresh"
! getent passwd hmdnode >/dev/null 2>&1 ||
    skip "the user hmdnode exists on this machine: the guest could not show the postinst creating it"

start=$(date +%s.%N)
mkdir -p "$work"
rm -f "$work"/hmdnode_*.deb
cpack --config "$build/CPackConfig.cmake" -B "$work" >"$work/cpack.log" 2>&1 ||
    { cat "$work/cpack.log"; echo "package boot FAILED: cpack"; exit 1; }
deb="$work/hmdnode_${version}_amd64.deb"
[ -f "$deb" ] || { echo "package boot FAILED: cpack made no $deb"; exit 1; }
packed=$(date +%s.%N)

kernel_lane_boot_image "$vmlinuz" "$kver" "$work"
initrd="$work/initramfs-boot-$kver.cpio"
"$here/build_initramfs.sh" "$initrd" "$kver" "$here/guest.sh" "$deb" ||
    { echo "package boot FAILED: building the initramfs failed"; exit 1; }

log="$work/serial.log"
booted=$(date +%s.%N)
times >"$work/times"  # note: not in $(...), whose subshell has no children yet
cpu_before=$(tail -n 1 "$work/times")
# shellcheck disable=SC2086
timeout 500 qemu-system-x86_64 -accel tcg -cpu max -m 2048 -smp 2 -nodefaults -no-user-config \
    -display none -serial stdio -no-reboot $bios -kernel "$kernel" -initrd "$initrd" \
    -virtfs local,path=/,mount_tag=host,security_model=none,readonly=on,multidevs=remap \
    -append "console=ttyS0 quiet panic=-1 mitigations=off systemd.unit=hmdnode-boot.target systemd.show_status=0" \
    </dev/null >"$log" 2>&1
qemu_status=$?
end=$(date +%s.%N)
times >"$work/times"
cpu_after=$(tail -n 1 "$work/times")
tr -d '\r' <"$log" | grep -v '^$' | sed 's/^/guest| /'
# The guest's CPU time (qemu's, user + system; from `times`: the shell's children) says what the
# wall time would be on an idle machine, where the guest's vCPUs get whole cores.
cpu() { echo "$1" | tr 'ms' '  ' | awk '{ print $1 * 60 + $2 + $3 * 60 + $4 }'; }
times=$(echo "$start $packed $booted $end $(cpu "$cpu_before") $(cpu "$cpu_after")" |
    awk '{ printf "%.1f s wall: cpack %.1f s, guest %.1f s (qemu CPU %.1f s)", $4 - $1, $2 - $1, $4 - $3, $6 - $5 }')
if [ $qemu_status -eq 124 ]; then
    echo "package boot FAILED: the guest did not finish within 500 s ($times)"
    exit 1
fi
if grep -q "HMDNODE_BOOT_RESULT: PASS" "$log"; then
    echo "package boot PASSED in $times (kernel $kver, $(basename "$kernel"))"
    exit 0
fi
echo "package boot FAILED ($times): no PASS marker from the guest; serial log: $log"
exit 1
