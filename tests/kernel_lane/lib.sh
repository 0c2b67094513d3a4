# Sourced by the real-kernel lanes (tests/kernel_lane, tests/package_boot): what qemu boots and
# the modules their initramfs loads.
#
# kernel_lane_host: what the lanes need of this machine.
# usage: kernel_lane_host || skip "$kernel_lane_missing"   sets $vmlinuz (the newest
#        /boot/vmlinuz-*) and $kver (its version), or says in $kernel_lane_missing what is missing
#        (qemu, busybox, cpio, modprobe, a readable kernel image, its modules) and returns 1.
kernel_lane_host() {
    kernel_lane_missing=""
    command -v qemu-system-x86_64 >/dev/null 2>&1 ||
        kernel_lane_missing="qemu-system-x86_64 not installed (apt-get install qemu-system-x86)"
    command -v busybox >/dev/null 2>&1 ||
        kernel_lane_missing="busybox not installed (apt-get install busybox-static)"
    command -v cpio >/dev/null 2>&1 || kernel_lane_missing="cpio not installed"
    command -v modprobe >/dev/null 2>&1 || kernel_lane_missing="modprobe not installed (apt-get install kmod)"
    [ -z "$kernel_lane_missing" ] || return 1
    vmlinuz=$(ls -1 /boot/vmlinuz-* 2>/dev/null | sort -V | tail -n 1)
    if [ -z "$vmlinuz" ] || [ ! -r "$vmlinuz" ]; then
        kernel_lane_missing="no readable /boot/vmlinuz-* (apt-get install linux-image-amd64)"
        return 1
    fi
    kver=${vmlinuz#/boot/vmlinuz-}
    [ -d "/lib/modules/$kver" ] || { kernel_lane_missing="no /lib/modules/$kver for $vmlinuz"; return 1; }
}

# kernel_lane_boot_image: picks what qemu boots. The ELF vmlinux inside the bzImage boots directly (PVH entry) with qboot: about
# twice as fast as the bzImage through SeaBIOS. Found as the kernel's extract-vmlinux does: try
# every offset of a compression magic and keep the first that decompresses to an ELF file. Cached
# per kernel in WORK_DIR.
#
# usage: kernel_lane_boot_image VMLINUZ KVER WORK_DIR   sets $kernel (the image to pass to -kernel)
#        and $bios ("-bios /usr/share/qemu/qboot.rom" with the ELF vmlinux, "" with the bzImage).
kernel_lane_is_elf() { [ "$(head -c 4 "$1" 2>/dev/null | od -An -c | tr -d ' \n')" = '177ELF' ]; }
kernel_lane_boot_image() {
    _vmlinuz=$1
    _vmlinux="$3/vmlinux-$2"
    if ! kernel_lane_is_elf "$_vmlinux"; then
        _try() {  # _try MAGIC_GREP_PATTERN DECOMPRESSOR...
            _magic=$1
            shift
            for _off in $(LC_ALL=C grep -obUaP "$_magic" "$_vmlinuz" | cut -d: -f1); do
                tail -c +"$((_off + 1))" "$_vmlinuz" | "$@" >"$_vmlinux.tmp" 2>/dev/null
                if kernel_lane_is_elf "$_vmlinux.tmp"; then mv "$_vmlinux.tmp" "$_vmlinux"; return 0; fi
            done
            return 1
        }
        _try '\xfd7zXZ\x00' xz -dc ||
            _try '\x28\xb5\x2f\xfd' zstd -dc ||
            _try '\x1f\x8b\x08' gzip -dc ||
            _try '\x02\x21\x4c\x18' lz4 -dc ||
            true
        rm -f "$_vmlinux.tmp"
    fi
    bios=""
    if kernel_lane_is_elf "$_vmlinux" && [ -r /usr/share/qemu/qboot.rom ]; then
        kernel=$_vmlinux
        bios="-bios /usr/share/qemu/qboot.rom"
    else
        echo "kernel lane: could not extract an ELF vmlinux (or no qboot.rom): booting $_vmlinuz via SeaBIOS (slower)"
        kernel=$_vmlinuz
    fi
}

# usage: kernel_lane_modules ROOT KVER MODULE...   copies each MODULE of kernel KVER and its
#        dependencies, in `modprobe -S KVER --show-depends` load order and each once, into
#        ROOT/modules (decompressed when .xz/.zst: busybox insmod cannot) and appends their names to
#        ROOT/modules/load.list, one a line, for the /init to insmod in that order.
kernel_lane_modules() {
    _root=$1
    _kver=$2
    shift 2
    mkdir -p "$_root/modules"
    touch "$_root/modules/load.list"
    for _m in "$@"; do
        modprobe -S "$_kver" --show-depends "$_m" | while read -r _verb _path _rest; do
            [ "$_verb" = insmod ] || continue
            _name=$(basename "$_path")
            _name=${_name%.xz}
            _name=${_name%.zst}
            if grep -q "^$_name\$" "$_root/modules/load.list"; then continue; fi
            case "$_path" in
            *.xz) xz -dc "$_path" >"$_root/modules/$_name" ;;
            *.zst) zstd -qdc "$_path" >"$_root/modules/$_name" ;;
            *) cp "$_path" "$_root/modules/$_name" ;;
            esac
            echo "$_name" >>"$_root/modules/load.list"
        done
    done
}
