#!/bin/sh
# The Debian package as an integrator gets it: cpack builds hmdnode_<version>_amd64.deb
# from the build tree; its contents and control fields are checked; it is unpacked into a scratch
# root (dpkg -x: files only, no maintainer scripts, no root needed); the unit is checked there with
# `systemd-analyze verify --root` (its ExecStart must exist and be executable in that root; any
# message, warnings included, fails the test); and the installed daemon runs the installed config
# (paths moved into the scratch root, simulated clock) for a few frames.
# This test needs no root and no VM. dpkg -i with the maintainer scripts (sysusers, udev reload),
# systemctl start to READY=1 and stop on a booted system are tests/package_boot/run.sh's (label
# kernel: a qemu guest with systemd as PID 1).
# Usage: run.sh BUILD_DIR WORK_DIR VERSION. Exit 77 (skip) without dpkg-deb.
set -eu
build=$1
work=$2
version=$3
command -v dpkg-deb >/dev/null 2>&1 || { echo "package: SKIPPED -- no dpkg-deb" >&2; exit 77; }
rm -rf "$work"
mkdir -p "$work"
cd "$work"

fail() { echo "package: FAIL: $*" >&2; exit 1; }

cpack --config "$build/CPackConfig.cmake" -B "$work" >cpack.log 2>&1 || { cat cpack.log; fail "cpack"; }
deb="$work/hmdnode_${version}_amd64.deb"
[ -f "$deb" ] || { ls "$work"; fail "no $deb"; }

dpkg-deb -c "$deb" | awk '{print $6}' >contents.txt
for f in ./usr/bin/hmdnoded ./usr/bin/hmdnode ./lib/systemd/system/hmdnoded.service \
         ./lib/udev/rules.d/70-hmdnode.rules ./etc/hmdnode/hmdnoded.json \
         ./usr/lib/sysusers.d/hmdnode.conf ./usr/share/hmdnode/demo_room.glb \
         ./usr/share/hmdnode/traces/corbillon2018_user1.csv \
         ./usr/share/hmdnode/traces/corbillon2018_user1_gaze.csv \
         ./usr/share/hmdnode/headsets/generic.json ./usr/share/doc/hmdnode/daemon.md \
         ./usr/share/doc/hmdnode/README.md; do
  grep -qx "$f" contents.txt || fail "$f is not in the package"
done
# Nothing of the build tree or the tests.
! grep -q -e '/test_' -e '\.a$' -e 'CMake' contents.txt || fail "build files in the package"

depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for p in libvulkan1 libegl1 libgles2 libegl-mesa0 libhidapi-hidraw0 libusb-1.0-0 libudev1 libpcap0.8 \
         libdrm2 libspdlog mesa-vulkan-drivers; do
  echo "$depends" | grep -q "$p" || fail "Depends lacks $p"
done
dpkg-deb -I "$deb" conffiles | grep -qx /etc/hmdnode/hmdnoded.json || fail "config not a conffile"
for s in postinst prerm postrm; do
  dpkg-deb -I "$deb" "$s" >/dev/null || fail "no $s"
done

root="$work/root"
dpkg -x "$deb" "$root"
exec_start=$(sed -n 's/^ExecStart=\([^ ]*\).*/\1/p' "$root/lib/systemd/system/hmdnoded.service")
[ -x "$root$exec_start" ] || fail "ExecStart $exec_start is not the installed daemon"
if command -v systemd-analyze >/dev/null 2>&1 && [ -d /lib/systemd/system ]; then
  # The host's units (targets, sysinit) beside the package's, so the unit's dependencies resolve.
  mkdir -p "$root/usr/lib/systemd/system"
  cp -a /lib/systemd/system/. "$root/usr/lib/systemd/system/"
  cp "$root/lib/systemd/system/hmdnoded.service" "$root/usr/lib/systemd/system/"
  systemd-analyze verify --root="$root" /lib/systemd/system/hmdnoded.service >verify.log 2>&1 ||
    { cat verify.log; fail "systemd-analyze verify"; }
  [ ! -s verify.log ] || { cat verify.log; fail "systemd-analyze verify printed messages"; }
  echo "systemd-analyze verify --root: clean"
else
  echo "systemd-analyze: not here; the unit was not verified" >&2
fi

# The installed daemon on the installed config, its data in the scratch root.
sed -e "s|/usr/share/hmdnode|$root/usr/share/hmdnode|g" -e "s|/run/hmdnode|$work|" \
    -e 's|"clock": "real"|"clock": "sim"|' -e 's|"realtime_priority": 20|"realtime_priority": 0|' \
    "$root/etc/hmdnode/hmdnoded.json" >"$work/hmdnoded.json"
"$root/usr/bin/hmdnoded" --config "$work/hmdnoded.json" --max-frames 3 >daemon.log 2>&1 ||
  { cat daemon.log; fail "the installed daemon on the installed config"; }
grep -q "stopped after 3 frames" daemon.log || { cat daemon.log; fail "daemon did not run 3 frames"; }
echo "package: OK ($deb)"
