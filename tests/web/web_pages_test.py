#!/usr/bin/python3
"""The service's pages in a real browser: headless Chromium (through chromedriver) against
`gaugeloop serve`, which measures a virtual grinder (`gaugeloop sim --grind`).

Three runs are measured over the HTTP API with every table held for approval: intake lobe 1 of
shaft S-1001 (its table approved here: version 1 of CAM_INTAKE_L1), then lobe 1 and lobe 2 of
shaft S-1002 (two pending tables); later two gears of the virtual gear grinder's loop join the
same database. The browser then looks at every page, approves the lobe 1
table with the token (the NC history shows version 2 and its diff) and rejects the lobe 2 one,
after both were refused without it, a wrong token was refused as it was entered, and each
question was dismissed once with nothing written; the lobe 1 table's change from the table in
force is shown above its diff as computed here from the two programs. It rolls back (dismissed
once, then accepted), previews lobe 2's first program and writes it (lobe 1's, which has a
history, is refused), and measures from the service page, which says the table waits. At
390x844 the verdicts and write buttons of the run history, the characteristics, the NC history,
the pending tables and the service page are within the screen and whole, and the run's plot
keeps its drawn size in a box that scrolls. Screenshots of every page, at 1366x768 and 390x844,
go to --screenshots. Exits 0 when every check holds; a failed check says what the page showed.
"""

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.common.exceptions import WebDriverException
from selenium.webdriver.chrome.service import Service as DriverService
from selenium.webdriver.common.by import By

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
# A loaded 2-core machine runs a build beside this: every wait is for a condition, with room.
DEADLINE_S = 90.0
SIZES = {"desktop": (1366, 768), "phone": (390, 844)}


class Failed(Exception):
    pass


def check(condition, what):
    if not condition:
        raise Failed(what)


def wait_until(what, condition, deadline_s=DEADLINE_S):
    """Polls `condition` until it returns something true; its last exception or value says why not."""
    end = time.monotonic() + deadline_s
    last = None
    while time.monotonic() < end:
        try:
            value = condition()
            if value:
                return value
            last = value
        except (WebDriverException, Failed, urllib.error.URLError, KeyError, IndexError, ValueError) as e:
            last = e
        time.sleep(0.1)
    raise Failed(f"timed out after {deadline_s:.0f} s waiting for {what}; last: {last!r}")


def log(text):
    print(f"[web test] {text}", flush=True)


class Service:
    """The virtual grinder and the service measuring it, in `work`."""

    def __init__(self, gaugeloop, work):
        self.gaugeloop = gaugeloop
        self.work = work
        self.procs = []
        token_file = work / "token"
        subprocess.run([gaugeloop, "token", "new", str(token_file)], check=True, stdout=subprocess.DEVNULL)
        self.token = token_file.read_text().strip()
        sim = self.start([gaugeloop, "sim", "--grind", "--port", "0", "--time-scale", "10", "--data-dir", str(work)],
                         "sim.log")
        sim_port = self.read_line(sim, lambda line: int(line.split()[1]) if line.startswith("port ") else None,
                                  "the gauge simulator's port", work / "sim.log")
        gauge = (EXAMPLES / "gauges/simulator.toml").read_text().replace("port = 1502", f"port = {sim_port}")
        (work / "gauge.toml").write_text(gauge)
        # Lobe 2 of the same shaft: the intake design again, its own program.
        for name in ("intake_flat.toml", "intake_flat.csv"):
            shutil.copy(EXAMPLES / name, work / name)
        lobe2 = (work / "intake_flat.toml").read_text().replace("lobe = 1", "lobe = 2", 1)
        (work / "intake_flat_l2.toml").write_text(lobe2.replace('"CAM_INTAKE_L1"', '"CAM_INTAKE_L2"', 1))
        # The shaft the two lobes are on: the camshaft page gives each lobe's index error.
        (work / "shaft.toml").write_text("""name = "web camshaft"
reference_c_deg = 0.0
index_tolerance_deg = 0.25
[[lobe]]
part = "intake_flat.toml"
angle_deg = 0.0
[[lobe]]
part = "intake_flat_l2.toml"
angle_deg = 110.0
""")
        (work / "service.toml").write_text(f"""machine = "grinder-web"
[gauge]
config = "gauge.toml"
revolutions = 3
[[part]]
file = "intake_flat.toml"
[[part]]
file = "intake_flat_l2.toml"
[[shaft]]
file = "shaft.toml"
[compensation]
max_correction_um = 500.0
[nc]
dir = "nc"
template = "{EXAMPLES}/sinumerik/cam_table.spf"
main_template = "{EXAMPLES}/sinumerik/cam_main.mpf"
require_approval = true
[database]
path = "gaugeloop.sqlite"
[http]
host = "127.0.0.1"
port = 0
token_file = "token"
""")
        serve = self.start([gaugeloop, "serve", "--config", str(work / "service.toml")], "serve.log")
        self.port = self.read_line(
            serve, lambda line: int(line.rsplit(":", 1)[1].split()[0].strip("/"))
            if "listening on http://127.0.0.1:" in line else None, "the service's HTTP port", work / "serve.log")
        self.base = f"http://127.0.0.1:{self.port}"

    def start(self, argv, log_name):
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=open(self.work / log_name, "w"), text=True,
                             cwd=self.work)
        self.procs.append(p)
        return p

    @staticmethod
    def read_line(proc, parse, what, log_file):
        for line in proc.stdout:
            value = parse(line)
            if value is not None:
                # Keep reading, so the child never blocks on a full pipe.
                threading.Thread(target=lambda: [None for _ in proc.stdout], daemon=True).start()
                return value
        raise Failed(f"{what} was not printed; see {log_file}:\n{log_file.read_text()[-2000:]}")

    def request(self, method, path, body=None, token=None):
        headers = {"Content-Type": "application/json"} if body is not None else {}
        if token:
            headers["Authorization"] = f"Bearer {token}"
        req = urllib.request.Request(self.base + path, method=method, headers=headers,
                                     data=json.dumps(body).encode() if body is not None else None)
        try:
            with urllib.request.urlopen(req, timeout=DEADLINE_S) as r:
                return r.status, r.read(), r.headers.get("Content-Type", "")
        except urllib.error.HTTPError as e:
            return e.code, e.read(), e.headers.get("Content-Type", "")

    def get_json(self, path):
        status, body, _ = self.request("GET", path)
        check(status == 200, f"GET {path}: {status} {body[:300]!r}")
        return json.loads(body)

    def measure(self, lobe, serial):
        status, body, _ = self.request("POST", "/api/measure",
                                       {"part": "intake_flat", "lobe": lobe, "serial": serial, "operator": "anna"},
                                       self.token)
        check(status == 200, f"measuring lobe {lobe} of {serial}: {status} {body[:500]!r}")
        return json.loads(body)

    def stop(self):
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()


