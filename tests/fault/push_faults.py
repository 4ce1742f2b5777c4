#!/usr/bin/python3
"""A push under system-call faults, and the run database under damaged pages: what each leaves.

  push_faults.py syscalls --gaugeloop BIN --source DIR   (ctest PushFaults.Syscalls)
  push_faults.py pages --gaugeloop BIN --source DIR      (ctest PushFaults.Pages)

Both measure the intake lobe of examples/ on the built-in gauge simulator (`gaugeloop sim` on a
free loopback port, seeded) into data directories of their own under a temporary directory.

syscalls: a data directory with one table version in force (a first measurement pushed it) is
copied, and one push (`gaugeloop measure`: the run stored, the table and the main program
written, the push recorded) is traced once by strace to count its calls of fdatasync, fsync,
rename, renameat, renameat2, unlink, unlinkat, flock, pwrite64, write and openat. Each chosen
call (`choose_faults` says which, and why not all; renameat, renameat2 and unlinkat are faulted
where the binary makes them, which on x86-64 it does not) is then failed in a fresh copy of the
same state, the same push made again: the process killed by SIGKILL as it enters the call, or the
call failing with EIO, and with ENOSPC for the writes and flushes. After each, whatever the
fault, as docs/nc_output.md promises ("What the loop guarantees after a kill, a power cut, a
full disk or a lock"):
  - `db check` calls the database sound;
  - the run is stored, or the command exited non-zero; an exit 0 stored the run and recorded its
    push, and follows no failed call on the NC directory but the removal of a temporary file
    (a program written or flushed through a failed call is not known to be on the control's
    disk: its push stays open, as for a directory that cannot be flushed);
  - `nc check` exits 0 with the table and the main program of one version, or non-zero; after
    `nc reconcile` it exits 0, the files those of the history's last version;
  - no temporary file of ours is left in the NC directory or beside the database;
  - the next measurement pushes a version above every version the history or the control held
    before it (an intent abandoned because its program never reached the control leaves no
    version behind), and `nc check` agrees.
The C++ tests stop a push at the steps it exposes; this one stops it at the system calls the
binary really makes, SQLite's included, so a step nobody hooked is covered too.

pages: a database of three runs, closed (no -wal), is damaged one page at a time in a copy: the
page zeroed, or 8 of its bytes inverted. Then `db check` exits 4 naming what it found, or every
run reads back (`runs show --json`, `runs export`) byte for byte as before. As docs/storage.md
promises ("Integrity and backups"): a run `db check` names is refused by `runs show`, naming
it, and the next measurement either refuses, naming a damaged run or the damaged database, or
builds on a run that reads back as it was stored.

Exits 0 when every check holds, printing one line. Otherwise prints each failure (the case, the
commands, their status and output) and keeps the work directory.
"""

import argparse
import concurrent.futures
import dataclasses
import json
import pathlib
import random
import re
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time

# The simulated spindle runs this many times faster than its 60 rpm: three revolutions in
# 0.3 s. The amplifier's latch ring holds 512 degrees, 142 ms at this speed: the margin a push
# traced by strace (every system call stopped, for SIGKILL) needs on a loaded 2-core machine. A
# run whose gauge failed before its fault was reached is made again (GAUGE_ATTEMPTS): the gauge
# is not what is tested here.
TIME_SCALE = 10
GAUGE_ATTEMPTS = 5
COMMAND_TIMEOUT_S = 120
TRACED = ("fdatasync", "fsync", "rename", "renameat", "renameat2", "unlink", "unlinkat", "flock", "pwrite64",
          "write", "openat")
# The calls that write or flush: a full disk fails them too.
WRITES = ("write", "pwrite64", "fsync", "fdatasync")
# atomic_temporary_prefix (core/atomic_file.cc): ".<file name>.tmp-" and mkstemp's six characters.
TEMPORARY = re.compile(r"^\..+\.tmp-[A-Za-z0-9]{6}$")
# Files the process opens that are not ours to fault: the loader's, the C library's, the kernel's.
SYSTEM_PATHS = ("/lib", "/usr", "/etc", "/proc", "/sys", "/dev")
PART_FILES = ("intake_flat.toml", "intake_flat.csv")


class Failed(Exception):
    """A check that does not hold, or a set-up that could not be made."""


