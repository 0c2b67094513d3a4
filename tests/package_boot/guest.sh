#!/bin/sh
# Runs inside the package boot test's guest (tests/package_boot/run.sh), as root, as a service of
# the guest's systemd (PID 1), on an overlay of the host's root: installs the package for real and
# runs the daemon as its unit, checking each step. Prints one line per check and
# `HMDNODE_BOOT_RESULT: PASS|FAIL`. docs/daemon.md, "The package on a booted system".
#
# usage: guest.sh DEB
deb=$1
failed=0
t0=$(cut -d' ' -f1 /proc/uptime)
step() { printf 'HMDNODE_BOOT: [%6.1f s] %s\n' "$(cut -d' ' -f1 /proc/uptime)" "$*"; }
ok() { step "ok: $*"; }
bad() { step "FAIL: $*"; failed=1; }
check() {  # check WHAT COMMAND...: runs COMMAND, output indented; ok/FAIL by its status
    what=$1
    shift
    if out=$("$@" 2>&1); then ok "$what"; else bad "$what (exit $?)"; fi
    [ -z "$out" ] || printf '%s\n' "$out" | sed 's/^/    /'
}
finish() {
    if [ $failed -eq 0 ]; then echo "HMDNODE_BOOT_RESULT: PASS"; else echo "HMDNODE_BOOT_RESULT: FAIL"; fi
    exit $failed
}
step "systemd $(systemctl --version | head -n 1 | cut -d' ' -f2) is PID 1 ($(cat /proc/1/comm)); booted to the test in $t0 s"

# The package, as an integrator installs it: dpkg runs the maintainer scripts (postinst: the
# service user by systemd-sysusers, udev's rules reloaded, systemd's units reloaded).
[ -d /run/udev ] && udevadm control --ping && ok "udevd runs (the postinst reloads its rules)" ||
    bad "udevd is not running"
getent passwd hmdnode >/dev/null && bad "user hmdnode exists before the install"
check "dpkg -i $(basename "$deb")" dpkg -i "$deb"
status=$(dpkg-query -W -f='${Package} ${Version}: ${Status}' hmdnode 2>&1)
[ "$status" = "hmdnode $(dpkg-deb -f "$deb" Version): install ok installed" ] && ok "dpkg: $status" ||
    bad "not installed: $status"
if getent passwd hmdnode >/dev/null; then
    ok "postinst created the user: $(id hmdnode)"
    id -nG hmdnode | tr ' ' '\n' | grep -qx plugdev || bad "hmdnode is not in plugdev"
else
    bad "no user hmdnode after the install"
fi
# Any message of verify, warnings included, fails.
if out=$(systemd-analyze verify /lib/systemd/system/hmdnoded.service 2>&1) && [ -z "$out" ]; then
    ok "systemd-analyze verify /lib/systemd/system/hmdnoded.service: clean"
else
    bad "systemd-analyze verify"
    printf '%s\n' "$out" | sed 's/^/    /'
fi

# The service, on the installed config and unit with one change that the emulated CPU makes
# necessary (a TCG guest runs lavapipe some 30 times slower than the host; docs/daemon.md): a small
# mock panel (the start renders the demo room some 50 times to learn its frame cost; at the
# config's 360x400 per eye one frame can pass the renderer's 20 s fence timeout). The unit's own
# TimeoutStartSec=60 stands: while that calibration goes on, the daemon extends it
# (EXTEND_TIMEOUT_USEC), so a slow start that progresses is not killed and a hung one is. Everything
# else -- the scene, the trace on the real clock, the frame loop's real-time priority, the status
# file and the control socket -- is the installed config's, but for node.cpu_wake "off": the
# guest has no cpuidle driver, so "auto" would spin a thread on each vCPU, and under TCG every
# spinning vCPU is a host core taken from the renderer in the guest and from the rest of the
# suite beside it (the host's other tests), for nothing a test here reads.
cfg=/etc/hmdnode/hmdnoded.json
sed -i -e 's/"eye_width": [0-9]*/"eye_width": 96/' -e 's/"eye_height": [0-9]*/"eye_height": 96/' \
    -e 's/"node": {/"node": {\n    "cpu_wake": "off",/' "$cfg"