class Browser:
    def __init__(self, work):
        options = webdriver.ChromeOptions()
        options.binary_location = "/usr/bin/chromium"
        options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                    f"--user-data-dir={work / 'chromium-profile'}", "--window-size=1366,768", "--lang=en-US"):
            options.add_argument(arg)
        self.driver = webdriver.Chrome(service=DriverService("/usr/bin/chromedriver"), options=options)
        self.driver.set_page_load_timeout(DEADLINE_S)

    def size(self, name):
        w, h = SIZES[name]
        # The viewport, not the window: screenshots are of what a screen that size shows.
        self.driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                                    {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": name == "phone"})

    def text(self, css):
        return self.driver.find_element(By.CSS_SELECTOR, css).text

    def wait_text(self, css, fragment):
        return wait_until(f"'{fragment}' in {css}", lambda: fragment in self.text(css) and self.text(css))

    def count(self, css):
        return len(self.driver.find_elements(By.CSS_SELECTOR, css))

    def go(self, url):
        self.driver.get(url)

    def quit(self):
        self.driver.quit()


def screenshots(browser, out, name, ready):
    """Each page at both sizes; `ready` is the condition the page is drawn."""
    for size in SIZES:
        browser.size(size)
        wait_until(f"{name} drawn at {size}", ready)
        browser.driver.save_screenshot(str(out / f"{name}_{size}.png"))
    browser.size("desktop")


# What of `selector` a phone shows whole, as a list of what it does not: each element is scrolled
# into view by the window, vertically only (a box that scrolls sideways is left where it is, as a
# person finds it), then its box must lie within the viewport's width and within every ancestor
# that clips what overflows it; with `whole_text`, neither it nor its cell may hold text wider
# than itself.
IN_VIEW_JS = """
const [selector, width, wholeText] = arguments;
const out = [];
const found = document.querySelectorAll(selector);
if (found.length === 0) return [`nothing matches ${selector}`];
for (const el of found) {
  window.scrollTo(0, window.scrollY + el.getBoundingClientRect().top - window.innerHeight / 2);
  const r = el.getBoundingClientRect();
  const name = `${selector} "${el.textContent.trim().slice(0, 30)}"`;
  if (r.width === 0 || r.height === 0) { out.push(`${name}: not shown`); continue; }
  if (r.left < 0 || r.right > width) out.push(`${name}: at x ${r.left.toFixed(0)} to ${r.right.toFixed(0)}, not within 0 to ${width}`);
  for (let a = el.parentElement; a && a !== document.body; a = a.parentElement) {
    if (getComputedStyle(a).overflowX === "visible") continue;
    const box = a.getBoundingClientRect();
    if (r.left < box.left - 0.5 || r.right > box.right + 0.5) {
      out.push(`${name}: cut off by its ${a.tagName.toLowerCase()}.${a.className} (x ${box.left.toFixed(0)} to ${box.right.toFixed(0)})`);
    }
  }
  const cell = el.closest("td, th") || el.parentElement;
  if (wholeText && (el.scrollWidth > el.clientWidth || cell.scrollWidth > cell.clientWidth)) {
    out.push(`${name}: its text is clipped (${el.scrollWidth} > ${el.clientWidth} or ${cell.scrollWidth} > ${cell.clientWidth})`);
  }
}
window.scrollTo(0, 0);
return out;
"""


def check_in_view(b, what, size, selectors, whole_text=()):
    """At `size`, every element of `selectors` in full view and each of `whole_text` unclipped."""
    b.size(size)
    width = SIZES[size][0]
    problems = []
    for css in selectors:
        problems += b.driver.execute_script(IN_VIEW_JS, css, width, css in whole_text)
    b.size("desktop")
    check(problems == [], f"{what} at {size} {SIZES[size]}: " + "; ".join(problems[:8])
          + (f" (and {len(problems) - 8} more)" if len(problems) > 8 else ""))


def table_points(program):
    """A curve table program's points (C deg, X mm) and whether it is a CSPLINE table."""
    points, inside, x = [], False, None
    for line in program.splitlines():
        code = line.split(";", 1)[0].strip()
        if code.startswith("CTABDEF"):
            inside = True
        elif code.startswith("CTABEND"):
            break
        elif inside and code:
            words = {w[0]: float(w[1:].lstrip("=")) for w in code.split()
                     if w[0] in "CX" and len(w) > 1 and (w[1].isdigit() or w[1] in "-.=")}
            x = words.get("X", x)  # X is modal
            points.append((words["C"], x))
    return points, "CSPLINE" in program


def table_x_mm(points, spline):
    """X at any C as the control interpolates the periodic table: straight lines, or the natural
    cubic spline (BNAT ENAT) through the points, C read modulo the table's turn."""
    c, y = [p[0] for p in points], [p[1] for p in points]
    n = len(c)
    h = [c[i + 1] - c[i] for i in range(n - 1)]
    moments = [0.0] * n
    if spline:  # h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (slope[i] - slope[i-1]), by elimination
        slope = [(y[i + 1] - y[i]) / h[i] for i in range(n - 1)]
        diag = [2 * (h[i - 1] + h[i]) for i in range(1, n - 1)]
        rhs = [6 * (slope[i] - slope[i - 1]) for i in range(1, n - 1)]
        for k in range(1, n - 2):
            f = h[k] / diag[k - 1]
            diag[k] -= f * h[k]
            rhs[k] -= f * rhs[k - 1]
        for k in range(n - 3, -1, -1):
            moments[k + 1] = (rhs[k] - (h[k + 1] * moments[k + 2] if k + 2 < n - 1 else 0.0)) / diag[k]

    def at(cc):
        cc = c[0] + (cc - c[0]) % (c[-1] - c[0])
        i = max(j for j in range(n - 1) if c[j] <= cc)
        a, b = (c[i + 1] - cc) / h[i], (cc - c[i]) / h[i]
        return a * y[i] + b * y[i + 1] + ((a ** 3 - a) * moments[i] + (b ** 3 - b) * moments[i + 1]) * h[i] ** 2 / 6
    return at


def table_change(pending, in_force, threshold_um=0.1):
    """The largest |dX| in um between two table programs over the whole degrees of C, where, and
    how many degrees differ by more than the threshold."""
    p, f = table_x_mm(*table_points(pending)), table_x_mm(*table_points(in_force))
    dx = [abs(p(d) - f(d)) * 1000 for d in range(360)]
    at = max(range(360), key=lambda d: dx[d])
    return dx[at], at, sum(1 for v in dx if v > threshold_um)


def run_checks(svc, browser, shots):
    b = browser
    ui = svc.base + "/ui/"

    # `/` leads to the pages.
    b.go(svc.base + "/")
    wait_until("/ to show the run history", lambda: "Run history" in b.text("h1"))

    # ---- Run history: every run, then the filters narrow it ----
    b.go(ui + "#/runs")
    wait_until("3 runs listed", lambda: b.count("table#runs tbody tr") == 3)
    table = b.text("table#runs")
    for fragment in ("S-1001", "S-1002", "intake_flat", "grinder-web", "µm", "deg"):
        check(fragment in table, f"the run history shows {fragment}: {table}")
    screenshots(b, shots, "runs", lambda: b.count("table#runs tbody tr") == 3)
    # On a phone every run's verdict, and every figure, is in view and whole.
    check_in_view(b, "the run history", "phone", ["table#runs td .verdict", "table#runs td"],
                  whole_text=["table#runs td .verdict"])
    all_ids = [r.get_attribute("data-run") for r in b.driver.find_elements(By.CSS_SELECTOR, "table#runs tbody tr")]
    check(all_ids == sorted(all_ids, key=int, reverse=True), f"newest first: {all_ids}")
    # Paging, 2 runs a page: the older page holds the third.
    b.go(ui + "#/runs?size=2")
    wait_until("a page of 2 runs", lambda: b.count("table#runs tbody tr") == 2)
    check(b.count("#older") == 1 and b.count("#newer") == 0, "the first page leads only to older runs")
    b.driver.find_element(By.CSS_SELECTOR, "#older").click()
    wait_until("the second page's 1 run", lambda: b.count("table#runs tbody tr") == 1)
    check(b.count("#newer") == 1 and b.count("#older") == 0, "the last page leads only to newer runs")
    last = b.driver.find_element(By.CSS_SELECTOR, "table#runs tbody tr").get_attribute("data-run")
    check(last == all_ids[2], f"the second page holds the oldest run: {last}, not {all_ids[2]}")
    check("runs 3–3" in b.text("#page-of"), b.text("#page-of"))
    b.go(ui + "#/runs?serial=S-1002")
    wait_until("the serial filter to leave 2 runs", lambda: b.count("table#runs tbody tr") == 2)
    check("S-1001" not in b.text("table#runs"), "the serial filter leaves out S-1001")
    # The form: lobe 2 only.
    b.go(ui + "#/runs")
    wait_until("3 runs listed again", lambda: b.count("table#runs tbody tr") == 3)
    b.driver.find_element(By.CSS_SELECTOR, "#run-filters input[name=lobe]").send_keys("2")
    b.driver.find_element(By.CSS_SELECTOR, "#run-filters button[type=submit]").click()
    wait_until("the lobe filter to leave 1 run", lambda: b.count("table#runs tbody tr") == 1)
    check("lobe=2" in b.driver.current_url, f"the filter is in the address: {b.driver.current_url}")
    b.go(ui + "#/runs?since=2000-01-01&until=2000-01-02")
    wait_until("a date range without runs", lambda: "No run matches" in b.text("#runs-out"))

    # ---- One run: identity, figures with units, the SVG plot, the PDF link ----
    runs = svc.get_json("/api/runs?serial=S-1002&lobe=1")
    run_id = runs[0]["id"]
    b.go(ui + f"#/run/{run_id}")
    title = b.wait_text("#title", f"Run {run_id}")
    check("intake_flat lobe 1" in title and "grinder-web" in title, f"the run page's title: {title}")
    figures = b.wait_text("#figures", "Max lift error, judged")
    check("S-1002" in figures, f"the run page shows its serial: {figures}")
    detail = svc.get_json(f"/api/runs/{run_id}")
    judged = detail["judged_error"]
    check(f"{judged['max_abs_um']:.2f} µm" in figures, f"the judged max error with its unit: {figures}")
    check(f"{runs[0]['max_abs_error_um']:.2f} µm" in figures, f"the raw max error beside it: {figures}")
    check("deg" in figures, f"the phase in deg: {figures}")
    # Runout is the dial figure the tolerance judges; the first harmonic is the eccentricity.
    check(f"Base circle runout (dial)\n{detail['dial_runout_um']:.2f} µm" in figures,
          f"the runout card shows the dial figure: {figures}")
    check(f"Eccentricity (1st harmonic)\n{detail['base_circle_runout_um']:.2f} µm" in figures,
          f"the eccentricity card shows the first harmonic: {figures}")
    wait_until("the error plot's SVG", lambda: b.count("#plot svg") == 1)
    check(b.count("table#characteristics tbody tr") > 0, "the run's characteristics")
    # One judged quantity per picture: the caption, the plot's headline and each lift error
    # verdict name the same curve, and the plot counts degrees outside on that curve, so its
    # headline agrees with the verdicts of the lift error and its zones.
    check(judged["name"] in b.text("#judged-caption"), f"the caption names the judged curve: {b.text('#judged-caption')}")
    svg = b.driver.find_element(By.CSS_SELECTOR, "#plot svg").get_attribute("outerHTML")
    check(f"judged: {judged['name']}" in svg, "the plot's headline names the judged curve")
    lift_rows = [r for r in b.driver.find_elements(By.CSS_SELECTOR, "table#characteristics tbody tr")
                 if r.text.startswith("Lift error")]
    check(len(lift_rows) > 0 and all(judged["reference"] in r.text for r in lift_rows),
          f"each lift error verdict says which error it judges: {[r.text for r in lift_rows]}")
    lift_verdicts = [c["verdict"] for c in detail["characteristics"] if c["key"].startswith("lift_error")]
    plot_out = "degrees outside" in svg
    check(plot_out == ("out" in lift_verdicts),
          f"the plot's headline ({'out' if plot_out else 'within'}) agrees with the lift verdicts {lift_verdicts}")
    pdf_href = b.driver.find_element(By.CSS_SELECTOR, "#report-pdf").get_attribute("href")
    status, body, ctype = svc.request("GET", pdf_href.replace(svc.base, ""))
    check(status == 200 and ctype == "application/pdf" and body.startswith(b"%PDF"),
          f"the PDF link answers a PDF: {status} {ctype} {body[:20]!r}")
    screenshots(b, shots, "run", lambda: b.count("#plot svg") == 1)
    # The plot: on the desktop as wide as the page; on a phone at the size it was drawn at, whose
    # text reads as on the desktop, in a box that scrolls sideways under a hint that says so.
    plot_js = """const svg = document.querySelector('#plot svg'), box = document.querySelector('#plot .plot-scroll');
        const hint = document.querySelector('#plot .plot-hint');
        return [svg.getBoundingClientRect().width, svg.width.baseVal.value, box.clientWidth, box.scrollWidth,
                hint && hint.getBoundingClientRect().height > 0 ? hint.textContent : ''];"""
    # The screenshots went through the phone's size: the plot is drawn wide again on the desktop.
    drawn_width = "const s = document.querySelector('#plot svg'); return s ? s.width.baseVal.value : 0;"
    wait_until("the plot drawn wide", lambda: b.driver.execute_script(drawn_width) == 1200)
    width, drawn, box, scrolled, hint = b.driver.execute_script(plot_js)
    check(abs(width - box) < 1 and scrolled <= box and hint == "", f"the plot fits the desktop's page: {width, box, scrolled, hint}")
    # On a phone the run's plot is drawn again stacked for it (380 px wide) and shown as wide as
    # the screen: no sideways scrolling, every text inside the picture, the smallest at 9 px or
    # more on the screen, and the headline naming the judged curve with the same verdict.
    b.size("phone")
    wait_until("the plot drawn for the phone", lambda: b.driver.execute_script(drawn_width) == 380)
    width, drawn, box, scrolled, hint = b.driver.execute_script(plot_js)
    check(abs(width - box) < 1 and scrolled <= box + 1 and hint == "",
          f"on a phone the plot fits the screen: {width, drawn, box, scrolled, hint}")
    smallest, outside = b.driver.execute_script("""const svg = document.querySelector('#plot svg');
        const texts = [...svg.querySelectorAll('text')];
        const page = svg.getBoundingClientRect();
        const out = texts.filter((t) => { const r = t.getBoundingClientRect(); return r.left < page.left - 0.5 || r.right > page.right + 0.5; })
                         .map((t) => t.textContent);
        return [Math.min(...texts.map((t) => parseFloat(t.getAttribute('font-size')))), out];""")
    check(smallest * width / drawn >= 9, f"the narrow plot's smallest text reads at {smallest * width / drawn:.1f} px")
    check(outside == [], f"every text of the narrow plot inside it: {outside}")
    narrow_svg = b.driver.find_element(By.CSS_SELECTOR, "#plot svg").get_attribute("outerHTML")
    check(f"judged: {judged['name']}" in narrow_svg and ("degrees outside" in narrow_svg) == plot_out,
          "the narrow plot names the judged curve and says what the wide one says of it")
    b.size("desktop")
    wait_until("the plot drawn wide again", lambda: b.driver.execute_script(drawn_width) == 1200)
    # The characteristics' verdicts whole, on the desktop too ("not judgec" was cut off by the
    # table's box), and on a phone every figure of them.
    check_in_view(b, "the characteristics", "desktop", ["table#characteristics td .verdict"],
                  whole_text=["table#characteristics td .verdict"])
    check_in_view(b, "the characteristics", "phone", ["table#characteristics td .verdict", "table#characteristics td"],
                  whole_text=["table#characteristics td .verdict"])
    # The first run's table, approved: version 1 of CAM_INTAKE_L1.
    first_id = svc.get_json("/api/runs?serial=S-1001")[0]["id"]
    b.go(ui + f"#/run/{first_id}")
    pushes = b.wait_text("table#run-pushes", "CAM_INTAKE_L1")
    check("approved by setup" in pushes and "µm" in pushes, f"the run's pushes: {pushes}")

    # ---- Trend of the lobe with its limits ----
    b.go(ui + "#/trend?part=intake_flat&lobe=1")
    wait_until("the trend plot", lambda: b.count("#trend-plot svg") == 1)
    wait_until("2 runs in the trend", lambda: b.count("table#trend-runs tbody tr") == 2)
    check("µm" in b.text("table#trend-runs"), "the trend's figures have units")
    screenshots(b, shots, "trend", lambda: b.count("#trend-plot svg") == 1)
    # Another characteristic of the run, chosen from those the lobe was judged on.
    wait_until("the phase among the characteristics",
               lambda: b.count("#trend-filters select[name=key] option[value=phase]") == 1)
    lift_svg = b.driver.find_element(By.CSS_SELECTOR, "#trend-plot svg").get_attribute("outerHTML")
    b.driver.execute_script("document.querySelector('#trend-filters select[name=key]').value = 'phase'")
    b.driver.find_element(By.CSS_SELECTOR, "#trend-filters button[type=submit]").click()
    b.wait_text("#trend-title", "phase per run")
    wait_until("the phase's trend plot", lambda: b.count("#trend-plot svg") == 1
               and b.driver.find_element(By.CSS_SELECTOR, "#trend-plot svg").get_attribute("outerHTML") != lift_svg)

    # ---- A camshaft's lobes ----
    # The service knows the shaft file: the record gives each lobe's nominal angle and index error.
    check(svc.get_json("/api/health")["shafts"] == ["web camshaft"], "the service names its shaft")
    b.go(ui + "#/shaft?serial=S-1002")
    b.wait_text("#shaft-title", "Serial S-1002 on web camshaft")
    wait_until("both lobes of S-1002", lambda: b.count("table#shaft-lobes tbody tr") == 2)
    shaft_text = b.text("#page")
    for fragment in ("index tolerance ±0.250 deg", "110.000 deg", "0.000 deg"):
        check(fragment in shaft_text, f"the shaft record shows {fragment}: {shaft_text}")
    check(b.count("table#shaft-lobes tbody tr a[href^='#/run/']") == 2, "both lobes link their runs")
    screenshots(b, shots, "shaft", lambda: b.count("table#shaft-lobes tbody tr") == 2)
    # A shaft the service does not know: the page says so and lists the serial's lobes instead.
    b.go(ui + "#/shaft?serial=S-1002&shaft=no-such-shaft")
    b.wait_text("#shaft-title", "2 lobes measured")
    check("no-such-shaft" in b.text("#shaft-note"), b.text("#shaft-note"))

    # ---- Pending tables: refused without the token ----
    pending = svc.get_json("/api/nc/pending")
    check(len(pending) == 2, f"two tables pending: {pending}")
    by_file = {p["nc_file"].rsplit("/", 1)[-1]: p["id"] for p in pending}
    approve_id, reject_id = by_file["CAM_INTAKE_L1.SPF"], by_file["CAM_INTAKE_L2.SPF"]
    b.go(ui + "#/pending")
    wait_until("two pending tables shown", lambda: b.count(".card.pending") == 2)
    check("needs the token" in b.text(f".card.pending[data-id='{approve_id}'] button.approve"),
          "the approve button says it needs the token")
    b.driver.find_element(By.CSS_SELECTOR, "#decided-by").send_keys("anna")
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{approve_id}'] button.approve").click()
    b.wait_text(f".card.pending[data-id='{approve_id}'] .result", "Refused")
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{reject_id}'] button.reject").click()
    b.wait_text(f".card.pending[data-id='{reject_id}'] .result", "Refused")
    check(len(svc.get_json("/api/nc/pending")) == 2, "nothing was decided without the token")
    check(len(svc.get_json("/api/nc/history?program=CAM_INTAKE_L1")) == 1, "no version written without the token")
    screenshots(b, shots, "pending", lambda: b.count(".card.pending") == 2)
    check_in_view(b, "the pending tables", "phone", [".card.pending .verdict", ".card.pending button.approve",
                                                     ".card.pending button.reject"],
                  whole_text=[".card.pending .verdict"])

    # ---- A wrong token is refused as it is entered, before any write ----
    b.driver.find_element(By.CSS_SELECTOR, "#token-input").send_keys("not-the-token")
    b.driver.find_element(By.CSS_SELECTOR, "#token-use").click()
    b.wait_text("#token-state", "token refused")
    check("not the one configured" in b.driver.find_element(By.CSS_SELECTOR, "#token-state").get_attribute("title"),
          "the refusal says why")
    wait_until("the token field still offered", lambda: b.driver.find_element(By.CSS_SELECTOR, "#token-input").is_displayed())
    wait_until("the pending tables drawn again, still needing the token",
               lambda: "needs the token" in b.text(f".card.pending[data-id='{approve_id}'] button.approve"))
    check(len(svc.get_json("/api/nc/pending")) == 2, "nothing was decided with a wrong token")

    # ---- The token, entered once for the session, and forgotten ----
    def enter_token():
        b.driver.find_element(By.CSS_SELECTOR, "#token-input").send_keys(svc.token)
        b.driver.find_element(By.CSS_SELECTOR, "#token-use").click()
        b.wait_text("#token-state", "writes enabled")
    enter_token()
    b.driver.find_element(By.CSS_SELECTOR, "#token-forget").click()
    b.wait_text("#token-state", "read-only")
    wait_until("the token field back", lambda: b.driver.find_element(By.CSS_SELECTOR, "#token-input").is_displayed())
    enter_token()
    wait_until("the buttons to no longer ask for the token",
               lambda: b.text(f".card.pending[data-id='{approve_id}'] button.approve") == "Approve and write")

    # ---- The change a table makes, above its diff, as the service computes it ----
    detail = svc.get_json(f"/api/nc/pending/{approve_id}")
    change = detail["change"]
    check(detail["in_force_version"] == 1 and detail["next_version"] == 2 and change["against_version"] == 1,
          f"the table would become version 2 over version 1: {detail}")
    summary_css = f".card.pending[data-id='{approve_id}'] .change-summary"
    summary = b.wait_text(summary_css, "Change from version 1 in force")
    check(b.text(summary_css + " .change-max") == f"{change['max_abs_um']:.2f} µm"
          and b.text(summary_css + " .change-at") == f"C {change['at_c_deg']}°"
          and b.text(summary_css + " .change-over") == str(change["degrees_over"])
          and "by more than 0.1 µm" in summary, f"the summary shows the service's figures {change}: {summary}")
    check(0 < change["degrees_over"] <= 360 and change["max_abs_um"] > 0.1, f"the new table changes the path: {change}")
    # The same figures computed here from the two programs' points.
    in_force_text = svc.get_json("/api/nc/table?program=CAM_INTAKE_L1")["program_text"]
    mine = table_change(detail["program_text"], in_force_text)
    check(abs(mine[0] - change["max_abs_um"]) < 0.005 and mine[1] == change["at_c_deg"] and mine[2] == change["degrees_over"],
          f"the change computed here {mine} is the service's {change}")
    b.wait_text(f".card.pending[data-id='{reject_id}'] .change-summary", "No table of CAM_INTAKE_L2 is in force yet")
    # A diff of the pending table from the table in force, below the summary.
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{approve_id}'] button.show-diff").click()
    b.wait_text(f".card.pending[data-id='{approve_id}'] #diff-count", "differ")
    check(b.driver.execute_script(
        "const c = document.querySelector(arguments[0]);"
        "return c.querySelector('.change-summary').getBoundingClientRect().bottom <= c.querySelector('#diff').getBoundingClientRect().top",
        f".card.pending[data-id='{approve_id}']"), "the summary is above the diff")

    # ---- Approve and reject ask first; dismissed, nothing is written ----
    b.wait_text("#pending-count", "2 tables wait")
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{approve_id}'] button.approve").click()
    question = wait_until("the approval's question", lambda: b.driver.switch_to.alert)
    asked = question.text
    for fragment in (f"Approve table {approve_id} for CAM_INTAKE_L1", "as version 2", "Version 1 is in force",
                     f"at most {change['max_abs_um']:.2f} µm at C {change['at_c_deg']}°",
                     f"{change['degrees_over']} of 360 degrees"):
        check(fragment in asked, f"the approval's question says {fragment!r}: {asked}")
    question.dismiss()
    b.wait_text(f".card.pending[data-id='{approve_id}'] .result", "Not approved: nothing was written")
    check(len(svc.get_json("/api/nc/pending")) == 2 and len(svc.get_json("/api/nc/history?program=CAM_INTAKE_L1")) == 1,
          "a dismissed approval writes nothing")
    check("2 tables wait" in b.text("#pending-count"), b.text("#pending-count"))
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{reject_id}'] button.reject").click()
    question = wait_until("the rejection's question", lambda: b.driver.switch_to.alert)
    check(f"Reject table {reject_id} for CAM_INTAKE_L2" in question.text and "version 1" in question.text,
          f"the rejection's question: {question.text}")
    question.dismiss()
    b.wait_text(f".card.pending[data-id='{reject_id}'] .result", "Not rejected: nothing was written")
    check(len(svc.get_json("/api/nc/pending")) == 2, "a dismissed rejection writes nothing")
    # Accepted: written, and the page shows what the service holds now without a reload.
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{approve_id}'] button.approve").click()
    wait_until("the approval's question", lambda: b.driver.switch_to.alert).accept()
    b.wait_text(f".card.pending[data-id='{approve_id}'] .result", "Approved: version 2 of CAM_INTAKE_L1")
    b.wait_text(f".card.pending[data-id='{approve_id}'] h2 .verdict", "approved")
    check(b.count(f".card.pending[data-id='{approve_id}'] button.approve") == 0, "an approved table offers no approval")
    check("by anna" in b.text(f".card.pending[data-id='{approve_id}'] dl"), "the card says who approved it")
    b.wait_text("#pending-count", "1 table waits")
    b.driver.find_element(By.CSS_SELECTOR, f".card.pending[data-id='{reject_id}'] button.reject").click()
    wait_until("the rejection's question", lambda: b.driver.switch_to.alert).accept()
    b.wait_text(f".card.pending[data-id='{reject_id}'] .result", "Rejected")
    b.wait_text(f".card.pending[data-id='{reject_id}'] h2 .verdict", "rejected")
    b.wait_text("#pending-count", "No table waits")
    check(svc.get_json("/api/nc/pending") == [], "no table is pending after the decisions")
    decided = {p["id"]: p for p in svc.get_json("/api/nc/pending?all=true")}
    check(decided[approve_id]["status"] == "approved" and decided[approve_id]["decided_by"] == "anna",
          f"approved by anna: {decided[approve_id]}")
    check(decided[reject_id]["status"] == "rejected" and decided[reject_id]["decided_by"] == "anna",
          f"rejected by anna: {decided[reject_id]}")
    # The token is kept for the session: a reload still writes.
    b.driver.refresh()
    b.wait_text("#token-state", "writes enabled")
    wait_until("no pending table left", lambda: b.count("#no-pending") == 1)

    # ---- NC history: version 2 is in force, and its diff from version 1 ----
    b.go(ui + "#/nc?program=CAM_INTAKE_L1")
    b.wait_text("#nc-title", "2 versions, version 2 in force")
    wait_until("the NC history's rows", lambda: b.count("table#nc-history tbody tr") == 2)
    b.wait_text("#diff-count", "differ")
    check(b.count("#diff .add") > 0 and b.count("#diff .del") > 0, "the diff marks added and removed lines")
    screenshots(b, shots, "nc", lambda: b.count("#diff .add") > 0)
    check_in_view(b, "the NC history", "phone", ["table#nc-history button.rollback", "table#nc-history td"])
    # Roll back to version 1, after a question naming the versions: dismissed, nothing is written;
    # accepted, version 3 holds its table, and the history shows it without a reload.
    b.driver.find_element(By.CSS_SELECTOR, "table#nc-history tr[data-version='1'] button.rollback").click()
    question = wait_until("the rollback's question", lambda: b.driver.switch_to.alert)
    check("Roll CAM_INTAKE_L1 back to the table of version 1" in question.text and "as version 3" in question.text
          and "version 2 is in force" in question.text, f"the rollback's question: {question.text}")
    question.dismiss()
    b.wait_text("#nc-message", "Not rolled back")
    check(len(svc.get_json("/api/nc/history?program=CAM_INTAKE_L1")) == 2, "a dismissed rollback writes nothing")
    b.driver.find_element(By.CSS_SELECTOR, "table#nc-history tr[data-version='1'] button.rollback").click()
    wait_until("the rollback's question", lambda: b.driver.switch_to.alert).accept()
    b.wait_text("#nc-message", "Rolled back: version 3 holds the table of version 1")
    b.wait_text("#nc-title", "3 versions, version 3 in force")
    b.wait_text("#diff-count", "differ")
    check(b.count("table#nc-history tr[data-version='3'] button.rollback") == 0
          and b.count("table#nc-history tr[data-version='2'] button.rollback") == 1
          and b.count("table#nc-history tr[data-version='1'] button.rollback") == 1,
          "version 3 is in force, versions 1 and 2 can be rolled back to")
    v1 = svc.get_json("/api/nc/table?program=CAM_INTAKE_L1&version=1")["program_text"]
    v3 = svc.get_json("/api/nc/table?program=CAM_INTAKE_L1&version=3")["program_text"]
    check(v3 != v1 and "rollback" in svc.get_json("/api/nc/history?program=CAM_INTAKE_L1")[0]["reason"],
          "version 3 was written by the rollback")

    # ---- A new program from the drawing: previewed, then written ----
    # Lobe 2's only table was rejected: CAM_INTAKE_L2 has no history, and its first program is
    # written here. Lobe 1's program has one, and is refused without "replace".
    b.go(ui + "#/new")
    wait_until("the parts to choose from", lambda: b.count("#new-part option") == 2)
    b.driver.execute_script("document.querySelector('#new-part').value = 'intake_flat|2'")
    b.driver.find_element(By.CSS_SELECTOR, "#new-form button[type=submit]").click()
    b.wait_text("#new-title", "CAM_INTAKE_L2: intake_flat lobe 2")
    check("part=intake_flat" in b.driver.current_url and "lobe=2" in b.driver.current_url,
          f"the preview is a link: {b.driver.current_url}")
    cards = b.wait_text("#new-cards", "Command position error")
    check("blocks" in cards and "µm" in cards and "turns" in cards, f"the preview's cards: {cards}")
    wait_until("the preview picture", lambda: b.count("#new-plot svg") == 1)
    check(b.count("table#new-choices tr.chosen") == 1, "one table of those weighed is marked chosen")
    check(svc.request("GET", "/api/nc/history?program=CAM_INTAKE_L2")[0] == 404, "a preview writes nothing")
    screenshots(b, shots, "new", lambda: b.count("#new-plot svg") == 1)
    b.driver.find_element(By.CSS_SELECTOR, "#new-write").click()
    b.wait_text("#new-message", "Written: version 1 of CAM_INTAKE_L2")
    written = svc.get_json("/api/nc/history?program=CAM_INTAKE_L2")
    check(len(written) == 1 and written[0]["run_id"] is None and "new program" in written[0]["reason"],
          f"version 1 with no run behind it: {written}")
    b.go(ui + "#/new?part=intake_flat&lobe=1")
    b.wait_text("#new-title", "CAM_INTAKE_L1")
    b.driver.find_element(By.CSS_SELECTOR, "#new-write").click()
    refused = b.wait_text("#new-message", "has a history")
    check("replace" in refused, f"the refusal says how to replace it: {refused}")
    check(len(svc.get_json("/api/nc/history?program=CAM_INTAKE_L1")) == 3, "the refused program is unchanged")

    # ---- Service state, refreshing itself ----
    b.go(ui + "#/state")
    cards = b.wait_text("#state-cards", "grinder-web")
    check("idle" in cards and "Last run" in cards, f"the service state: {cards}")
    state = b.text("#state-out")
    for section in ("Outbox (plant broker)", "Central history sync"):
        at = state.find(section)
        check(at >= 0 and "not configured" in state[at:at + len(section) + 40],
              f"the state says {section} is not configured: {state}")
    first = b.text("#state-time")
    wait_until("the state to refresh itself", lambda: b.text("#state-time") != first, deadline_s=30)
    screenshots(b, shots, "state", lambda: b.count("#state-cards") == 1)
    check_in_view(b, "the service page", "phone", ["#measure-button", "#state-cards .card"])
    # Measure now, with the token still in the session.
    before = len(svc.get_json("/api/runs"))
    b.driver.find_element(By.CSS_SELECTOR, "#measure-form input[name=serial]").send_keys("S-1003")
    b.driver.find_element(By.CSS_SELECTOR, "#measure-button").click()
    said = b.wait_text("#measure-message", "Measured: run")
    runs = svc.get_json("/api/runs")
    check(len(runs) == before + 1 and runs[0]["serial"] == "S-1003", f"a run of S-1003 was measured: {runs[0]}")
    waiting = svc.get_json("/api/nc/pending")
    check(len(waiting) == 1 and waiting[0]["run_id"] == runs[0]["id"], f"its table waits: {waiting}")
    check(f"Measured: run {runs[0]['id']} — its table waits for approval (table {waiting[0]['id']})" in said,
          f"the page says where its table went: {said}")
    b.driver.find_element(By.CSS_SELECTOR, "#measure-message a").click()
    b.wait_text("#title", f"Run {runs[0]['id']}")

    # ---- Gears: two gears of the virtual gear grinder's loop in the same database ----
    subprocess.run([svc.gaugeloop, "demo", "--part", str(EXAMPLES / "gear_71.toml"), "--iterations", "1",
                    "--machine-seed", "2", "--data-dir", str(svc.work)], check=True, stdout=subprocess.DEVNULL)
    b.go(ui + "#/gears")
    wait_until("two gear runs listed", lambda: b.count("table#gear-runs tbody tr") == 2)
    gears = b.text("table#gear-runs")
    for fragment in ("gear_71", "virtual gear grinder", "GEAR-1", "µm", "stroke v2"):
        check(fragment in gears, f"the gear runs show {fragment}: {gears}")
    verdicts = [td.text for td in b.driver.find_elements(By.CSS_SELECTOR, "table#gear-runs tbody tr td:nth-child(8)")]
    check(verdicts == ["in", "out"], f"the corrected gear in, the first out: {verdicts}")
    screenshots(b, shots, "gears", lambda: b.count("table#gear-runs tbody tr") == 2)
    b.driver.find_element(By.CSS_SELECTOR, "table#gear-runs tbody tr:last-child").click()
    b.wait_text("#gear-title", "Gear run 1: gear_71")
    wait_until("the lead's 8 traces drawn and tabled", lambda: b.count("#lead-plot svg polyline") == 8
               and b.count("table#gear-traces tbody tr") == 8)
    figures = b.text("#gear-figures")
    check("class 5 asked" in figures and "v2 pushed from it" in figures and "within" in figures,
          f"the gear's figures: {figures}")
    check(b.count("table#gear-profiles tbody tr") == 8, "the profiles of the 8 flanks tabled")
    check("Fα worst flank" in b.text("#gear-profile-figures"), "the profile's figures shown")
    gear_pdf = b.driver.find_element(By.CSS_SELECTOR, "#gear-report-pdf").get_attribute("href")
    status, body, ctype = svc.request("GET", gear_pdf.replace(svc.base, ""))
    check(status == 200 and ctype == "application/pdf" and body.startswith(b"%PDF"),
          f"the gear's lead report link answers a PDF: {status} {ctype} {body[:20]!r}")
    screenshots(b, shots, "gear", lambda: b.count("#lead-plot svg") == 1)

    # ---- A correction layer: the NC page names the design table the control adds it to ----
    subprocess.run([svc.gaugeloop, "nc", "new", "--part", str(EXAMPLES / "intake_flat_layer.toml"), "--replace",
                    "--data-dir", str(svc.work)], check=True, stdout=subprocess.DEVNULL)
    b.go(ui + "#/nc?program=CAM_INTAKE_L1")
    b.wait_text("#nc-layer", "is a correction layer")
    layer = b.text("#nc-layer")
    check("CAM_INTAKE_L1_DESIGN (table 5)" in layer and "never by a push" in layer,
          f"the layer names its design table: {layer}")

    # ---- Every asset from the service itself, nothing from elsewhere ----
    sources = b.driver.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)"
        ".concat([...document.querySelectorAll('[src],[href]')].map(e => e.src || e.href))")
    foreign = [s for s in sources if s.startswith("http") and not s.startswith(svc.base)]
    check(foreign == [], f"every asset comes from the service: {foreign}")

    # No script error or blocked resource on any page; the writes refused without the token
    # (401), the record of the shaft the service does not know (404) and the new program refused
    # over a history (409) were meant.
    errors = [e for e in b.driver.get_log("browser")
              if e["level"] == "SEVERE" and "status of 401" not in e["message"]
              and not ("shaft=no-such-shaft" in e["message"] and "status of 404" in e["message"])
              and not ("/api/nc/new" in e["message"] and "status of 409" in e["message"])]
    check(errors == [], f"the browser console holds errors: {errors}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gaugeloop", required=True)
    ap.add_argument("--screenshots", required=True, help="directory the screenshots are written to")
    args = ap.parse_args()
    shots = pathlib.Path(args.screenshots)
    shots.mkdir(parents=True, exist_ok=True)
    for old in shots.glob("*.png"):  # what a person finds there is this run's
        old.unlink()
    work = pathlib.Path(tempfile.mkdtemp(prefix="gaugeloop-web-"))
    started = time.monotonic()
    svc = None
    browser = None
    ok = False
    try:
        svc = Service(str(pathlib.Path(args.gaugeloop).resolve()), work)
        log(f"service on {svc.base}, work in {work}")
        wait_until("the service's health", lambda: svc.get_json("/api/health").get("state") == "idle")
        svc.measure(1, "S-1001")
        first = svc.get_json("/api/nc/pending")
        check(len(first) == 1, f"the first run's table is pending: {first}")
        status, body, _ = svc.request("POST", f"/api/nc/approve/{first[0]['id']}", {"by": "setup"}, svc.token)
        check(status == 200, f"approving the first table: {status} {body!r}")
        svc.measure(1, "S-1002")
        svc.measure(2, "S-1002")
        log(f"3 runs measured in {time.monotonic() - started:.1f} s")
        try:
            browser = Browser(work)
        except (WebDriverException, OSError) as e:
            raise Failed(f"cannot start headless Chromium ({e}); scripts/install-deps.sh installs chromium, "
                         "chromium-driver and python3-selenium")
        run_checks(svc, browser, shots)
        ok = True
    except Failed as e:
        print(f"FAILED: {e}", file=sys.stderr)
        if browser is not None:
            try:
                browser.driver.save_screenshot(str(shots / "failure.png"))
                print(f"the page at the failure: {shots / 'failure.png'}", file=sys.stderr)
            except WebDriverException:
                pass
    finally:
        if browser is not None:
            browser.quit()
        if svc is not None:
            svc.stop()
        if ok:
            shutil.rmtree(work, ignore_errors=True)
        else:
            print(f"work directory kept: {work}", file=sys.stderr)
    log(f"{'passed' if ok else 'FAILED'} in {time.monotonic() - started:.1f} s; screenshots in {shots}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