@dataclasses.dataclass
class Outcome:
    """A finished command: what was run, its exit status (negative: killed by that signal), output."""
    argv: list
    status: int
    stdout: str
    stderr: str

    @property
    def text(self):
        return self.stdout + self.stderr

    def describe(self, tail_lines=25):
        lines = self.text.rstrip("\n").splitlines()
        shown = lines[-tail_lines:]
        cut = f"    ... ({len(lines) - len(shown)} lines before)\n" if len(lines) > len(shown) else ""
        body = "".join(f"    {line}\n" for line in shown) or "    (no output)\n"
        return f"  $ {' '.join(str(a) for a in self.argv)}\n  exit status {self.status}\n{cut}{body}"


def run(argv, cwd=None):
    try:
        p = subprocess.run([str(a) for a in argv], cwd=cwd, capture_output=True, text=True, errors="replace",
                           timeout=COMMAND_TIMEOUT_S)
    except subprocess.TimeoutExpired as e:
        raise Failed(f"`{' '.join(str(a) for a in argv)}` did not finish within {COMMAND_TIMEOUT_S} s; "
                     f"its output so far:\n{e.stdout or ''}{e.stderr or ''}")
    return Outcome(list(argv), p.returncode, p.stdout, p.stderr)


class Simulator:
    """`gaugeloop sim` on a free loopback port, serving one part for ever (no grinding)."""

    def __init__(self, gaugeloop, log_path):
        self.log = open(log_path, "w")
        self.proc = subprocess.Popen([gaugeloop, "sim", "--port", "0", "--time-scale", str(TIME_SCALE), "--seed", "1"],
                                     stdout=subprocess.PIPE, stderr=self.log, text=True)
        self.port = None
        for line in self.proc.stdout:
            if line.startswith("port "):
                self.port = int(line.split()[1])
                break
        if self.port is None:
            self.stop()
            raise Failed(f"the gauge simulator printed no port; see {log_path}")
        # Keep reading, so the simulator never blocks on a full pipe.
        threading.Thread(target=lambda: [None for _ in self.proc.stdout], daemon=True).start()

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


class Gaugeloop:
    """The binary under test, measuring the intake lobe on the simulator.

    Every command runs in the parent of its data directory, named `data` there (`--data-dir
    data`): what it prints of the directory's own paths is then the same for every copy."""

    def __init__(self, binary, part, port):
        self.binary = binary
        self.part = part
        self.port = port

    def __call__(self, *args, data):
        return run([self.binary, *args, "--data-dir", data.name], cwd=data.parent)

    def measure(self, data, ground_with=None, prefix=()):
        argv = [*prefix, self.binary, "measure", "--gauge", f"127.0.0.1:{self.port}", "--part", self.part,
                "--data-dir", data.name]
        if ground_with is not None:
            argv += ["--ground-with", ground_with]
        return run(argv, cwd=data.parent)

    def measure_retrying_gauge(self, data, ground_with=None):
        """A measurement without faults: exit 3 (the gauge) is the loaded machine's, so it is repeated."""
        for _ in range(GAUGE_ATTEMPTS):
            out = self.measure(data, ground_with)
            if out.status != 3:
                return out
        return out

    def json(self, *args, data):
        out = self(*args, "--json", data=data)
        if out.status != 0:
            raise Failed(f"{' '.join(args)} --json failed:\n{out.describe()}")
        return json.loads(out.stdout)


def prepare(gl, data, pushes):
    """A data directory whose history holds `pushes` runs and table versions, each pushed."""
    data.parent.mkdir(parents=True, exist_ok=True)
    for version in range(pushes):
        # The first part was ground with the design; each next one with the table just pushed,
        # which the simulator's one part does not show: --ground-with says so.
        out = gl.measure_retrying_gauge(data, version or None)
        if out.status != 0:
            raise Failed(f"preparing the data directory: measurement {version + 1} failed:\n{out.describe()}")


def copy_state(state, case_dir):
    """A copy of the prepared data directory `state` as case_dir/data."""
    shutil.copytree(state, case_dir / "data", symlinks=True)
    return case_dir / "data"


