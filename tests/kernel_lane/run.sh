#!/bin/sh
# Runs the real-kernel lane: boots Debian's own kernel in qemu (TCG, no KVM: a nested guest hangs)
# with the lane's initramfs and the host's root filesystem shared read-only over 9p (the guest
# runs the lane program chrooted into it), and turns the guest's result marker into the exit
# status.
# 0 = pass, 1 = fail, 77 = skipped (no qemu, kernel image, busybox-static, cpio or modprobe: the
# reason is printed). docs/hardware.md.
#
# usage: run.sh LANE_BINARY DEMO_SCENE [WORK_DIR]
set -u
here=$(cd "$(dirname "$0")" && pwd)
usage="usage: run.sh LANE_BINARY DEMO_SCENE [WORK_DIR]"
lane=${1:?$usage}
scene=${2:?$usage}
work=${3:-${TMPDIR:-/tmp}/hmdnode-kernel-lane}
mkdir -p "$work"

skip() {
    echo "kernel lane SKIPPED: $*"
    exit 77
}

# qemu, busybox, cpio, modprobe, the kernel image ($vmlinuz, $kver) and its modules (lib.sh).
. "$here/lib.sh"
kernel_lane_host || skip "$kernel_lane_missing"
[ -x "$lane" ] || { echo "kernel lane: $lane is not an executable"; exit 1; }
[ -r "$scene" ] || { echo "kernel lane: $scene is not a readable scene"; exit 1; }

start=$(date +%s.%N)

# The ELF vmlinux with qboot where it can be extracted, else the bzImage (tests/kernel_lane/lib.sh).
kernel_lane_boot_image "$vmlinuz" "$kver" "$work"

initrd="$work/initramfs-$kver.cpio"
"$here/build_initramfs.sh" "$lane" "$scene" "$initrd" "$kver" || { echo "kernel lane: building the initramfs failed"; exit 1; }

log="$work/serial.log"
# shellcheck disable=SC2086
timeout 150 qemu-system-x86_64 -accel tcg -cpu max -m 2048 -smp 2 -nodefaults -no-user-config \
    -display none -serial stdio -no-reboot $bios -kernel "$kernel" -initrd "$initrd" \
    -device bochs-display,edid=on,xres=320,yres=240,refresh_rate=60000 \
    -virtfs local,path=/,mount_tag=host,security_model=none,readonly=on,multidevs=remap \
    -append "console=ttyS0 quiet panic=-1 mitigations=off" </dev/null >"$log" 2>&1
qemu_status=$?
end=$(date +%s.%N)
tr -d '\r' <"$log" | grep -v '^$' | sed 's/^/guest| /'
wall=$(echo "$end $start" | awk '{ printf "%.1f", $1 - $2 }')
if [ $qemu_status -eq 124 ]; then
    echo "kernel lane FAILED: the guest did not finish within 150 s (wall $wall s)"
    exit 1
fi
if grep -q "HMDNODE_KERNEL_LANE: PASS" "$log" && grep -q "HMDNODE_KERNEL_LANE_EXIT: 0" "$log"; then
    echo "kernel lane PASSED in $wall s wall (kernel $kver, $(basename "$kernel"))"
    exit 0
fi
echo "kernel lane FAILED (wall $wall s): no PASS marker from the guest; serial log: $log"
exit 1
