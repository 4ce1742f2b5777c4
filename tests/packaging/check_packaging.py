#!/usr/bin/env python3
"""Checks of the systemd unit and the installed tree, run by ctest (tests/packaging).

  check_packaging.py unit UNIT_FILE BINARY
      `systemd-analyze security --offline=true` rates the unit at most 2.5, and a unit with
      none of its hardening above that (so the check can fail); `systemd-analyze verify`
      prints nothing on it with ExecStart pointed at BINARY (verify wants the binary to
      exist); the settings the service relies on are there.
  check_packaging.py install BUILD_DIR SOURCE_DIR VERSION CMAKE
      `CMAKE --install` into a DESTDIR, for the configured prefix and for /usr (the Debian
      package's layout): the binary and nothing else in bin/, the unit naming that binary, the
      sysusers.d and tmpfiles.d entries, the docs and the examples; the installed binary's
      --version, and `serve --check` on the installed example config; the maintainer
      scripts parse (and pass shellcheck where it is installed).

Exit status 0: passed; 1: failed, each failure on a line of its own; 77: systemd-analyze is
not installed (ctest reports the test as skipped).
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

MAX_EXPOSURE = 2.5

# Settings the service and its docs rely on (docs/service.md), as the unit must say them.
REQUIRED = {
    "Type": "notify",
    "NotifyAccess": "main",
    "WatchdogSec": "30s",
    "User": "gaugeloop",
    "Group": "gaugeloop",
    "SupplementaryGroups": "dialout",
    "Restart": "on-failure",
    "RestartPreventExitStatus": "2",
    "UMask": "0027",
    "StateDirectory": "gaugeloop",
    "ProtectSystem": "strict",
    "CapabilityBoundingSet": "",
    "MemoryMax": "512M",
}

failures = []


def fail(message):
    failures.append(message)


def run(args, **kwargs):
    return subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kwargs)


def settings(text):
    """Every Key=Value line of a unit, a key given more than once as the list of its values."""
    found = {}
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith(("#", ";", "[")) or "=" not in line:
            continue
        key, value = line.split("=", 1)
        found.setdefault(key.strip(), []).append(value.strip())
    return found


def exposure(unit_path):
    """The overall exposure systemd-analyze gives the unit, and its whole output."""
    out = run(["systemd-analyze", "security", "--offline=true", "--no-pager", unit_path]).stdout
    m = re.search(r"Overall exposure level for \S+: (\d+(?:\.\d+)?)", out)
    return (float(m.group(1)) if m else None), out


def check_unit(unit_path, binary):
    if shutil.which("systemd-analyze") is None:
        print("systemd-analyze is not installed (Debian package systemd): unit not checked")
        sys.exit(77)
    with open(unit_path, encoding="utf-8") as f:
        text = f.read()
    found = settings(text)
    for key, value in REQUIRED.items():
        if value not in found.get(key, []):
            fail(f"{unit_path}: {key}={value} missing (has {found.get(key, 'nothing')})")

    level, out = exposure(unit_path)
    if level is None:
        fail(f"systemd-analyze security gave no overall exposure level:\n{out}")
    elif level > MAX_EXPOSURE:
        weak = "\n".join(line for line in out.splitlines() if line.startswith("✗"))
        fail(f"exposure {level} over {MAX_EXPOSURE}; what systemd-analyze holds against it:\n{weak}")
    else:
        print(f"exposure {level} (at most {MAX_EXPOSURE})")

    with tempfile.TemporaryDirectory(prefix="gaugeloop-unit-") as tmp:
        # The same check fails on the unit without its hardening: it can fail.
        bare = os.path.join(tmp, "bare", "gaugeloop.service")
        os.makedirs(os.path.dirname(bare))
        with open(bare, "w", encoding="utf-8") as f:
            f.write("[Service]\nType=notify\nExecStart=/usr/bin/true\n")
        bare_level, bare_out = exposure(bare)
        if bare_level is None or bare_level <= MAX_EXPOSURE:
            fail(f"a unit without hardening rated {bare_level}, not over {MAX_EXPOSURE}:\n{bare_out}")

        # verify wants the binary ExecStart names to exist: the build's, in a copy.
        installed = next((v.split()[0] for v in found.get("ExecStart", [])), "")
        if not installed.endswith("/gaugeloop"):
            fail(f"ExecStart names {installed!r}, not the gaugeloop binary")
        copy = os.path.join(tmp, "gaugeloop.service")
        with open(copy, "w", encoding="utf-8") as f:
            f.write(text.replace(installed, binary))
        verified = run(["systemd-analyze", "verify", copy])
        if verified.returncode != 0 or verified.stdout.strip():
            fail(f"systemd-analyze verify (exit status {verified.returncode}):\n{verified.stdout}")


def tree(root):
    """Every file under root, as paths relative to it."""
    files = set()
    for d, _, names in os.walk(root):
        for n in names:
            files.add(os.path.relpath(os.path.join(d, n), root))
    return files


def check_install(cmake, build_dir, source_dir, version, prefix, unit_dir):
    """`cmake --install` for `prefix` (None: the configured one) into a DESTDIR."""
    with tempfile.TemporaryDirectory(prefix="gaugeloop-install-") as destdir:
        args = [cmake, "--install", build_dir] + (["--prefix", prefix] if prefix else [])
        installed = run(args, env=dict(os.environ, DESTDIR=destdir))
        if installed.returncode != 0:
            fail(f"{' '.join(args)} failed:\n{installed.stdout}")
            return
        if prefix is None:
            m = re.search(r"CMAKE_INSTALL_PREFIX:PATH=(.*)", open(os.path.join(build_dir, "CMakeCache.txt")).read())
            prefix = m.group(1)
            unit_dir = prefix + "/lib/systemd/system"
        files = tree(destdir)
        root = destdir + prefix
        rel = prefix.lstrip("/")
        doc = f"{rel}/share/doc/gaugeloop"
        binaries = sorted(f for f in files if f.startswith(f"{rel}/bin/"))
        if binaries != [f"{rel}/bin/gaugeloop"]:
            fail(f"bin/ holds {binaries}, not gaugeloop alone (tests and benchmarks are never installed)")
        unit = unit_dir.lstrip("/") + "/gaugeloop.service"
        places = (f"{rel}/bin/", unit, f"{rel}/lib/sysusers.d/gaugeloop.conf", f"{rel}/lib/tmpfiles.d/gaugeloop.conf",
                  f"{doc}/")
        for f in sorted(files):
            if not f.startswith(places):
                fail(f"{f} installed, outside the places docs/service.md names")
        docs = sorted(n for n in os.listdir(os.path.join(source_dir, "docs")) if n.endswith(".md"))
        # The figures the docs show, and every Sinumerik template the docs and the example
        # config name (the crankpins' too).
        images = sorted(os.listdir(os.path.join(source_dir, "docs", "img")))
        sinumerik = sorted(os.listdir(os.path.join(source_dir, "examples", "sinumerik")))
        expected = ([f"{doc}/README.md", f"{doc}/examples/service/gaugeloop.toml", unit] +
                    [f"{doc}/docs/{n}" for n in docs] + [f"{doc}/docs/img/{n}" for n in images] +
                    [f"{doc}/examples/sinumerik/{n}" for n in sinumerik] +
                    [f"{doc}/examples/crankpin_cx.toml", f"{doc}/examples/crankpin_cxy.toml"])
        for f in expected:
            if f not in files:
                fail(f"{f} not installed (prefix {prefix})")
        if unit in files:
            unit_settings = settings(open(os.path.join(destdir, unit), encoding="utf-8").read())
            want = f"{prefix}/bin/gaugeloop serve --config /etc/gaugeloop/gaugeloop.toml"
            if unit_settings.get("ExecStart") != [want]:
                fail(f"{unit}: ExecStart is {unit_settings.get('ExecStart')}, not {want!r}")

        binary = os.path.join(root, "bin", "gaugeloop")
        shown = run([binary, "--version"])
        if shown.returncode != 0 or version not in shown.stdout:
            fail(f"{binary} --version: exit status {shown.returncode}, {shown.stdout!r} (want {version})")
        example = os.path.join(root, "share/doc/gaugeloop/examples/service/gaugeloop.toml")
        checked = run([binary, "serve", "--check", "--config", example])
        if checked.returncode != 0 or "configuration ok" not in checked.stdout:
            fail(f"serve --check on the installed example: exit status {checked.returncode}:\n{checked.stdout}")
        print(f"prefix {prefix}: {len(files)} files installed; the example config checks")


def check_scripts(source_dir):
    scripts = [os.path.join(source_dir, "packaging", n) for n in ("postinst", "prerm", "postrm")]
    for s in scripts:
        parsed = run(["sh", "-n", s])
        if parsed.returncode != 0:
            fail(f"{s} does not parse:\n{parsed.stdout}")
        if not os.access(s, os.X_OK):
            fail(f"{s} is not executable")
    if shutil.which("shellcheck"):
        checked = run(["shellcheck"] + scripts)
        if checked.returncode != 0:
            fail(f"shellcheck:\n{checked.stdout}")


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "unit":
        check_unit(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 6 and sys.argv[1] == "install":
        build_dir, source_dir, version, cmake = sys.argv[2:]
        check_install(cmake, build_dir, source_dir, version, None, None)
        check_install(cmake, build_dir, source_dir, version, "/usr", "/lib/systemd/system")
        check_scripts(source_dir)
    else:
        print(__doc__)
        return 2
    for f in failures:
        print(f"FAILED: {f}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