def program_files(nc):
    """The table version and table number of the table program and of the main program on the
    control, as their text says; a string saying what could not be read instead of a number."""
    def grab(path, pattern):
        try:
            m = re.search(pattern, path.read_text(errors="replace"), re.M)
        except OSError as e:
            return f"{path.name} unreadable ({e.strerror})"
        return int(m.group(1)) if m else f"{path.name} without /{pattern}/"
    table = nc / "CAM_INTAKE_L1.SPF"
    main = nc / "CAM_INTAKE_L1_MAIN.MPF"
    return {
        "table version": grab(table, r"^; gaugeloop table_version: (\d+)$"),
        "table number": grab(table, r"^; gaugeloop table_number: (\d+)$"),
        "main program's table version": grab(main, r"with table version (\d+) of"),
        "main program's coupled table": grab(main, r'EGON\(X,"FINE",C,(\d+),0\)'),
    }


def one_version(files):
    """None if the table and the main program belong to one version, else why not."""
    if not all(isinstance(v, int) for v in files.values()):
        return f"the programs do not read: {files}"
    if files["table version"] != files["main program's table version"] or \
            files["table number"] != files["main program's coupled table"]:
        return f"the table and the main program are of different versions: {files}"
    return None


def versions_in(files):
    """The table versions the programs on the control name."""
    return {files[k] for k in ("table version", "main program's table version") if isinstance(files[k], int)}


def temporary_files(data):
    """Temporary files of ours in the data directory, its NC directory and unstored-runs/."""
    found = []
    for d in (data, data / "nc", data / "unstored-runs"):
        if d.is_dir():
            found += [str(p.relative_to(data)) for p in d.iterdir() if TEMPORARY.match(p.name)]
    return sorted(found)


# ---------------------------------------------------------------------------------------------
# syscalls


@dataclasses.dataclass(frozen=True)
class Call:
    """One traced system call of the push."""
    syscall: str
    nth: int       # 1-based among this syscall's calls in the process: strace's when=
    target: str    # the file it acts on, named inside the case directory
    flags: str     # openat's flags; pwrite64's length and offset
    ours: bool     # acts on a file of the work directory (or stdout), not a system file
    after: str     # the traced call of ours before it, to place it in the push: "rename call 1"


@dataclasses.dataclass(frozen=True)
class Case:
    call: Call
    fault: str     # "KILL", "EIO" or "ENOSPC"

    def __str__(self):
        how = "SIGKILL on entering" if self.fault == "KILL" else f"{self.fault} from"
        c = self.call
        details = ", ".join(d for d in (c.target, c.flags, c.after and f"after {c.after}") if d)
        return f"{how} {c.syscall} call {c.nth} ({details})"


TRACE_LINE = re.compile(r"^(\d+) +(\w+)\((.*)\) += (.*)$")
QUOTED = re.compile(r'"((?:[^"\\]|\\.)*)"')


def parse_trace(text, case_dir):
    """The traced calls in order, each with the file it acts on (fds followed through openat)."""
    prefix = str(case_dir) + "/"
    fds = {"0": "stdin", "1": "stdout", "2": "stderr"}
    counts = {}
    calls = []
    pids = set()
    for line in text.splitlines():
        m = TRACE_LINE.match(line)
        if not m:
            continue
        pid, syscall, args, result = m.groups()
        pids.add(pid)
        paths = [p.replace(prefix, "") for p in QUOTED.findall(args)]
        paths = [re.sub(r"\.tmp-[A-Za-z0-9]{6}$", ".tmp-XXXXXX", p) for p in paths]
        flags = ""
        if syscall == "openat":
            target = paths[0]
            flags = args.split(", ")[2]
            if result.split()[0].isdigit():
                fds[result.split()[0]] = target
            ours = not target.startswith(SYSTEM_PATHS)
        elif syscall in ("rename", "renameat", "renameat2"):
            target, ours = " -> ".join(paths), True
        elif syscall in ("unlink", "unlinkat"):
            target, ours = paths[0], True
        else:
            fd = args.split(",")[0].strip()
            target = fds.get(fd, f"fd {fd}")
            ours = not target.startswith(SYSTEM_PATHS)
            if syscall == "pwrite64":
                flags = "length {} at {}".format(*[a.strip() for a in args.rsplit(",", 2)[1:]])
        counts[syscall] = counts.get(syscall, 0) + 1
        previous = next((f"{p.syscall} call {p.nth}" for p in reversed(calls) if p.ours), "")
        calls.append(Call(syscall, counts[syscall], target, flags, ours, previous))
    if len(pids) > 1:
        # strace counts when= per thread; the sweep names calls by their number in one process.
        raise Failed(f"the push made traced calls in {len(pids)} threads or processes; the sweep counts the "
                     "calls of one: it needs to fault each thread's calls by that thread's count")
    return calls


