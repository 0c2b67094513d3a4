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
# environment: HMDNODE_WRITE_DOCS=1: when the test passes, writes docs/results/package-boot.md (one
# row per step of the guest: wall time and qemu's CPU time).
set -u
here=$(cd "$(dirname "$0")" && pwd)
usage="usage: run.sh BUILD_DIR WORK_DIR VERSION"
build=${1:?$usage}
work=${2:?$usage}
version=${3:?$usage}
src=$(cd "$here/../.." && pwd)
write_docs=${HMDNODE_WRITE_DOCS:-0}

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

# docs/results/package-boot.md from this run (HMDNODE_WRITE_DOCS=1, after a pass).
write_result() {
    kernel_lane_wait_samples "$work/samples"
    command="HMDNODE_WRITE_DOCS=1 tests/package_boot/run.sh $(kernel_lane_in_tree "$src" "$build")"
    command="$command $(kernel_lane_in_tree "$src" "$work") $version"
    # The renderer the daemon chose, from its journal, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (vulkan)".
    renderer=$(tr -d '\r' <"$log" | sed -n 's/.*, renderer \(.*\) (\(vulkan\|gles\), [^)]*)$/\1 (\2)/p' | head -n 1)
    # The frame-cost model the daemon's start-up calibration measured (most of `systemctl start`).
    calibration=$(tr -d '\r' <"$log" | sed -n 's/.*\[info\] \(frame cost: .*\)$/\1/p' | head -n 1)
    body="$work/package-boot.body"
    {
        echo "Settings: the test as \`ctest -L kernel\` runs it (\`HMDNODE_WRITE_DOCS=1 ctest --test-dir"
        echo "build/release -L kernel\` writes this file and [kernel-lane.md](kernel-lane.md)): qemu \`-accel tcg"
        echo "-cpu max -m 2048 -smp 2\`, the package cpack builds from the build tree, the installed unit and"
        echo "config with the mock panel at 96x96 per eye (tests/package_boot/guest.sh). The guest's vCPUs"
        echo "share the host's cores with whatever else runs there: compare the rows of this table, not tables"
        echo "of different runs. run.sh: PASS in $times."
        [ -z "$calibration" ] || echo "The daemon's start-up calibration in the guest (its journal): \`$calibration\`."
        echo
        echo "| step | result | wall (s) | CPU (s) | figures |"
        echo "|---|---|---|---|---|"
        echo "$packed $start $cpu_packed $cpu_start $(basename "$deb")" |
            awk '{ printf "| cpack, on the host | ok | %.2f | %.1f | %s |\n", $1 - $2, $3 - $4, $5 }'
        echo "$booted $packed $cpu_before $cpu_packed $(basename "$kernel")${bios:+ with qboot}" |
            awk '{ t = $1 - $2; c = $3 - $4; $1 = $2 = $3 = $4 = ""; sub(/^ +/, "")
                   printf "| the boot image and the initramfs, on the host | ok | %.2f | %.1f | %s |\n", t, c, $0 }'
        kernel_lane_rows "$work/samples" "$log" "$steps" \
            's/^HMDNODE_BOOT: \[ *\([0-9.]*\) s\] \(ok\|FAIL\): \(.*\)/\1\t\2\t\3/p
             s/^HMDNODE_BOOT: \[ *\([0-9.]*\) s\] \(.*\)/\1\t-\t\2/p
             s/^HMDNODE_BOOT_RESULT: \(.*\)/-\t\1\tthe guest'"'"'s result marker/p' \
            "$up_start" "$up_end" "$qemu_cpu" | sed "s|$src/||g"
        echo "$end $start $cpu_after $cpu_start" | awk '{ printf "| the whole test | PASS | %.2f | %.1f | - |\n", $1 - $2, $3 - $4 }'
        echo
        echo "step: one row per step guest.sh printed in the guest (its checks, \`ok\` or \`FAIL\`, and the"
        echo "steps it announces, \`-\`; the text before the first \`: \` outside parentheses), after rows for"
        echo "cpack and the boot image and initramfs on the host and one for the boot (qemu's start to the"
        echo "guest's first line: the kernel, the initramfs and systemd up to the test's service), before one"
        echo "for the power-off and one for the whole test. wall: seconds from the row above, from the guest's"
        echo "uptime stamps where both rows have one, else from the host's clock when the line reached the"
        echo "serial log (sampled every 0.25 s). CPU: qemu's user + system CPU time over the row, all its"
        echo "threads, from \`/proc/PID/stat\` sampled every 0.25 s (a row shorter than that may show the CPU"
        echo "of rows before it), which moves less with the host's other load than wall time does; on the"
        echo "host rows, the host commands'. figures: the rest of the line."
    } >"$body"
    kernel_lane_write_result "$src" package-boot "The Debian package installed and started in a booted qemu guest" \
        "$command" "$renderer" "$body"
}

