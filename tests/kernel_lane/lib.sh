# Sourced by the real-kernel lanes (tests/kernel_lane, tests/package_boot): what qemu boots, the
# modules their initramfs loads, and the results file each writes when asked (HMDNODE_WRITE_DOCS=1).
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

# The lanes' results files (HMDNODE_WRITE_DOCS=1: docs/results/kernel-lane.md and
# package-boot.md, listed in docs/results/README.md): the machine, the command, the date, what was
# measured and one table of the run, one row per line the guest printed, with the wall time and
# qemu's CPU time of each.
#
# kernel_lane_cpu_now FILE   sets $kernel_lane_cpu to the CPU seconds (user + system) of the
#        calling shell's waited-for children so far (`times`, through FILE: in $(...) the subshell
#        has no children of its own).
kernel_lane_cpu_now() {
    times >"$1"
    kernel_lane_cpu=$(tail -n 1 "$1" | tr 'ms' '  ' | awk '{ printf "%.2f", $1 * 60 + $2 + $3 * 60 + $4 }')
}

# kernel_lane_sample PIDFILE LOG PATTERN OUT   starts a sampler detached from the caller (its own
#        CPU is not among the caller's children's in `times`): once the process whose pid qemu
#        writes to PIDFILE (-pidfile) runs, every 0.25 s it appends "LINES UPTIME TICKS" to OUT --
#        how many lines of LOG match the extended regular expression PATTERN, the host's
#        /proc/uptime and that process's user + system CPU in clock ticks -- and "end" once the
#        process is gone (or has not appeared within 20 s).
kernel_lane_sample() {
    rm -f "$4"
    (_kernel_lane_sampler "$@" </dev/null >/dev/null 2>&1 &)
}
_kernel_lane_sampler() {
    _pidfile=$1 _log=$2 _pattern=$3 _out=$4
    _i=0
    until [ -s "$_pidfile" ]; do
        _i=$((_i + 1))
        if [ $_i -gt 400 ]; then echo end >>"$_out"; return; fi
        sleep 0.05
    done
    read -r _pid <"$_pidfile"
    while { read -r _stat <"/proc/$_pid/stat"; } 2>/dev/null; do
        read -r _up _idle </proc/uptime
        _n=$(grep -c -a -E "$_pattern" "$_log" 2>/dev/null)
        # shellcheck disable=SC2086 # the fields of /proc/PID/stat, split on purpose (14: utime, 15: stime)
        set -- $_stat
        echo "${_n:-0} $_up $((${14} + ${15}))" >>"$_out"
        sleep 0.25
    done
    echo end >>"$_out"
}

# kernel_lane_wait_samples OUT   waits (at most 5 s) for the sampler's "end" line.
kernel_lane_wait_samples() {
    _i=0
    while ! grep -qx end "$1" 2>/dev/null && [ $_i -lt 50 ]; do
        _i=$((_i + 1))
        sleep 0.1
    done
}