grep -q '"eye_width": 96' "$cfg" && grep -q '"eye_height": 96' "$cfg" &&
    grep -q '"cpu_wake": "off"' "$cfg" &&
    ok "$cfg: display.eye_width/eye_height set to 96x96, node.cpu_wake off (the rest as installed)" ||
    bad "could not set the eye size and cpu_wake in $cfg"
step "systemctl start hmdnoded (Type=notify: returns once the daemon sent READY=1)"
check "systemctl start hmdnoded" systemctl start hmdnoded
# One systemctl call per look (each costs seconds in the guest while the daemon renders). STATUS=
# with the figures comes every status window (status.every_s, 5 s in the installed config).
prop() { printf '%s\n' "$props" | sed -n "s/^$1=//p"; }  # prop NAME: from the last $props
i=0
while :; do
    props=$(systemctl show -p ActiveState,MainPID,StatusText hmdnoded)
    text=$(prop StatusText)
    case "$text" in frames\ *) break ;; esac
    i=$((i + 1))
    if [ $i -gt 30 ] || [ "$(prop ActiveState)" != active ]; then break; fi
    sleep 1
done
state=$(prop ActiveState)
if [ "$state" = active ]; then ok "hmdnoded is $state"; else bad "hmdnoded is $state, not active"; fi
pid=$(prop MainPID)
user=$(stat -c %U "/proc/$pid" 2>/dev/null)
if [ "$user" = hmdnode ]; then
    ok "its main process $pid runs as $user ($(tr '\0' ' ' <"/proc/$pid/cmdline"))"
else
    bad "main process $pid runs as '$user', not hmdnode"
fi
case "$text" in
frames\ *) ok "StatusText: $text" ;;
*) bad "no figures in StatusText after $i polls: '$text'" ;;
esac
# The control socket (control.path /run/hmdnode/control, group hmdnode), asked by root.
if out=$(hmdnode ctl status 2>&1) && printf '%s\n' "$out" | grep -q '"window_frames"'; then
    ok "hmdnode ctl status answers: $(printf '%s\n' "$out" | grep -m1 -o '"frames": [0-9]*')"
else
    bad "hmdnode ctl status"
    printf '%s\n' "$out" | sed 's/^/    /'
fi
# Still the process that became ready: the watchdog (WatchdogSec=10) did not kill it, nothing
# restarted it (NRestarts is cleared by a stop, so it is read before).
props=$(systemctl show -p MainPID,NRestarts hmdnoded)
if [ "${pid:-0}" != 0 ] && [ "$(prop MainPID)" = "$pid" ] && [ "$(prop NRestarts)" = 0 ]; then
    ok "still main process $pid, NRestarts=0"
else
    bad "restarted: main process $(prop MainPID) (was $pid), NRestarts=$(prop NRestarts)"
fi
check "systemctl stop hmdnoded" systemctl stop hmdnoded
props=$(systemctl show -p ActiveState,Result,ExecMainStatus hmdnoded)
result="$(prop ActiveState) $(prop Result) $(prop ExecMainStatus)"
if [ "$result" = "inactive success 0" ]; then
    ok "stopped cleanly: inactive, Result=success, ExecMainStatus=0"
else
    bad "not stopped cleanly: ActiveState, Result, ExecMainStatus = $result"
fi
if journalctl -u hmdnoded --no-pager -o cat 2>&1 | grep -q -e 'Watchdog timeout' -e 'Scheduled restart'; then
    bad "the journal shows a watchdog timeout or a restart"
fi
step "the journal of hmdnoded:"
journalctl -u hmdnoded --no-pager -o cat 2>&1 | tail -n 30 | sed 's/^/    /'
finish