def choose_faults(calls):
    """The faults the sweep injects, in the order the push makes the calls.

    Every call of fdatasync, fsync, rename*, unlink*, flock and write (a few each): SIGKILL and
    EIO, and ENOSPC for the writes and flushes. openat (about a hundred calls, most the loader's):
    only files of ours, the first open of each file with each set of flags for each call that
    follows it (so the table's temporary file counts apart from the probe's of the same name,
    and listing the NC directory apart from locking it); EIO, and SIGKILL where the open
    creates the file (a kill before any other open leaves what a kill before the next call
    that changes a file leaves, and those calls are all faulted). pwrite64 (SQLite's,
    over a hundred): the first write of each run of writes to one file (a transaction's frames
    in the -wal, a checkpoint into the database, the -shm's sizing, whose three identical runs
    count once), with all three faults: to gaugeloop a transaction failed or was cut short
    whichever of its writes it was; how SQLite recovers from a torn one is SQLite's to test.
    97 cases for the push of a lobe's table and main program, each about 1 s of CPU (two
    measurements, one traced, and six to eight short commands), two at a time: 80 to 95 s on
    a 2-core machine beside another build, about 45 s on two idle cores. Every call of ours of every
    kind would be about 450 cases, 330 of them SQLite's writes.
    """
    pwrite_runs = []
    for i, c in enumerate(calls):
        if c.syscall == "pwrite64":
            if pwrite_runs and pwrite_runs[-1][-1][0] == i - 1 and pwrite_runs[-1][-1][1].target == c.target:
                pwrite_runs[-1].append((i, c))
            else:
                pwrite_runs.append([(i, c)])
    pwrite_chosen = set()
    seen_runs = set()
    for r in pwrite_runs:
        shape = (r[0][1].target, tuple(c.flags for _, c in r))
        if shape in seen_runs:
            continue
        seen_runs.add(shape)
        pwrite_chosen.add(r[0][0])

    ours = [i for i, c in enumerate(calls) if c.ours]
    next_call = {i: calls[j].syscall for i, j in zip(ours, ours[1:])}
    cases = []
    opened = set()
    for i, c in enumerate(calls):
        if not c.ours:
            continue
        if c.syscall == "openat":
            use = (c.target, c.flags, next_call.get(i))
            if use in opened:
                continue
            opened.add(use)
            faults = (["KILL"] if "O_CREAT" in c.flags else []) + ["EIO"]
        elif c.syscall == "pwrite64":
            if i not in pwrite_chosen:
                continue
            faults = ["KILL", "EIO", "ENOSPC"]
        else:
            faults = ["KILL", "EIO"] + (["ENOSPC"] if c.syscall in WRITES else [])
        cases += [Case(c, f) for f in faults]
    return cases


def strace_prefix(trace, syscalls, inject=None):
    # --seccomp-bpf stops only at the traced calls, so a traced push runs at nearly its own
    # speed; strace 6.1 does not deliver an injected signal under it, so a kill goes without.
    argv = ["strace", "-f", "-o", trace]
    if inject is None or "signal=" not in inject:
        argv.append("--seccomp-bpf")
    argv += ["-e", "trace=" + ",".join(syscalls)]
    if inject:
        argv += ["-e", "inject=" + inject]
    return argv