# kernel_lane_rows SAMPLES LOG PATTERN SED UP_START UP_END QEMU_CPU   prints the table rows of the
#        guest: the lines of LOG (\r removed) that match PATTERN -- the lines the sampler counted --
#        turned by the sed script SED (run with -n; one output line per input line) into
#        "TIME<tab>RESULT<tab>TEXT" (TIME: the guest's timestamp in seconds, or - for none). Row
#        k's qemu CPU is read from the first sample that counted k lines; its wall time is the
#        difference of the guest's timestamps from the row above where both have one, else of the
#        samples' host uptimes. The first row runs from qemu's start (UP_START, host uptime); a
#        last row, power-off, to its exit (UP_END; QEMU_CPU, its whole CPU in seconds). TEXT
#        splits at its first ": " outside parentheses into the step and its figures.
kernel_lane_rows() {
    tr -d '\r' <"$2" | grep -a -E "$3" | sed -n -e "$4" |
        awk -F '\t' -v samples="$1" -v up_start="$5" -v up_end="$6" -v qemu_cpu="$7" \
            -v tck="$(getconf CLK_TCK 2>/dev/null || echo 100)" '
        BEGIN {
            n = 0
            while ((getline line < samples) > 0) {
                if (line == "end") continue
                split(line, f, " ")
                n++; lines[n] = f[1]; ups[n] = f[2]; cpus[n] = f[3] / tck
            }
            j = 1; prev_up = up_start; prev_cpu = 0; prev_t = "-"
        }
        function esc(s) { gsub(/\|/, "\\|", s); return s == "" ? "-" : s }
        function split_text(s,   i, c, depth) {
            depth = 0
            for (i = 1; i < length(s); i++) {
                c = substr(s, i, 1)
                if (c == "(") depth++
                else if (c == ")") depth--
                else if (depth == 0 && c == ":" && substr(s, i + 1, 1) == " ") {
                    step = substr(s, 1, i - 1); figures = substr(s, i + 2); return
                }
            }
            step = s; figures = ""
        }
        function row(s, result, wall, cpu, figs) {
            printf "| %s | %s | %.2f | %.1f | %s |\n", esc(s), esc(result), wall, cpu, esc(figs)
        }
        {
            while (j <= n && lines[j] < NR) j++
            if (j <= n) { up = ups[j]; cpu = cpus[j] } else { up = up_end; cpu = qemu_cpu }
            if (NR == 1) { step = "boot: qemu start to the first line"; figures = $3 }
            else split_text($3)
            wall = ($1 != "-" && prev_t != "-") ? $1 - prev_t : up - prev_up
            row(step, $2, wall, cpu - prev_cpu, figures)
            prev_up = up; prev_cpu = cpu; prev_t = $1
        }
        END { row("power-off: the last line to qemu'"'"'s exit", "-", up_end - prev_up, qemu_cpu - prev_cpu, "") }'
}

# kernel_lane_in_tree SOURCE_DIR PATH   PATH relative to SOURCE_DIR when it lies inside it, so
#        that a command quoted in a results file reads the same on every checkout.
kernel_lane_in_tree() {
    case "$2" in
    "$1"/*) echo "${2#"$1"/}" ;;
    *) echo "$2" ;;
    esac
}

# kernel_lane_write_result SOURCE_DIR NAME TITLE COMMAND RENDERER BODY_FILE   writes
#        SOURCE_DIR/docs/results/NAME.md atomically (a temporary file in that folder, renamed): the
#        title; the machine (CPU model, hardware threads, the host's kernel, qemu's version, the
#        guest's kernel $kver, RENDERER in the guest when known); COMMAND; today's date (UTC); then
#        BODY_FILE (what was measured, the table, what its columns mean).
kernel_lane_write_result() {
    _dir="$1/docs/results"
    [ -d "$_dir" ] || { echo "cannot write $_dir/$2.md: no such folder"; return 1; }
    _cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -n 1)
    _machine="${_cpu:-unknown CPU}, $(nproc) hardware threads, Linux $(uname -r);"
    _machine="$_machine $(qemu-system-x86_64 --version | head -n 1); guest kernel $kver"
    [ -z "$5" ] || _machine="$_machine; renderer $5 in the guest"
    _tmp=$(mktemp "$_dir/.$2.md.XXXXXX") || return 1
    # shellcheck disable=SC2016 # the backquotes are markdown's
    if {
        printf '# %s\n\n' "$3"
        printf -- '- Machine: %s\n' "$_machine"
        printf -- '- Command: `%s`\n' "$4"
        printf -- '- Date: %s\n\n' "$(date -u +%Y-%m-%d)"
        cat "$6"
        printf '\n<!-- Written by the command above (tests/kernel_lane/lib.sh, kernel_lane_write_result): edit the lane, not this file. -->\n'
    } >"$_tmp" && chmod 644 "$_tmp" && mv -f "$_tmp" "$_dir/$2.md"; then
        echo "wrote docs/results/$2.md"
        return 0
    fi
    rm -f "$_tmp"
    echo "cannot write $_dir/$2.md"
    return 1
}
