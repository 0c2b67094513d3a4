#!/bin/sh
# Builds the package boot test's initramfs (uncompressed newc cpio): busybox (static), the modules
# of the 9p share over virtio and of overlayfs (with their dependencies, from the same kernel as
# the image qemu boots), and an /init that makes the guest's root an overlay -- the host's root
# filesystem from qemu's 9p share (mount tag "host", read-only) as the lower layer, a tmpfs as the
# upper -- writes the test's units into the upper layer's /etc/systemd/system and switch_roots into
# it with the host's own systemd as PID 1. The kernel command line's `systemd.unit=` starts the
# test's target (hmdnode-boot.target), whose service runs GUEST_SCRIPT DEB (host paths, seen in
# the guest at the same paths) with its output on the serial console, then powers the guest off.
# docs/daemon.md, "The package on a booted system".
#
# usage: build_initramfs.sh OUT.cpio KVER GUEST_SCRIPT DEB
set -eu
out=$1
kver=$2
guest=$(realpath "$3")
deb=$(realpath "$4")
here=$(cd "$(dirname "$0")" && pwd)
. "$here/../kernel_lane/lib.sh"

root=$(mktemp -d "${TMPDIR:-/tmp}/hmdnode-boot-initramfs.XXXXXX")
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/bin" "$root/dev" "$root/proc" "$root/sys" "$root/lower" "$root/rw" "$root/root"

busybox=$(command -v busybox)
case "$(file -b "$busybox" 2>/dev/null || echo static)" in
*dynamically*) echo "build_initramfs: $busybox is not static (install busybox-static)" >&2; exit 2 ;;
esac
cp "$busybox" "$root/bin/busybox"
for a in sh mount insmod mkdir cat echo rm ln switch_root poweroff; do ln -s busybox "$root/bin/$a"; done
kernel_lane_modules "$root" "$kver" virtio_pci 9pnet_virtio 9p overlay

# The test's units, written into the upper layer (the host's /etc is not changed). The target
# wants only the test service, so the guest starts what that service needs (sysinit.target and
# basic.target by its default dependencies, as on any booted box) and nothing of the host's
# multi-user.target. The service's stdout and stderr go to the serial console; when it ends,
# whatever its result, the guest powers off (the host reads the result marker it printed).
mkdir -p "$root/units"
cat >"$root/units/hmdnode-boot.target" <<UNIT
[Unit]
Description=hmdnode package boot test
Wants=hmdnode-boot.service
AllowIsolate=yes
UNIT
cat >"$root/units/hmdnode-boot.service" <<UNIT
[Unit]
Description=hmdnode package boot test: dpkg -i, systemctl start hmdnoded, checks
SuccessAction=poweroff-force
FailureAction=poweroff-force

[Service]
Type=oneshot
ExecStart=/bin/sh '$guest' '$deb'
StandardOutput=tty
StandardError=tty
TTYPath=/dev/ttyS0
Environment=SYSTEMD_PAGER= SYSTEMD_COLORS=0 LANG=C.UTF-8
UNIT

# Masked in the guest (links to /dev/null in the upper layer's /etc/systemd): what a booted box
# runs but this test does not need and a TCG guest pays for. Every generator (no fstab, disks,
# gettys or SysV scripts here); systemd-tmpfiles-setup (it would empty the host's /tmp in the
# overlay, over 9p); udev's coldplug (the guest has no device of ours: its uevents would only keep
# udevd's workers busy; udevd itself runs, for the postinst's rules reload); the persistent
# journal's flush, the network time, binfmt, sysctl, utmp, the random seed, kernel modules and
# the boot-time sysusers (the postinst runs sysusers for the package itself); the API file systems
# nothing here uses.
ls /lib/systemd/system-generators >"$root/units/generators.mask" 2>/dev/null || true
cat >"$root/units/units.mask" <<MASK
systemd-tmpfiles-setup.service
systemd-tmpfiles-clean.timer
systemd-udev-trigger.service
systemd-journal-flush.service
systemd-timesyncd.service
systemd-binfmt.service
proc-sys-fs-binfmt_misc.automount
systemd-sysctl.service
systemd-update-utmp.service
systemd-random-seed.service
systemd-modules-load.service
kmod-static-nodes.service
modprobe@.service
systemd-sysusers.service
systemd-pstore.service
dev-hugepages.mount
dev-mqueue.mount
sys-kernel-debug.mount
sys-kernel-tracing.mount
sys-kernel-config.mount
sys-fs-fuse-connections.mount
timers.target
MASK

cat >"$root/init" <<'INIT'
#!/bin/sh
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
exec </dev/console >/dev/console 2>&1
while read -r name; do
    insmod /modules/$name || echo "HMDNODE_BOOT: insmod $name failed"
done </modules/load.list
fail() {
    echo "HMDNODE_BOOT: $*"
    echo "HMDNODE_BOOT_RESULT: FAIL"
    poweroff -f
}
mount -t 9p -o trans=virtio,version=9p2000.L,ro,cache=loose,msize=512000 host /lower ||
    fail "mounting the host's 9p share failed"
mount -t tmpfs -o mode=0755 tmpfs /rw || fail "tmpfs"
mkdir -p /rw/upper /rw/work
mount -t overlay -o lowerdir=/lower,upperdir=/rw/upper,workdir=/rw/work overlay /root ||
    fail "mounting the overlay (9p lower, tmpfs upper) failed"
# note: a host that is itself a container has /.dockerenv; systemd finding it would take the guest
# for a container and ignore the kernel command line (the test's systemd.unit=).
rm -f /root/.dockerenv /root/run/.containerenv
mkdir -p /root/etc/systemd/system /root/etc/systemd/system-generators
while read -r u; do ln -sf /dev/null /root/etc/systemd/system/$u; done </units/units.mask
while read -r g; do ln -sf /dev/null /root/etc/systemd/system-generators/$g; done </units/generators.mask
cat /units/hmdnode-boot.target >/root/etc/systemd/system/hmdnode-boot.target
cat /units/hmdnode-boot.service >/root/etc/systemd/system/hmdnode-boot.service
for m in dev sys proc; do mount -o move /$m /root/$m || fail "moving /$m into the new root"; done
exec switch_root /root /lib/systemd/systemd
INIT
chmod +x "$root/init"

(cd "$root" && find . | cpio -o -H newc --quiet) >"$out.tmp"
mv "$out.tmp" "$out"
echo "build_initramfs: $out ($(du -k "$out" | cut -f1) KiB, kernel $kver)"