class SyscallSweep:
    def __init__(self, gl, work):
        self.gl = gl
        self.work = work
        self.state = work / "prepared" / "data"
        self.in_force = 1
        self.notes = {}

    def prepare(self):
        prepare(self.gl, self.state, pushes=1)
        self.runs_before = {r["id"] for r in self.gl.json("runs", "list", data=self.state)}
        self.versions_before = {p["table_version"] for p in self.gl.json("nc", "history", data=self.state)}
        case_dir = self.work / "count"
        data = copy_state(self.state, case_dir)
        out = self.gl.measure(data, self.in_force, strace_prefix(case_dir / "trace", TRACED))
        if out.status != 0:
            raise Failed(f"the push traced to count its calls failed:\n{out.describe()}")
        self.calls = parse_trace((case_dir / "trace").read_text(), case_dir)
        shutil.rmtree(case_dir)
        return choose_faults(self.calls)

    def run_case(self, index, case):
        """The failures of one case: each a paragraph naming the check, with the commands' output."""
        c = case.call
        for _ in range(GAUGE_ATTEMPTS):
            case_dir = self.work / f"case-{index:03d}"
            shutil.rmtree(case_dir, ignore_errors=True)
            data = copy_state(self.state, case_dir)
            trace = case_dir / "trace"
            fault = "signal=KILL" if case.fault == "KILL" else f"error={case.fault}"
            inject = f"{c.syscall}:{fault}:when={c.nth}"
            faulted = self.gl.measure(data, self.in_force, strace_prefix(trace, [c.syscall], inject))
            traced = trace.read_text(errors="replace") if trace.exists() else ""
            injected = "+++ killed by SIGKILL +++" in traced if case.fault == "KILL" else "(INJECTED)" in traced
            if injected or faulted.status != 3:
                break
        failures = []
        shown = [faulted]

        def check(condition, what, *outcomes):
            if not condition:
                failures.append(f"{what}\n" + "".join(o.describe() for o in (*shown, *outcomes)))
            return condition

        if not check(injected, f"the fault was never injected: the push ended before its {c.syscall} call {c.nth} "
                               "(it made that many when traced to count them)"):
            return failures

        if case.fault != "KILL" and c.target.startswith("data/nc") and c.syscall not in ("unlink", "unlinkat"):
            # Removing our own temporary file is the one call on the control's files whose
            # failure costs the push nothing: the file is a leftover the next push removes.
            check(faulted.status != 0,
                  f"the push exited 0 though {c.syscall} failed on the control's directory: a program written through "
                  "a failed call is not known to be on the control's disk, yet its push was recorded as done")

        db = self.gl("db", "check", data=data)
        check(db.status == 0, "db check does not call the database sound after the fault", db)

        stored = []
        if faulted.status == 0:
            # Exited 0: the run and its push were recorded. Any other exit says what it lost.
            stored = [r for r in self.gl.json("runs", "list", data=data) if r["id"] not in self.runs_before]
            history = self.gl.json("nc", "history", data=data)
            check(len(stored) == 1, f"the push exited 0 but stored {len(stored)} runs")
            if stored:
                check(stored[0].get("status") == "pushed" and history and history[0].get("run_id") == stored[0]["id"],
                      f"the push exited 0 but its table is not recorded as pushed: run {stored[0]}, newest push "
                      f"{history[0] if history else None}")

        seen = versions_in(program_files(data / "nc"))
        first = self.gl("nc", "check", data=data)
        files = program_files(data / "nc")
        if first.status == 0:
            check(one_version(files) is None, f"nc check exits 0 but {one_version(files)}", first)
        else:
            check(faulted.status != 0, "the push exited 0 but nc check does not agree", first)
        reconcile = self.gl("nc", "reconcile", data=data)
        self.notes[index] = f"exit {faulted.status} ({last_line(faulted.stderr)}); nc check {first.status}; " \
                            f"reconcile: {last_line(reconcile.text)}"
        check(reconcile.status == 0, "nc reconcile does not finish the interrupted push", reconcile)
        second = self.gl("nc", "check", data=data)
        files = program_files(data / "nc")
        check(second.status == 0, "nc check fails after nc reconcile", first, reconcile, second)
        check(one_version(files) is None, f"after nc reconcile {one_version(files)}", reconcile, second)
        history = self.gl.json("nc", "history", data=data)
        versions = {p["table_version"] for p in history}
        if history and isinstance(files["table version"], int):
            check(files["table version"] == max(versions),
                  f"after nc reconcile the control holds table version {files['table version']}, the history's last "
                  f"is {max(versions)}", reconcile, second)
        left = temporary_files(data)
        check(not left, f"temporary files left after nc reconcile: {', '.join(left)}", reconcile)

        before = self.versions_before | versions | seen | versions_in(files)
        ground_with = files["table version"] if isinstance(files["table version"], int) else max(versions)
        nxt = self.gl.measure_retrying_gauge(data, ground_with)
        if check(nxt.status == 0, "the next measurement after nc reconcile does not push", reconcile, nxt):
            after = program_files(data / "nc")
            third = self.gl("nc", "check", data=data)
            check(third.status == 0 and one_version(after) is None,
                  f"nc check after the next push: {one_version(after) or 'fails'}", nxt, third)
            new = after["table version"]
            check(isinstance(new, int) and new > max(before),
                  f"the next push wrote table version {new}, not above every version before it "
                  f"({sorted(before)}): a version used again", reconcile, nxt)
        return failures


