#!/usr/bin/env python3
"""A plant on one machine: a broker, a central PostgreSQL and N simulated grinders.

Starts a real mosquitto broker and a real PostgreSQL 15 cluster in a temporary directory on
free loopback ports, and N grinders, each a virtual grinder (`gaugeloop sim --grind`) measured
by its own service (`gaugeloop serve`) with its own SQLite file, publishing to the broker.
Every grinder is asked for a run every few seconds (POST /api/measure); every few seconds each
grinder's file is synced into PostgreSQL (`gaugeloop plant sync`, as a timer would), or, with
--service-sync, each service syncs its own file ([plant.central]). An independent subscriber
(mosquitto_sub) records what the broker delivers.

With --outages the broker and then PostgreSQL are each stopped for a while in the middle, and
one grinder's service is killed with SIGKILL and started again. At the end the outboxes are
drained, a last sync is made (or waited for), and the runs stored in the grinders' files are counted against
those the subscriber received and those in PostgreSQL, by UUID: lost, duplicated, and repeat
deliveries (a consumer drops those by message_uuid). Exit status 0 only with nothing lost and
nothing duplicated.

    plant_run.py --grinders 3 --minutes 1                 # the plant demo
    plant_run.py --grinders 20 --minutes 10 --outages     # the load test (docs/plant.md)
    plant_run.py --grinders 3 --minutes 1.5 --outages --service-sync

Needs the Debian packages scripts/install-deps.sh installs (mosquitto, mosquitto-clients,
postgresql-15) and a built gaugeloop (--gaugeloop, default build/bin/gaugeloop). Runs as root
or as any user; as root, PostgreSQL runs as the postgres user. Everything listens on 127.0.0.1
only and everything it started is stopped at the end.
"""
import argparse
import json
import os
import pathlib
import random
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

ROOT = pathlib.Path(__file__).resolve().parents[2]
PG_BIN = pathlib.Path("/usr/lib/postgresql/15/bin")
SITE = "plant"


def log(text):
    print(f"[{time.strftime('%H:%M:%S')}] {text}", flush=True)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_until(what, check, timeout_s=60.0, interval_s=0.1):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if check():
            return
        time.sleep(interval_s)
    raise RuntimeError(f"timed out after {timeout_s:.0f} s waiting for {what}")


def accepts(port):
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=1):
            return True
    except OSError:
        return False


class Broker:
    """mosquitto with persistence, restartable on the same port and directory."""

    def __init__(self, work):
        self.dir = work / "broker"
        self.dir.mkdir()
        self.port = free_port()
        self.conf = self.dir / "mosquitto.conf"
        self.conf.write_text(
            f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence true\n"
            f"persistence_location {self.dir}/\nautosave_interval 1\nmax_queued_messages 0\n"
            f"log_dest file {self.dir}/mosquitto.log\n")
        if os.geteuid() == 0:
            shutil.chown(self.dir, "mosquitto" if _user_exists("mosquitto") else "root")
        self.proc = None

    def start(self):
        self.proc = subprocess.Popen(["mosquitto", "-c", str(self.conf)], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        wait_until("the broker to accept connections", lambda: accepts(self.port))

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=30)


def _user_exists(name):
    try:
        import pwd
        pwd.getpwnam(name)
        return True
    except KeyError:
        return False


