#!/bin/sh
# Builds the real-kernel lane's initramfs (uncompressed newc cpio): busybox, the kernel modules of
# uhid/hid-generic, vivid, bochs and the 9p share over virtio (with their dependencies, in load
# order, from the same kernel as the image qemu boots), and an /init that loads the modules, mounts
# the host's root filesystem read-only from qemu's 9p share (mount tag "host"), chroots into it and
# runs the lane program there, so that the program, its shared libraries, Mesa and the demo scene
# are the host's own files at their own paths (nothing is copied in); then powers off.
# docs/hardware.md.
#
# usage: build_initramfs.sh LANE_BINARY DEMO_SCENE OUT.cpio KVER   (LANE and SCENE: host paths)
# HMDNODE_LANE_RENDERERS (gles, vulkan or both; default gles) is the lane program's second
# argument: which renderers' frames the KMS runs show (lane_main.cpp).
set -eu
lane=$(realpath "$1")
scene=$(realpath "$2")
out=$3
kver=$4
renderers=${HMDNODE_LANE_RENDERERS:-gles}
case "$renderers" in
gles | vulkan | both) ;;
*) echo "build_initramfs: HMDNODE_LANE_RENDERERS=$renderers (gles, vulkan or both)" >&2; exit 2 ;;
esac

root=$(mktemp -d "${TMPDIR:-/tmp}/hmdnode-initramfs.XXXXXX")
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/bin" "$root/dev" "$root/proc" "$root/sys" "$root/host" "$root/modules"

busybox=$(command -v busybox)
case "$(file -b "$busybox" 2>/dev/null || echo static)" in
*dynamically*) echo "build_initramfs: $busybox is not static (install busybox-static)" >&2; exit 2 ;;
esac
cp "$busybox" "$root/bin/busybox"
for a in sh mount insmod poweroff echo cat chroot; do ln -s busybox "$root/bin/$a"; done

# Modules in load order, each once (tests/kernel_lane/lib.sh). vivid: one instance with a video
# capture node (/dev/video0: input 0 a webcam, input 1 HDMI; input_types has two bits an input, 00
# webcam, 11 HDMI) and a video output node (/dev/video1: one HDMI output), which vivid loops back
# to its HDMI input when both have the same size and format (the lane's loopback, lane_main.cpp 8).
. "$(dirname "$0")/lib.sh"
kernel_lane_modules "$root" "$kver" hid-generic uhid vivid bochs virtio_pci 9pnet_virtio 9p
vivid_args="n_devs=1 node_types=0x101 num_inputs=2 input_types=0xc num_outputs=1 output_types=0x1"
sed -i "s/^vivid\\.ko\$/vivid.ko $vivid_args vid_cap_nr=0 vid_out_nr=1/" "$root/modules/load.list"

# note: the share is mounted over directories of a read-only filesystem; proc, sys, dev and run are
# mounted on the host's own mount points inside it (mounting does not write to it). Not /tmp: the
# lane program and the scene may live there (a checkout under /tmp), and a tmpfs over it hid them;
# the guest's scratch space (HOME, TMPDIR) is the tmpfs on /run.
cat >"$root/init" <<INIT
#!/bin/sh
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
while read -r name args; do
    insmod /modules/\$name \$args || echo "lane: insmod \$name failed"
done </modules/load.list
if mount -t 9p -o trans=virtio,version=9p2000.L,ro,cache=loose,msize=512000 host /host; then
    mount -t proc proc /host/proc
    mount -t sysfs sysfs /host/sys
    mount -t devtmpfs devtmpfs /host/dev
    mount -t tmpfs tmpfs /host/run
    HOME=/run TMPDIR=/run chroot /host '$lane' '$scene' $renderers
    echo "HMDNODE_KERNEL_LANE_EXIT: \$?"
else
    echo "lane: mounting the host's 9p share failed"
    echo "HMDNODE_KERNEL_LANE_EXIT: 1"
fi
poweroff -f
INIT
chmod +x "$root/init"

(cd "$root" && find . | cpio -o -H newc --quiet) >"$out.tmp"
mv "$out.tmp" "$out"
echo "build_initramfs: $out ($(du -k "$out" | cut -f1) KiB, kernel $kver)"