# ---------------------------------------------------------------------------------------------
# pages


class PageSweep:
    RUNS = 3

    def __init__(self, gl, work):
        self.gl = gl
        self.work = work
        self.state = work / "prepared" / "data"
        self.notes = {}

    def prepare(self):
        prepare(self.gl, self.state, pushes=self.RUNS)
        db = self.state / "gaugeloop.sqlite"
        check = self.gl("db", "check", data=self.state)
        if check.status != 0:
            raise Failed(f"the prepared database is not sound:\n{check.describe()}")
        wal = db.with_name(db.name + "-wal")
        if wal.exists() and wal.stat().st_size:
            raise Failed(f"{wal} holds changes after every gaugeloop closed the database")
        self.runs = sorted(r["id"] for r in self.gl.json("runs", "list", data=self.state))
        self.read_back = {r: self.read_run(self.state, r) for r in self.runs}
        # Read-only, immutable: no -shm or -wal is made beside the file, nothing is written.
        conn = sqlite3.connect(f"file:{db}?mode=ro&immutable=1", uri=True)
        try:
            self.page_size = conn.execute("PRAGMA page_size").fetchone()[0]
            pages = conn.execute("PRAGMA page_count").fetchone()[0]
            # What each page holds, for the messages (where SQLite is built with dbstat).
            try:
                self.holds = {n: f"{name} {kind}" for n, name, kind in
                              conn.execute("SELECT pageno, name, pagetype FROM dbstat")}
            except sqlite3.OperationalError:
                self.holds = {}
        finally:
            conn.close()
        if db.stat().st_size != pages * self.page_size:
            raise Failed(f"{db} is {db.stat().st_size} bytes, not {pages} pages of {self.page_size}")
        return [(page, how) for page in range(1, pages + 1) for how in ("zeroed", "flipped")]

    def read_run(self, data, run_id):
        show = self.gl("runs", "show", str(run_id), "--json", data=data)
        export = self.gl("runs", "export", str(run_id), data=data)
        return show, export

    def damage(self, db, page, how):
        with open(db, "r+b") as f:
            f.seek((page - 1) * self.page_size)
            content = bytearray(f.read(self.page_size))
            if how == "zeroed":
                content = bytearray(self.page_size)
            else:
                # Eight bytes inverted, chosen among the page's non-zero bytes (its data, not its
                # free space) by a generator seeded with the page number: the same for the same file.
                used = [i for i, b in enumerate(content) if b] or list(range(self.page_size))
                for i in random.Random(page).sample(used, min(8, len(used))):
                    content[i] ^= 0xFF
            f.seek((page - 1) * self.page_size)
            f.write(content)

    def run_case(self, index, case):
        page, how = case
        case_dir = self.work / f"case-{index:03d}"
        data = copy_state(self.state, case_dir)
        self.damage(data / "gaugeloop.sqlite", page, how)
        failures = []

        def check(condition, what, *outcomes):
            if not condition:
                failures.append(f"{what}\n" + "".join(o.describe() for o in outcomes))
            return condition

        db = self.gl("db", "check", data=data)
        self.notes[index] = f"db check {db.status}: {last_line(db.text)[:300]}"
        if db.status == 0:
            for r in self.runs:
                now = self.read_run(data, r)
                for was, is_ in zip(self.read_back[r], now):
                    check(was.status == is_.status and was.stdout == is_.stdout,
                          f"db check calls the database sound, but run {r} reads back otherwise "
                          f"({' '.join(is_.argv[1:4])}){first_difference(was.stdout, is_.stdout)}", db, is_)
            return failures
        check(db.status == 4 and re.search(r"damaged: \S", db.text),
              "db check fails but does not say the database is damaged and what it found", db)
        named = {int(r) for r in re.findall(r"\brun (\d+)\b", db.text)} & set(self.runs)
        for r in sorted(named):
            show = self.gl("runs", "show", str(r), data=data)
            check(show.status != 0 and re.search(rf"\brun {r}\b", show.text),
                  f"db check names run {r} damaged, but runs show does not refuse it naming it", db, show)
        nxt = self.gl.measure_retrying_gauge(data, self.RUNS)
        self.notes[index] += f"; measure {nxt.status}: {last_line(nxt.stderr) or last_line(nxt.stdout)}"
        if nxt.status in (0, 6):
            m = re.search(r"built on run (\d+)'s", nxt.stdout)
            if m:
                base = int(m.group(1))
                check(base not in named, f"the next measurement built on run {base}, which db check names damaged",
                      db, nxt)
                if base in self.read_back:
                    now = self.read_run(data, base)
                    same = all(was.stdout == is_.stdout and is_.status == 0
                               for was, is_ in zip(self.read_back[base], now))
                    check(same, f"the next measurement built on run {base}, which no longer reads back as stored",
                          db, nxt, *now)
        else:
            check(any(re.search(rf"\brun {r}\b", nxt.text) for r in named) or "damaged" in nxt.text,
                  "the next measurement refuses without naming a damaged run or the damaged database", db, nxt)
        return failures


