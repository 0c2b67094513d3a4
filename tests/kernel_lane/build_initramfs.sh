#!/bin/sh
# Builds the real-kernel lane's initramfs (uncompressed newc cpio): busybox, the kernel modules of
# uhid/hid-generic, vivid and bochs (with their dependencies, in load order, from the same kernel as
# the image qemu boots), the lane program with its shared libraries, and an /init that loads the
# modules, runs the program and powers off. docs/hardware.md.
#
# usage: build_initramfs.sh LANE_BINARY OUT.cpio KVER
set -eu
lane=$1
out=$2
kver=$3

root=$(mktemp -d "${TMPDIR:-/tmp}/hmdnode-initramfs.XXXXXX")
trap 'rm -rf "$root"' EXIT
mkdir -p "$root/bin" "$root/dev" "$root/proc" "$root/sys" "$root/tmp" "$root/run" "$root/modules"

busybox=$(command -v busybox)
case "$(file -b "$busybox" 2>/dev/null || echo static)" in
*dynamically*) echo "build_initramfs: $busybox is not static (install busybox-static)" >&2; exit 2 ;;
esac
cp "$busybox" "$root/bin/busybox"
for a in sh mount insmod poweroff echo cat ls sleep mkdir; do ln -s busybox "$root/bin/$a"; done

# Modules in load order, each once; .xz/.zst decompressed (busybox insmod cannot).

: >"$root/modules/load.list"
for m in hid-generic uhid vivid bochs; do
    modprobe -S "$kver" --show-depends "$m" | while read -r verb path rest; do
        [ "$verb" = insmod ] || continue
        name=$(basename "$path")
        name=${name%.xz}
        name=${name%.zst}
        if grep -q "^$name " "$root/modules/load.list"; then continue; fi
        case "$path" in
        *.xz) xz -dc "$path" >"$root/modules/$name" ;;
        *.zst) zstd -qdc "$path" >"$root/modules/$name" ;;
        *) cp "$path" "$root/modules/$name" ;;
        esac
        args=""
        [ "$m" = vivid ] && [ "$name" = vivid.ko ] &&
            args="n_devs=1 node_types=0x1 num_inputs=1 input_types=0x0"
        echo "$name $args" >>"$root/modules/load.list"
    done
done

# The lane program and every shared library it needs (ldd), at the same paths.
cp "$lane" "$root/bin/lane"
ldd "$lane" | awk '/=>/ { print $3 } /^\t\// { print $1 }' | while read -r lib; do
    [ -f "$lib" ] || continue
    mkdir -p "$root$(dirname "$lib")"
    cp -L "$lib" "$root$lib"
done
# The dynamic loader is also looked up as /lib64/ld-linux-x86-64.so.2.
if [ -f /lib64/ld-linux-x86-64.so.2 ] && [ ! -e "$root/lib64/ld-linux-x86-64.so.2" ]; then
    mkdir -p "$root/lib64"
    cp -L /lib64/ld-linux-x86-64.so.2 "$root/lib64/"
fi

cat >"$root/init" <<'INIT'
#!/bin/sh
mount -t proc proc /proc
mount -t sysfs sysfs /sys
mount -t devtmpfs devtmpfs /dev
mount -t tmpfs tmpfs /run
while read -r name args; do
    insmod /modules/$name $args || echo "lane: insmod $name failed"
done </modules/load.list
/bin/lane
echo "HMDNODE_KERNEL_LANE_EXIT: $?"
poweroff -f
INIT
chmod +x "$root/init"

(cd "$root" && find . | cpio -o -H newc --quiet) >"$out.tmp"
mv "$out.tmp" "$out"
echo "build_initramfs: $out ($(du -k "$out" | cut -f1) KiB, kernel $kver)"