class Postgres:
    """A PostgreSQL 15 cluster in a temporary directory, as the postgres user when root."""

    def __init__(self, work):
        self.dir = work / "postgres"
        self.dir.mkdir()
        self.port = free_port()
        self.as_user = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []
        if os.geteuid() == 0:
            shutil.chown(self.dir, "postgres", "postgres")
        self.data = self.dir / "data"
        self._run([str(PG_BIN / "initdb"), "-D", str(self.data), "-U", "gaugeloop", "--auth=trust", "-E", "UTF8",
                   "--locale=C.UTF-8"])
        self.url = f"postgresql://gaugeloop@127.0.0.1:{self.port}/plant"

    def _run(self, argv):
        subprocess.run(self.as_user + argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)

    def start(self):
        self._run([str(PG_BIN / "pg_ctl"), "-D", str(self.data), "-l", str(self.dir / "server.log"), "-w", "-o",
                   f"-p {self.port} -k {self.dir} -c listen_addresses=127.0.0.1", "start"])

    def create_database(self):
        self._run([str(PG_BIN / "createdb"), "-h", "127.0.0.1", "-p", str(self.port), "-U", "gaugeloop", "plant"])

    def stop(self):
        subprocess.run(self.as_user + [str(PG_BIN / "pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop"],
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def query(self, sql):
        out = subprocess.run(["psql", "-At", "-h", "127.0.0.1", "-p", str(self.port), "-U", "gaugeloop", "-d",
                              "plant", "-c", sql], check=True, capture_output=True, text=True)
        return [line for line in out.stdout.splitlines() if line]


class Grinder:
    """A virtual grinder (gaugeloop sim --grind) and the service that measures it."""

    def __init__(self, work, index, gaugeloop, broker_port, time_scale, central_url=None, sync_every_s=60):
        self.index = index
        self.machine = f"grinder-{index + 1:02d}"
        self.dir = work / self.machine
        self.dir.mkdir()
        self.gaugeloop = gaugeloop
        self.config = self.dir / "service.toml"
        self.db = self.dir / "gaugeloop.sqlite"
        self.token_file = self.dir / "token"
        subprocess.run([gaugeloop, "token", "new", str(self.token_file)], check=True, stdout=subprocess.DEVNULL)
        self.token = self.token_file.read_text().strip()
        self.sim = subprocess.Popen([gaugeloop, "sim", "--grind", "--port", "0", "--time-scale", str(time_scale),
                                     "--data-dir", str(self.dir), "--machine-seed", str(index + 1)],
                                    stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        sim_port = None
        for line in self.sim.stdout:
            if line.startswith("port "):
                sim_port = int(line.split()[1])
                break
        if sim_port is None:
            raise RuntimeError(f"{self.machine}: the gauge simulator did not say its port")
        threading.Thread(target=lambda: [None for _ in self.sim.stdout], daemon=True).start()
        gauge = (ROOT / "examples/gauges/simulator.toml").read_text().replace("port = 1502", f"port = {sim_port}")
        (self.dir / "gauge.toml").write_text(gauge)
        ex = ROOT / "examples"
        self.config.write_text(f"""machine = "{self.machine}"
[gauge]
config = "gauge.toml"
revolutions = 3
[[part]]
file = "{ex}/intake_flat.toml"
[nc]
dir = "nc"
template = "{ex}/sinumerik/cam_table.spf"
main_template = "{ex}/sinumerik/cam_main.mpf"
[database]
path = "gaugeloop.sqlite"
[http]
host = "127.0.0.1"
port = 0
token_file = "token"
[plant.mqtt]
host = "127.0.0.1"
port = {broker_port}
site = "{SITE}"
""" + ("" if central_url is None else f"""[plant.central]
url = "{central_url}"
interval_s = {max(10, int(sync_every_s))}
"""))
        self.serve = None
        self.http_port = None
        self.requested = 0
        self.answered = 0
        self.failed = 0

    def start_service(self):
        self.serve = subprocess.Popen([self.gaugeloop, "serve", "--config", str(self.config)], stdout=subprocess.PIPE,
                                      stderr=open(self.dir / "serve.log", "a"), text=True)
        for line in self.serve.stdout:
            if "listening on http://127.0.0.1:" in line:
                self.http_port = int(line.rsplit(":", 1)[1].split()[0].strip("/"))
                break
        if self.http_port is None:
            raise RuntimeError(f"{self.machine}: the service did not start; see {self.dir / 'serve.log'}")
        threading.Thread(target=lambda p=self.serve: [None for _ in p.stdout], daemon=True).start()

    def kill_service(self):
        self.serve.send_signal(signal.SIGKILL)
        self.serve.wait()
        self.http_port = None

    def measure(self):
        port = self.http_port
        if port is None:
            return
        self.requested += 1
        req = urllib.request.Request(f"http://127.0.0.1:{port}/api/measure", method="POST",
                                     data=json.dumps({"part": "intake_flat", "lobe": 1}).encode(),
                                     headers={"Authorization": f"Bearer {self.token}",
                                              "Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=120) as r:
                r.read()
                self.answered += 1
        except Exception:  # a refusal, a held table, the service killed: the run is counted from the file
            self.failed += 1

    def sync(self, url):
        r = subprocess.run([self.gaugeloop, "plant", "sync", "--to", url, "--config", str(self.config)],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        return r.returncode == 0

    def stored_run_uuids(self):
        with sqlite3.connect(f"file:{self.db}?mode=ro", uri=True) as c:
            return [row[0] for row in c.execute("SELECT uuid FROM runs")]

    def outbox_depth(self):
        with sqlite3.connect(f"file:{self.db}?mode=ro", uri=True) as c:
            return c.execute("SELECT depth FROM outbox_state").fetchone()[0]

    def stop(self):
        for p in (self.serve, self.sim):
            if p and p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=60)
                except subprocess.TimeoutExpired:
                    p.kill()


class Subscriber:
    """mosquitto_sub with a persistent session (QoS 1): what a plant consumer receives."""

    def __init__(self, work, port):
        self.file = work / "received.txt"
        self.port = port
        self.proc = None

    def start(self):
        out = open(self.file, "a")
        self.proc = subprocess.Popen(["mosquitto_sub", "-h", "127.0.0.1", "-p", str(self.port), "-q", "1", "-c",
                                      "-i", "plant-consumer", "-t", f"gaugeloop/{SITE}/+/run", "-F", "%t\t%p"],
                                     stdout=out, stderr=subprocess.DEVNULL)

    def alive(self):
        return self.proc is not None and self.proc.poll() is None

    def stop(self):
        if self.alive():
            self.proc.terminate()
            self.proc.wait(timeout=30)

    def received(self):
        runs, messages = [], []
        for line in self.file.read_text().splitlines():
            topic, _, payload = line.partition("\t")
            try:
                body = json.loads(payload)
            except json.JSONDecodeError:
                continue
            runs.append(body.get("uuid"))
            messages.append(body.get("message_uuid"))
        return runs, messages


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--grinders", type=int, default=3)
    ap.add_argument("--minutes", type=float, default=1.0)
    ap.add_argument("--run-every-s", type=float, default=3.0, help="each grinder is asked for a run this often")
    ap.add_argument("--sync-every-s", type=float, default=10.0)
    ap.add_argument("--service-sync", action="store_true",
                    help="each service syncs its own file ([plant.central], at least every 10 s) instead of this "
                         "script running `gaugeloop plant sync`")
    ap.add_argument("--outages", action="store_true",
                    help="stop the broker, then PostgreSQL, each for --outage-s, and kill one service with -9")
    ap.add_argument("--outage-s", type=float, default=60.0)
    ap.add_argument("--time-scale", type=float, default=10.0, help="the virtual grinders' simulated seconds per second")
    ap.add_argument("--gaugeloop", default=str(ROOT / "build/bin/gaugeloop"))
    ap.add_argument("--keep", action="store_true", help="keep the temporary directory")
    args = ap.parse_args()

    work = pathlib.Path(tempfile.mkdtemp(prefix="gaugeloop-plant-"))
    os.chmod(work, 0o755)  # the broker and PostgreSQL drop to their own users when started as root
    broker = Broker(work)
    pg = Postgres(work)
    grinders = []
    subscriber = Subscriber(work, broker.port)
    stop = threading.Event()
    try:
        broker.start()
        pg.start()
        pg.create_database()
        subscriber.start()
        log(f"broker on 127.0.0.1:{broker.port}, PostgreSQL at {pg.url}, work in {work}")
        for i in range(args.grinders):
            g = Grinder(work, i, args.gaugeloop, broker.port, args.time_scale,
                        pg.url if args.service_sync else None, args.sync_every_s)
            g.start_service()
            grinders.append(g)
        log(f"{len(grinders)} grinders running")

        def drive(g):
            rng = random.Random(g.index)
            while not stop.is_set():
                started = time.monotonic()
                g.measure()
                stop.wait(max(0.0, args.run_every_s * rng.uniform(0.8, 1.2) - (time.monotonic() - started)))

        def sync_loop():
            while not stop.is_set():
                for g in grinders:
                    g.sync(pg.url)
                stop.wait(args.sync_every_s)

        threads = [threading.Thread(target=drive, args=(g,)) for g in grinders]
        if not args.service_sync:
            threads.append(threading.Thread(target=sync_loop))
        for t in threads:
            t.start()

        total_s = args.minutes * 60.0
        t0 = time.monotonic()

        def at(fraction):
            stop.wait(max(0.0, t0 + fraction * total_s - time.monotonic()))

        if args.outages:
            at(0.25)
            log("broker stopped")
            broker.stop()
            stop.wait(args.outage_s)
            broker.start()
            if not subscriber.alive():
                subscriber.start()
            log("broker started again")
            at(0.5)
            log("PostgreSQL stopped")
            pg.stop()
            stop.wait(args.outage_s)
            pg.start()
            log("PostgreSQL started again")
            at(0.7)
            victim = grinders[0]
            log(f"{victim.machine}: service killed with SIGKILL")
            victim.kill_service()
            stop.wait(5.0)
            victim.start_service()
            log(f"{victim.machine}: service started again")
        at(1.0)
        stop.set()
        for t in threads:
            t.join()
        log("runs stopped; draining the outboxes and syncing once more")
        wait_until("every outbox to drain", lambda: all(g.outbox_depth() == 0 for g in grinders), timeout_s=300,
                   interval_s=1.0)
        if args.service_sync:
            # The services sync after each run and every interval: wait for them to catch up.
            wanted = {u for g in grinders for u in g.stored_run_uuids()}
            wait_until("the services to sync every run", lambda: wanted <= set(pg.query("SELECT uuid FROM runs")),
                       timeout_s=300, interval_s=1.0)
        else:
            for g in grinders:
                if not g.sync(pg.url):
                    raise RuntimeError(f"{g.machine}: the last sync failed")
        # The subscriber has what the broker acknowledged to the senders once it has caught up.
        stored = [u for g in grinders for u in g.stored_run_uuids()]
        wait_until("the subscriber to receive every run",
                   lambda: set(stored) <= set(subscriber.received()[0]), timeout_s=120, interval_s=1.0)
    except Exception as e:
        log(f"failed: {e}")
        stop.set()
        raise
    finally:
        stop.set()
        stored = []
        for g in grinders:
            try:
                stored += g.stored_run_uuids()
            except Exception:
                pass
        for g in grinders:
            g.stop()
        subscriber.stop()
        received_runs, received_messages = subscriber.received() if subscriber.file.exists() else ([], [])
        central = []
        try:
            central = pg.query("SELECT uuid FROM runs")
        except Exception as e:
            log(f"cannot read PostgreSQL: {e}")
        broker.stop()
        pg.stop()
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)

    stored_set = set(stored)
    requested = sum(g.requested for g in grinders)
    answered = sum(g.answered for g in grinders)
    lost_broker = len(stored_set - set(received_runs))
    lost_central = len(stored_set - set(central))
    repeats = len(received_messages) - len(set(received_messages))
    dup_central = len(central) - len(set(central))
    print(f"grinders {len(grinders)}, runs requested {requested}, answered {answered}, stored {len(stored)}"
          f" ({len(stored_set)} distinct)")
    print(f"broker: received {len(received_runs)} run messages, {len(set(received_runs))} distinct runs;"
          f" lost {lost_broker}; repeat deliveries {repeats} (dropped by message_uuid)")
    print(f"PostgreSQL: {len(central)} runs, {len(set(central))} distinct; lost {lost_central}; duplicated"
          f" {dup_central}")
    ok = lost_broker == 0 and lost_central == 0 and dup_central == 0 and len(stored) == len(stored_set)
    print("0 lost, 0 duplicated" if ok else "FAILED: runs lost or duplicated")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