start=$(date +%s.%N)
mkdir -p "$work"
kernel_lane_cpu_now "$work/times"
cpu_start=$kernel_lane_cpu
rm -f "$work"/hmdnode_*.deb
cpack --config "$build/CPackConfig.cmake" -B "$work" >"$work/cpack.log" 2>&1 ||
    { cat "$work/cpack.log"; echo "package boot FAILED: cpack"; exit 1; }
deb="$work/hmdnode_${version}_amd64.deb"
[ -f "$deb" ] || { echo "package boot FAILED: cpack made no $deb"; exit 1; }
packed=$(date +%s.%N)
kernel_lane_cpu_now "$work/times"
cpu_packed=$kernel_lane_cpu

kernel_lane_boot_image "$vmlinuz" "$kver" "$work"
initrd="$work/initramfs-boot-$kver.cpio"
"$here/build_initramfs.sh" "$initrd" "$kver" "$here/guest.sh" "$deb" ||
    { echo "package boot FAILED: building the initramfs failed"; exit 1; }

log="$work/serial.log"
booted=$(date +%s.%N)
kernel_lane_cpu_now "$work/times"
cpu_before=$kernel_lane_cpu
# The lines the results file's rows are made of (kernel_lane_rows): guest.sh's steps and its result.
steps='^(HMDNODE_BOOT: \[|HMDNODE_BOOT_RESULT: )'
rm -f "$work/qemu.pid" "$log"
: >"$log"
[ "$write_docs" = 1 ] && kernel_lane_sample "$work/qemu.pid" "$log" "$steps" "$work/samples"
read -r up_start _ </proc/uptime
# shellcheck disable=SC2086
timeout 500 qemu-system-x86_64 -accel tcg -cpu max -m 2048 -smp 2 -nodefaults -no-user-config \
    -display none -serial stdio -no-reboot $bios -kernel "$kernel" -initrd "$initrd" \
    -virtfs local,path=/,mount_tag=host,security_model=none,readonly=on,multidevs=remap \
    -pidfile "$work/qemu.pid" \
    -append "console=ttyS0 quiet panic=-1 mitigations=off systemd.unit=hmdnode-boot.target systemd.show_status=0" \
    </dev/null >>"$log" 2>&1
qemu_status=$?
read -r up_end _ </proc/uptime
end=$(date +%s.%N)
kernel_lane_cpu_now "$work/times"
cpu_after=$kernel_lane_cpu
tr -d '\r' <"$log" | grep -v '^$' | sed 's/^/guest| /'
# The guest's CPU time (qemu's, user + system; from `times`: the shell's children) says what the
# wall time would be on an idle machine, where the guest's vCPUs get whole cores.
qemu_cpu=$(echo "$cpu_after $cpu_before" | awk '{ printf "%.2f", $1 - $2 }')
times=$(echo "$start $packed $booted $end $qemu_cpu" |
    awk '{ printf "%.1f s wall: cpack %.1f s, guest %.1f s (qemu CPU %.1f s)", $4 - $1, $2 - $1, $4 - $3, $5 }')
if [ $qemu_status -eq 124 ]; then
    echo "package boot FAILED: the guest did not finish within 500 s ($times)"
    exit 1
fi
if grep -q "HMDNODE_BOOT_RESULT: PASS" "$log"; then
    echo "package boot PASSED in $times (kernel $kver, $(basename "$kernel"))"
    [ "$write_docs" = 1 ] && { write_result || exit 1; }
    exit 0
fi
echo "package boot FAILED ($times): no PASS marker from the guest; serial log: $log"
exit 1
