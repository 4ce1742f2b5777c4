#!/bin/sh
# `make test-package`: installs the Debian package on this machine with dpkg -i, as the CI
# does (as root), checks what it installed and made, then removes and purges it, leaving the
# machine as it was. Refuses a machine where gaugeloop is installed or has its user or
# directories: purging would delete them. Usage: packaging/test_package.sh BUILD_DIR
set -eu

build=${1:-build}
example=/usr/share/doc/gaugeloop/examples/service/gaugeloop.toml
wants=/etc/systemd/system/multi-user.target.wants/gaugeloop.service

fail() {
    echo "test-package FAILED: $*" >&2
    exit 1
}

set -- "$build"/gaugeloop_*.deb
if [ $# != 1 ] || [ ! -f "$1" ]; then fail "not one $build/gaugeloop_*.deb but: $*; make package builds it"; fi
deb=$1
[ "$(id -u)" = 0 ] || fail "dpkg -i needs root: run it as root (the CI does), on a machine without gaugeloop"
if dpkg-query -W -f '${Status}' gaugeloop 2>/dev/null | grep -q installed; then
    fail "gaugeloop is installed here; test-package would purge it and its runs"
fi
if getent passwd gaugeloop >/dev/null || [ -e /etc/gaugeloop ] || [ -e /var/lib/gaugeloop ]; then
    fail "this machine has a gaugeloop user, /etc/gaugeloop or /var/lib/gaugeloop; purging would delete them"
fi
trap 'dpkg --purge gaugeloop >/dev/null 2>&1 || true' EXIT

echo "== dpkg -i $deb"
dpkg -i "$deb"
/usr/bin/gaugeloop --version
/usr/bin/gaugeloop serve --check --config "$example"
getent passwd gaugeloop >/dev/null || fail "no user gaugeloop"
id -nG gaugeloop | grep -qw dialout || fail "gaugeloop is not in dialout: $(id -nG gaugeloop)"
[ "$(stat -c '%U:%G %a' /etc/gaugeloop)" = "root:gaugeloop 750" ] ||
    fail "/etc/gaugeloop is $(stat -c '%U:%G %a' /etc/gaugeloop), not root:gaugeloop 750"
grep -qx 'ExecStart=/usr/bin/gaugeloop serve --config /etc/gaugeloop/gaugeloop.toml' \
    /lib/systemd/system/gaugeloop.service || fail "the unit does not start /usr/bin/gaugeloop"
[ ! -e "$wants" ] || fail "the unit was enabled without a configuration"

echo "== dpkg -r: the runs, the configuration and the user stay"
dpkg -r gaugeloop
[ ! -e /usr/bin/gaugeloop ] || fail "/usr/bin/gaugeloop left after dpkg -r"
if [ ! -d /var/lib/gaugeloop ] || [ ! -d /etc/gaugeloop ] || ! getent passwd gaugeloop >/dev/null; then
    fail "dpkg -r deleted the runs, the configuration or the user"
fi

echo "== dpkg -i with a configuration: enabled"
printf 'machine = "test-package"\n' >/etc/gaugeloop/gaugeloop.toml
dpkg -i "$deb"
[ -L "$wants" ] || fail "a configuration exists, but the unit was not enabled"

echo "== dpkg --purge: all gone"
dpkg --purge gaugeloop
for p in /var/lib/gaugeloop /etc/gaugeloop "$wants" /etc/systemd/system/gaugeloop.service; do
    if [ -e "$p" ] || [ -L "$p" ]; then fail "$p left after dpkg --purge"; fi
done
! getent passwd gaugeloop >/dev/null || fail "user gaugeloop left after dpkg --purge"
! getent group gaugeloop >/dev/null || fail "group gaugeloop left after dpkg --purge"
trap - EXIT
echo "test-package: passed"