def last_line(text):
    lines = text.strip().splitlines()
    return lines[-1] if lines else ""


def first_difference(a, b):
    for n, (x, y) in enumerate(zip(a.splitlines(), b.splitlines()), 1):
        if x != y:
            return f": line {n} was\n    {x[:200]}\n  and is\n    {y[:200]}"
    return f": {len(a.splitlines())} lines then, {len(b.splitlines())} now"


# ---------------------------------------------------------------------------------------------


def describe_case(sweep, case):
    if isinstance(case, Case):
        return str(case)
    page, how = case
    holds = sweep.holds.get(page, "free")
    return f"page {page} ({holds}) {how}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep", choices=("syscalls", "pages"))
    ap.add_argument("--gaugeloop", required=True, help="the built binary")
    ap.add_argument("--source", required=True, help="the source directory (its examples/)")
    ap.add_argument("--jobs", type=int, default=2, help="cases at a time")
    ap.add_argument("--verbose", action="store_true", help="a line per case: what the faulted command did")
    args = ap.parse_args()
    if args.sweep == "syscalls" and shutil.which("strace") is None:
        print("FAILED: strace is not installed (scripts/install-deps.sh installs it)", file=sys.stderr)
        return 1
    started = time.monotonic()
    work = pathlib.Path(tempfile.mkdtemp(prefix=f"gaugeloop-faults-{args.sweep}-"))
    part_dir = work / "part"
    part_dir.mkdir()
    for name in PART_FILES:
        shutil.copy(pathlib.Path(args.source) / "examples" / name, part_dir / name)
    sim = None
    failures = []
    cases = []
    try:
        sim = Simulator(str(pathlib.Path(args.gaugeloop).resolve()), work / "sim.log")
        gl = Gaugeloop(str(pathlib.Path(args.gaugeloop).resolve()), str(part_dir / PART_FILES[0]), sim.port)
        sweep = SyscallSweep(gl, work) if args.sweep == "syscalls" else PageSweep(gl, work)
        cases = sweep.prepare()

        def one(item):
            index, case = item
            case_started = time.monotonic()
            try:
                found = sweep.run_case(index, case)
            except Failed as e:
                found = [str(e)]
            if args.verbose:
                print(f"case {index}, {describe_case(sweep, case)}: {sweep.notes.get(index, '')}, "
                      f"{time.monotonic() - case_started:.1f} s{', FAILED' if found else ''}", flush=True)
            if not found:
                shutil.rmtree(work / f"case-{index:03d}", ignore_errors=True)
            return [f"case {index} of {len(cases)}, {describe_case(sweep, case)}: {f}" for f in found]

        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            for found in pool.map(one, enumerate(cases, 1)):
                failures += found
    except Failed as e:
        failures.append(str(e))
    finally:
        if sim is not None:
            sim.stop()
    elapsed = time.monotonic() - started
    if failures:
        for f in failures:
            print(f"FAILED: {f}", file=sys.stderr)
        print(f"push_faults {args.sweep}: {len(failures)} failure(s) in {len(cases)} cases, {elapsed:.1f} s; "
              f"work directory kept: {work}", file=sys.stderr)
        return 1
    shutil.rmtree(work, ignore_errors=True)
    print(f"push_faults {args.sweep}: {len(cases)} cases hold, {elapsed:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
