// The pages of gaugeloop: one small app over the service's JSON API (docs/http_api.md), routed
// by the part of the address after '#', so every page is a link a person can keep. No library:
// the grinder's PC has no network, and every byte here is served by the service itself.
"use strict";

const PAGE_SIZE = 25;
const TOKEN_KEY = "gaugeloop.token";
const BY_KEY = "gaugeloop.by";
let refreshTimer = null;  // the service page's; stopped when another page is shown
// What a write did, for the page drawn after it from the service's answers ({page, text});
// taken by that page.
let notice = null;

// ---- Helpers ----

function esc(text) {
  return String(text ?? "").replace(/[&<>"']/g, (c) => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;"}[c]));
}

// A figure with its unit, or "–" when not recorded.
function fig(value, unit, decimals) {
  if (value === null || value === undefined || Number.isNaN(value)) return "–";
  return Number(value).toFixed(decimals) + (unit ? " " + unit : "");
}
const um = (v) => fig(v, "µm", 2);
const deg = (v) => fig(v, "deg", 4);

function unitText(unit) {
  return {um: "µm", deg: "deg", "mm/deg": "mm/deg", "mm/deg^2": "mm/deg²"}[unit] ?? unit;
}
function decimalsOf(unit) {
  return {um: 2, deg: 4, "mm/deg": 6, "mm/deg^2": 7}[unit] ?? 4;
}

function verdict(v) {
  return `<span class="verdict ${esc(v)}">${esc(String(v).replace("_", " "))}</span>`;
}

// A run's id, a link to its page when the run is in this grinder's file; a run listed from the
// plant's central history that is another grinder's has its page on that grinder.
function runLink(r) {
  if (r.here === false) {
    return `<span class="elsewhere" title="run ${r.id} of ${esc(r.machine)}: its page is on that grinder">${r.id}</span>`;
  }
  return `<a href="#/run/${r.id}">${r.id}</a>`;
}

function utc(text) {
  return text ? esc(String(text).replace("T", " ").replace("Z", "")) : "–";
}

function token() { return sessionStorage.getItem(TOKEN_KEY) || ""; }

class ApiError extends Error {
  constructor(status, message) { super(message); this.status = status; }
}

async function answerOf(r) {
  const text = await r.text();
  let body = null;
  try { body = JSON.parse(text); } catch (e) { body = null; }
  if (!r.ok) throw new ApiError(r.status, (body && body.error) || `HTTP ${r.status}`);
  return body;
}

async function api(path) {
  return answerOf(await fetch(path, {cache: "no-store"}));
}

async function apiText(path) {
  const r = await fetch(path, {cache: "no-store"});
  if (!r.ok) await answerOf(r);
  return r.text();
}

// A write: the token goes along when one was entered; without it the service refuses and the
// page shows its answer.
async function write(path, body) {
  const headers = {"Content-Type": "application/json"};
  if (token()) headers["Authorization"] = "Bearer " + token();
  return answerOf(await fetch(path, {method: "POST", headers, body: JSON.stringify(body)}));
}

function writeLabel(verb) { return token() ? verb : `${verb} (needs the token)`; }

function message(el, text, kind) {
  el.innerHTML = `<div class="message ${kind || ""}">${esc(text)}</div>`;
}

function errorText(e) {
  if (e instanceof ApiError && e.status === 401) {
    return `Refused: ${e.message}. ` + (token() ? "Forget the token at the top of the page and enter the right one." : "Enter the token at the top of the page.");
  }
  if (e instanceof ApiError && e.status === 403) return `Refused: ${e.message}.`;
  return e.message || String(e);
}

function page() { return document.getElementById("page"); }

function params(query) {
  const out = {};
  new URLSearchParams(query || "").forEach((v, k) => { if (v !== "") out[k] = v; });
  return out;
}

function hashOf(path, p) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(p)) if (v !== undefined && v !== null && v !== "") q.set(k, v);
  const s = q.toString();
  return "#" + path + (s ? "?" + s : "");
}

function apiQuery(p) {
  const q = new URLSearchParams();
  for (const [k, v] of Object.entries(p)) if (v !== undefined && v !== null && v !== "") q.set(k, v);
  return q.toString();
}

// A plot in `el`: the SVG markup (the service's own plots, no scripts in them) in a box of its
// own. On a wide screen it scales to the page; on a narrow one (style.css) it keeps the size it
// was drawn at, whose text reads as on the desktop, and the box scrolls sideways under a hint
// that says so and, with `path`, links the plot alone for the phone to zoom.
function plotHtml(svg, path) {
  return `<p class="plot-hint">The plot is at full size: swipe it sideways to see the rest${
    path ? `, or <a href="${esc(path)}" target="_blank">open it alone</a> to zoom` : ""}.</p><div class="plot-scroll">${svg}</div>`;
}

// A plot the service can also draw stacked for a phone (`narrowable`: its path takes
// ?layout=narrow) is asked in the layout the screen wants, shown as wide as the screen (class
// "fits"), and drawn again when the window crosses the narrow screen's width.
const narrowScreen = window.matchMedia("(max-width: 700px)");
const narrowablePlots = new Map();  // element -> path, while the element is on the page
narrowScreen.addEventListener("change", () => {
  for (const [el, path] of narrowablePlots) {
    if (el.isConnected) showSvg(el, path, {narrowable: true});
    else narrowablePlots.delete(el);
  }
});

// The newest request for an element wins: a plot asked for again (the window crossed the narrow
// width, and back) before the first answer came is not overwritten by that older answer.
async function showSvg(el, path, {narrowable = false} = {}) {
  const narrow = narrowable && narrowScreen.matches;
  const shown = narrow ? path + (path.includes("?") ? "&" : "?") + "layout=narrow" : path;
  if (narrowable) narrowablePlots.set(el, path);
  const ticket = (el.plotTicket = (el.plotTicket ?? 0) + 1);
  try {
    const svg = await apiText(shown);
    if (el.plotTicket !== ticket) return;
    el.innerHTML = narrow ? `<div class="plot-scroll">${svg}</div>` : plotHtml(svg, shown);
    el.classList.add("plot");
    el.classList.toggle("fits", narrow);
  } catch (e) {
    if (el.plotTicket === ticket) message(el, errorText(e), "error");
  }
}

// Every table the pages draw reads as cards on a narrow screen (style.css): each cell carries its
// column's name (data-label), and the cells that hold a verdict or a write button are marked
// (class "keep") so that they show whole. Set here once for every table as it is drawn, so a
// page only writes its table.
function labelTable(table) {
  const names = [...table.querySelectorAll("thead th")].map((th) => th.textContent.trim());
  table.querySelectorAll("tbody tr").forEach((tr) => {
    let column = 0;
    for (const td of tr.children) {
      td.dataset.label = td.colSpan > 1 ? "" : (names[column] ?? "");
      if (td.querySelector(".verdict, button.write, button.danger")) td.classList.add("keep");
      column += td.colSpan;
    }
  });
  table.dataset.labelled = "true";
}

new MutationObserver(() => {
  document.querySelectorAll("#page table:not([data-labelled])").forEach(labelTable);
}).observe(document.getElementById("page"), {childList: true, subtree: true});

// The verdict filter of a list's form: any, in, out, not judged.
function verdictFilter(p) {
  return `<label>Verdict<select name="verdict">
        ${["", "in", "out", "not_judged"].map((v) => `<option value="${v}" ${p.verdict === v ? "selected" : ""}>${v ? v.replace("_", " ") : "any"}</option>`).join("")}
      </select></label>`;
}

function card(label, value) {
  return `<div class="card"><div class="label">${esc(label)}</div><div class="value">${value}</div></div>`;
}

// ---- Run history ----

async function runsPage(p) {
  const pageNo = Math.max(0, parseInt(p.page || "0", 10) || 0);
  // `size`: runs a page; kept in the address like the filters.
  const size = Math.min(500, Math.max(1, parseInt(p.size || String(PAGE_SIZE), 10) || PAGE_SIZE));
  const filters = {machine: p.machine, part: p.part, lobe: p.lobe, serial: p.serial, verdict: p.verdict, since: p.since, until: p.until,
                   size: p.size};
  page().innerHTML = `
    <h1>Run history</h1>
    <form class="filters" id="run-filters">
      <label>Machine<input name="machine" list="machines" value="${esc(p.machine)}"></label>
      <label>Part<input name="part" list="parts" value="${esc(p.part)}"></label>
      <label>Lobe<input name="lobe" type="number" min="1" value="${esc(p.lobe)}"></label>
      <label>Serial<input name="serial" list="serials" value="${esc(p.serial)}"></label>
      <datalist id="machines"></datalist><datalist id="parts"></datalist><datalist id="serials"></datalist>
      ${verdictFilter(p)}
      <label>From (UTC)<input name="since" type="date" value="${esc(p.since)}"></label>
      <label>To (UTC)<input name="until" type="date" value="${esc(p.until)}"></label>
      <button type="submit">Filter</button>
      <a href="#/runs">Clear</a>
    </form>
    <div id="runs-out"><p>Loading…</p></div>`;
  document.getElementById("run-filters").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const f = new FormData(ev.target);
    location.hash = hashOf("/runs", {...Object.fromEntries(f.entries()), size: p.size});
  });
  const out = document.getElementById("runs-out");
  // What the recent runs name, offered as the filters are typed.
  api("/api/runs?limit=500").then((recent) => {
    for (const [id, field] of [["machines", "machine"], ["parts", "part"], ["serials", "serial"]]) {
      const list = document.getElementById(id);
      if (list) list.innerHTML = [...new Set(recent.map((r) => r[field]).filter((v) => v))].map((v) => `<option value="${esc(v)}">`).join("");
    }
  }).catch(() => {});
  try {
    // Newest first; one more than the page shows says whether there is an older page.
    const limit = (pageNo + 1) * size + 1;
    const runs = await api("/api/runs?" + apiQuery({...filters, size: undefined, limit}));
    const rows = runs.slice(pageNo * size, (pageNo + 1) * size);
    const more = runs.length > (pageNo + 1) * size;
    if (rows.length === 0) {
      message(out, pageNo > 0 ? "No more runs." : "No run matches these filters.");
      return;
    }
    out.innerHTML = `
      <div class="scroll"><table id="runs">
        <thead><tr><th>Run</th><th>Started (UTC)</th><th>Machine</th><th>Part</th><th>Lobe</th><th>Serial</th>
          <th>Max raw error</th><th>Raw RMS</th><th>Repeatability</th><th>Phase</th><th>Verdict</th><th>Status</th></tr></thead>
        <tbody>${rows.map((r) => `
          <tr${r.here === false ? "" : ` class="row-link" data-run="${r.id}"`}>
            <td>${runLink(r)}</td><td>${utc(r.started_utc)}</td><td>${esc(r.machine)}</td>
            <td>${esc(r.part)}</td><td>${r.lobe}</td><td>${esc(r.serial ?? "–")}</td>
            <td class="num">${um(r.max_abs_error_um)}</td><td class="num">${um(r.rms_error_um)}</td>
            <td class="num">${um(r.repeatability_um)}</td><td class="num">${deg(r.phase_error_deg)}</td>
            <td>${verdict(r.verdict)}</td><td>${esc(r.status)}</td></tr>`).join("")}
        </tbody></table></div>
      <div class="pager">
        ${pageNo > 0 ? `<a id="newer" href="${hashOf("/runs", {...filters, page: pageNo - 1})}">← Newer</a>` : ""}
        <span class="muted" id="page-of">Page ${pageNo + 1}: runs ${pageNo * size + 1}–${pageNo * size + rows.length}, newest first</span>
        ${more ? `<a id="older" href="${hashOf("/runs", {...filters, page: pageNo + 1})}">Older →</a>` : ""}
      </div>`;
    out.querySelectorAll("tr.row-link").forEach((tr) => tr.addEventListener("click", () => { location.hash = "#/run/" + tr.dataset.run; }));
  } catch (e) {
    message(out, errorText(e), "error");
  }
}

// ---- Gear runs ----

async function gearRunsPage(p) {
  page().innerHTML = `
    <h1>Gear runs</h1>
    <form class="filters" id="gear-filters">
      <label>Part<input name="part" value="${esc(p.part)}"></label>
      <label>Machine<input name="machine" value="${esc(p.machine)}"></label>
      <label>Serial<input name="serial" value="${esc(p.serial)}"></label>
      ${verdictFilter(p)}
      <label>From (UTC)<input name="since" type="date" value="${esc(p.since)}"></label>
      <label>To (UTC)<input name="until" type="date" value="${esc(p.until)}"></label>
      <button type="submit">Filter</button>
      <a href="#/gears">Clear</a>
    </form>
    <div id="gears-out"><p>Loading…</p></div>`;
  document.getElementById("gear-filters").addEventListener("submit", (ev) => {
    ev.preventDefault();
    location.hash = hashOf("/gears", Object.fromEntries(new FormData(ev.target).entries()));
  });
  const out = document.getElementById("gears-out");
  try {
    const runs = await api("/api/gear-runs?" + apiQuery({part: p.part, machine: p.machine, serial: p.serial, verdict: p.verdict,
                                                        since: p.since, until: p.until, limit: 200}));
    if (runs.length === 0) { message(out, "No gear run matches these filters."); return; }
    out.innerHTML = `
      <div class="scroll"><table id="gear-runs">
        <thead><tr><th>Gear run</th><th>Started (UTC)</th><th>Machine</th><th>Part</th><th>Serial</th>
          <th>F<sub>β</sub> worst</th><th>Class</th><th>Verdict</th><th>Ground with</th><th>Pushed</th></tr></thead>
        <tbody>${runs.map((g) => `
          <tr class="row-link" data-gear-run="${g.id}">
            <td><a href="#/gear/${g.id}">${g.id}</a></td><td>${utc(g.started_utc)}</td><td>${esc(g.machine)}</td>
            <td>${esc(g.part)}</td><td>${esc(g.serial ?? "–")}</td><td class="num">${um(g.total_max_um)}</td>
            <td class="num">${g.tolerance_class}</td><td>${verdict(g.verdict)}</td>
            <td>${g.ground_with_version ? "stroke v" + g.ground_with_version : "–"}</td>
            <td>${g.pushed_version ? "stroke v" + g.pushed_version : "–"}</td></tr>`).join("")}
        </tbody></table></div>`;
    out.querySelectorAll("tr.row-link").forEach((tr) => tr.addEventListener("click", () => { location.hash = "#/gear/" + tr.dataset.gearRun; }));
  } catch (e) {
    message(out, errorText(e), "error");
  }
}

// The lead traces as lines across the face: Z along, the deviation up (um), one colour a flank.
function leadSvg(traces) {
  const w = 640, h = 260, m = 40;
  const zs = traces.flatMap((t) => t.z_mm), ds = traces.flatMap((t) => t.deviation_um);
  const z0 = Math.min(...zs), z1 = Math.max(...zs);
  const span = Math.max(1, ...ds.map((d) => Math.abs(d)));
  const x = (z) => m + (w - 2 * m) * (z - z0) / Math.max(1e-9, z1 - z0);
  const y = (d) => h / 2 - (h / 2 - m / 2) * d / span;
  const lines = traces.map((t, i) => `<polyline fill="none" stroke="${t.flank === "left" ? "#1f6fb2" : "#c0392b"}" stroke-width="1.2"
      stroke-dasharray="${i % 4 < 2 ? "" : "4 2"}" points="${t.z_mm.map((z, k) => `${x(z).toFixed(1)},${y(t.deviation_um[k]).toFixed(1)}`).join(" ")}"><title>gap ${t.gap}, ${t.flank} flank</title></polyline>`).join("");
  return `<svg viewBox="0 0 ${w} ${h}" width="${w}" height="${h}" style="max-width:900px" role="img" aria-label="lead traces">
    <line x1="${m}" x2="${w - m}" y1="${h / 2}" y2="${h / 2}" stroke="#999" stroke-width="0.5"/>
    <text x="${m}" y="14" font-size="12">±${span.toFixed(2)} µm; blue: left flanks, red: right flanks</text>
    <text x="${m}" y="${h - 6}" font-size="12">Z ${z0.toFixed(1)} mm</text><text x="${w - m}" y="${h - 6}" font-size="12" text-anchor="end">Z ${z1.toFixed(1)} mm</text>
    ${lines}</svg>`;
}

async function gearRunPage(id) {
  page().innerHTML = `<p>Loading gear run ${esc(id)}…</p>`;
  let g;
  try {
    g = await api("/api/gear-runs/" + encodeURIComponent(id));
  } catch (e) {
    page().innerHTML = `<h1>Gear run ${esc(id)}</h1><div id="gear-message"></div>`;
    message(document.getElementById("gear-message"), errorText(e), "error");
    return;
  }
  const judged = g.required_class
    ? `class ${g.required_class} asked: F<sub>β</sub> within ${um(g.total_tolerance_um)}` +
      (g.profile_tolerance_um != null ? `, F<sub>α</sub> within ${um(g.profile_tolerance_um)}` : "")
    : "the part names no tolerance class";
  // The profiles at the face's middle, when they were traced (a flank probe gives leads only).
  const profiles = (g.profiles ?? []).length === 0
    ? `<p class="muted" id="gear-profiles-none">Profile: not measured (the traces are leads only).</p>`
    : `<div class="cards" id="gear-profile-figures">
        ${card("Fα worst flank", um(g.profile.total_max_um) + ` (class ${g.profile.tolerance_class})`)}
        ${card("Fα mean", um(g.profile.total_mean_um))}
        ${card("ffα mean", um(g.profile.form_mean_um))}
        ${card("|fHα| mean", um(g.profile.slope_mean_abs_um))}
      </div>
      <div class="scroll"><table id="gear-profiles">
      <thead><tr><th>Gap</th><th>Flank</th><th>F<sub>α</sub></th><th>f<sub>fα</sub></th><th>f<sub>Hα</sub></th><th>Class</th><th>Range (roll, mm)</th></tr></thead>
      <tbody>${g.profiles.map((t) => `<tr><td>${t.gap}</td><td>${esc(t.flank)}</td><td class="num">${um(t.total_um)}</td>
        <td class="num">${um(t.form_um)}</td><td class="num">${um(t.slope_um)}</td><td class="num">${t.tolerance_class}</td>
        <td>${t.from_roll_mm.toFixed(2)} … ${t.to_roll_mm.toFixed(2)}</td></tr>`).join("")}</tbody></table></div>`;
  page().innerHTML = `
    <h1 id="gear-title">Gear run ${g.id}: ${esc(g.part)} on ${esc(g.machine)}</h1>
    <p class="muted">Measured ${utc(g.started_utc)} by ${esc(g.source)}${g.serial ? `, serial ${esc(g.serial)}` : ""}${g.operator ? `, ${esc(g.operator)}` : ""}
      · <a id="gear-report-pdf" href="/api/gear-runs/${g.id}/report.pdf">Lead report (PDF)</a></p>
    <div class="cards" id="gear-figures">
      ${card("Verdict", verdict(g.verdict) + ` <span class="muted">(${judged})</span>`)}
      ${card("Fβ worst flank", um(g.total_max_um) + ` (class ${g.tolerance_class})`)}
      ${card("Fβ mean", um(g.total_mean_um))}
      ${card("ffβ mean", um(g.form_mean_um))}
      ${card("|fHβ| mean", um(g.slope_mean_abs_um))}
      ${card("Stroke", (g.ground_with_version ? `ground with v${g.ground_with_version}` : "ground with a stroke not known") +
             (g.pushed_version ? `; v${g.pushed_version} pushed from it` : ""))}
    </div>
    <div id="lead-plot" class="plot">${plotHtml(leadSvg(g.traces), "")}</div>
    <div class="scroll"><table id="gear-traces">
      <thead><tr><th>Gap</th><th>Flank</th><th>F<sub>β</sub></th><th>f<sub>fβ</sub></th><th>f<sub>Hβ</sub></th><th>Class</th><th>Range (mm)</th></tr></thead>
      <tbody>${g.traces.map((t) => `<tr><td>${t.gap}</td><td>${esc(t.flank)}</td><td class="num">${um(t.total_um)}</td>
        <td class="num">${um(t.form_um)}</td><td class="num">${um(t.slope_um)}</td><td class="num">${t.tolerance_class}</td>
        <td>${t.from_mm.toFixed(2)} … ${t.to_mm.toFixed(2)}</td></tr>`).join("")}</tbody></table></div>
    ${profiles}`;
}

// ---- One run ----

// "lift error" or "radius error": the quantity a run's judged error curve is of.
function judgedQuantity(j) {
  return j.name.startsWith("radius") ? "radius error" : "lift error";
}

async function runPage(id) {
  page().innerHTML = `<p>Loading run ${esc(id)}…</p>`;
  let r;
  try {
    r = await api("/api/runs/" + encodeURIComponent(id));
  } catch (e) {
    page().innerHTML = `<h1>Run ${esc(id)}</h1>`;
    page().insertAdjacentHTML("beforeend", `<div class="message error">${esc(errorText(e))}</div>`);
    return;
  }
  const chars = r.characteristics || [];
  const j = r.judged_error;
  const program = r.nc_file ? r.nc_file.split("/").pop().replace(/\.spf$/i, "") : "";
  page().innerHTML = `
    <h1 id="title">Run ${r.id} · ${esc(r.part)} lobe ${r.lobe} · ${esc(r.machine)}</h1>
    <div class="links">
      <a id="report-pdf" href="/api/runs/${r.id}/report.pdf" target="_blank">Cam report (PDF)</a>
      <a href="/api/runs/${r.id}/export?comments=true">Degrees (CSV)</a>
      <a href="${hashOf("/trend", {part: r.part, lobe: r.lobe})}">Trend of this lobe</a>
      ${r.serial ? `<a href="${hashOf("/shaft", {serial: r.serial})}">Camshaft ${esc(r.serial)}</a>` : ""}
      ${program ? `<a href="${hashOf("/nc", {program})}">NC history of ${esc(program)}</a>` : ""}
    </div>
    <div class="cards" id="figures">
      ${card("Verdict", verdict(r.verdict))}
      ${card("Serial", esc(r.serial ?? "–"))}
      ${card(`Max ${esc(judgedQuantity(j))}, judged`, um(j.max_abs_um) + ` <span class="muted">at ${fig(j.max_abs_at_deg, "deg", 0)}</span>`)}
      ${card(`RMS, judged`, um(j.rms_um))}
      ${card(`Peak to valley, judged`, um(j.peak_to_valley_um))}
      ${j.reference === "at nominal timing" ? "" : card("Max raw error (nominal timing)", um(r.max_abs_error_um) + ` <span class="muted">at ${fig(r.max_abs_error_at_cam_deg, "deg", 0)}</span>`)}
      ${card("Repeatability", um(r.repeatability_um))}
      ${card("Phase error", deg(r.phase_error_deg))}
      ${card("Base circle runout (dial)", um(r.dial_runout_um))}
      ${card("Eccentricity (1st harmonic)", um(r.base_circle_runout_um))}
      ${card("Largest correction", um(r.correction_max_um))}
      ${card("Revolutions", esc(r.revolutions))}
    </div>
    <h2>Lift error over the cam degrees</h2>
    <p class="muted" id="judged-caption">The verdicts judge the ${esc(j.name)}: the bold curve, with the tolerance band around it${j.reference === "at nominal timing" ? "" : "; the thin grey curve is the error at nominal timing, not judged"}.</p>
    <div id="plot"><p>Loading the plot…</p></div>
    <h2>Characteristics</h2>
    ${chars.length === 0 ? `<p class="muted">This run was not judged: its part file gives no tolerances.</p>` : `
    <div class="scroll"><table id="characteristics">
      <thead><tr><th>Characteristic</th><th>Value</th><th>Min</th><th>Max</th><th>Lower limit</th><th>Upper limit</th><th>Zone</th><th>Of the error</th><th>Verdict</th></tr></thead>
      <tbody>${chars.map((c) => {
        const u = unitText(c.unit), d = decimalsOf(c.unit);
        return `<tr><td class="wrap">${esc(c.title)}</td><td class="num">${fig(c.value, u, d)}</td><td class="num">${fig(c.min, u, d)}</td>
          <td class="num">${fig(c.max, u, d)}</td><td class="num">${fig(c.lower_limit, u, d)}</td><td class="num">${fig(c.upper_limit, u, d)}</td>
          <td>${c.from_deg === null || c.from_deg === undefined ? "whole turn" : `${c.from_deg} to ${c.to_deg} deg`}</td>
          <td class="judges wrap">${esc(c.judges ?? "–")}</td><td>${verdict(c.verdict)}</td></tr>`;
      }).join("")}</tbody></table></div>`}
    <h2>Curve tables written from this run</h2>
    ${(r.nc_pushes || []).length === 0 ? `<p class="muted">None: no table of this run was written to the control.</p>` : `
    <div class="scroll"><table id="run-pushes"><thead><tr><th>Program</th><th>Version</th><th>Written (UTC)</th><th>Why</th><th>Blocks</th><th>Command error</th></tr></thead>
      <tbody>${r.nc_pushes.map((x) => `<tr><td><a href="${hashOf("/nc", {program: programOf(x.nc_file)})}">${esc(programOf(x.nc_file))}</a></td>
        <td>${x.table_version}</td><td>${utc(x.pushed_utc)}</td><td>${esc(x.reason)}</td><td class="num">${esc(x.block_count ?? "–")}</td>
        <td class="num">${um(x.command_error_um)}</td></tr>`).join("")}</tbody></table></div>`}
    <h2>Record</h2>
    <dl class="kv">
      <dt>Started</dt><dd>${utc(r.started_utc)} UTC</dd><dt>Finished</dt><dd>${utc(r.finished_utc)} UTC</dd>
      <dt>Operator</dt><dd>${esc(r.operator ?? "–")}</dd><dt>Gauge</dt><dd>${esc(r.gauge)}</dd>
      <dt>Part temperature</dt><dd id="run-part-temperature">${r.part_temperature_c == null ? "not given"
        : `${r.part_temperature_c.toFixed(1)} °C (${r.part_temperature_source === "plc" ? "PLC" : esc(r.part_temperature_source ?? "source not recorded")})`}</dd>
      <dt>Status</dt><dd>${esc(r.status)}</dd><dt>Note</dt><dd>${esc(r.note || "–")}</dd>
      <dt>Zero offset</dt><dd>${fig(r.zero_offset_mm, "mm", 4)}</dd>
      <dt>Ground with table</dt><dd>${r.ground_with_version ? "version " + esc(r.ground_with_version) : "–"}</dd>
      <dt>NC program</dt><dd>${esc(r.nc_file || "none written")}</dd>
    </dl>`;
  showSvg(document.getElementById("plot"), `/api/runs/${r.id}/plot.svg`, {narrowable: true});
}

// ---- Trend of a lobe ----

async function trendPage(p) {
  page().innerHTML = `<h1>Trend of a lobe</h1><div id="trend-form"><p>Loading…</p></div><div id="trend-out"></div>`;
  let lobes = [];
  try {
    const recent = await api("/api/runs?limit=500");
    const seen = new Set();
    for (const r of recent) {
      const k = r.part + "\u0000" + r.lobe;
      if (!seen.has(k)) { seen.add(k); lobes.push({part: r.part, lobe: r.lobe}); }
    }
  } catch (e) {
    message(document.getElementById("trend-form"), errorText(e), "error");
    return;
  }
  if (!p.part && lobes.length > 0) { p.part = lobes[0].part; p.lobe = String(lobes[0].lobe); }
  const key = p.key || "lift_error";
  // The characteristics the lobe's newest run was judged on; lift error when it was not judged.
  let keys = [];
  if (p.part) {
    try {
      const newest = await api("/api/runs?" + apiQuery({part: p.part, lobe: p.lobe, limit: 1}));
      if (newest.length && newest[0].here !== false) {
        keys = ((await api("/api/runs/" + newest[0].id)).characteristics || []).map((c) => c.key);
      }
    } catch (e) { keys = []; }
  }
  if (!keys.includes("lift_error")) keys.unshift("lift_error");
  if (!keys.includes(key)) keys.push(key);
  document.getElementById("trend-form").innerHTML = `
    <form class="filters" id="trend-filters">
      <label>Lobe<select name="lobe-of">${lobes.map((l) => `<option value="${esc(l.part)}|${l.lobe}" ${l.part === p.part && String(l.lobe) === String(p.lobe) ? "selected" : ""}>${esc(l.part)} lobe ${l.lobe}</option>`).join("")}</select></label>
      <label>Characteristic<select name="key">${keys.map((k) => `<option value="${esc(k)}" ${k === key ? "selected" : ""}>${esc(k)}</option>`).join("")}</select></label>
      <label>Machine<input name="machine" value="${esc(p.machine)}"></label>
      <label>From (UTC)<input name="since" type="date" value="${esc(p.since)}"></label>
      <label>To (UTC)<input name="until" type="date" value="${esc(p.until)}"></label>
      <button type="submit">Show</button>
    </form>`;
  document.getElementById("trend-filters").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const f = Object.fromEntries(new FormData(ev.target).entries());
    const [part, lobe] = (f["lobe-of"] || "|").split("|");
    location.hash = hashOf("/trend", {part, lobe, key: f.key, machine: f.machine, since: f.since, until: f.until});
  });
  const out = document.getElementById("trend-out");
  if (!p.part) { message(out, "No runs yet: the trend shows once a lobe was measured."); return; }
  const q = {part: p.part, lobe: p.lobe, machine: p.machine, since: p.since, until: p.until};
  out.innerHTML = `<h2 id="trend-title">${esc(p.part)} lobe ${esc(p.lobe)}: ${esc(key)} per run, with its limits</h2>
    <div id="trend-plot"><p>Loading the plot…</p></div><h2>Runs</h2><div id="trend-table"></div>`;
  showSvg(document.getElementById("trend-plot"), "/api/trend.svg?" + apiQuery({...q, key}));
  try {
    const runs = await api("/api/trend?" + apiQuery(q));
    document.getElementById("trend-table").innerHTML = `<div class="scroll"><table id="trend-runs">
      <thead><tr><th>Run</th><th>Started (UTC)</th><th>Machine</th><th>Serial</th><th>Max raw error</th><th>Raw RMS</th><th>Phase</th><th>Verdict</th></tr></thead>
      <tbody>${runs.slice().reverse().map((r) => `<tr><td>${runLink(r)}</td><td>${utc(r.started_utc)}</td><td>${esc(r.machine)}</td>
        <td>${esc(r.serial ?? "–")}</td><td class="num">${um(r.max_abs_error_um)}</td><td class="num">${um(r.rms_error_um)}</td>
        <td class="num">${deg(r.phase_error_deg)}</td><td>${verdict(r.verdict)}</td></tr>`).join("")}</tbody></table></div>`;
  } catch (e) {
    message(document.getElementById("trend-table"), errorText(e), "error");
  }
}

// ---- A camshaft's lobes ----

async function shaftPage(p) {
  page().innerHTML = `<h1>Camshaft</h1>
    <form class="filters" id="shaft-form"><label>Serial<input name="serial" list="serials" value="${esc(p.serial)}"></label>
      <datalist id="serials"></datalist><button type="submit">Show</button></form>
    <div id="shaft-out"></div>`;
  document.getElementById("shaft-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    location.hash = hashOf("/shaft", {serial: new FormData(ev.target).get("serial")});
  });
  const out = document.getElementById("shaft-out");
  try {
    const recent = await api("/api/runs?limit=500");
    const serials = [...new Set(recent.map((r) => r.serial).filter((s) => s))];
    document.getElementById("serials").innerHTML = serials.map((s) => `<option value="${esc(s)}">`).join("");
    if (!p.serial) {
      out.innerHTML = serials.length === 0 ? `<div class="message">No run recorded a serial number yet.</div>`
        : `<p>Recent shafts: ${serials.slice(0, 30).map((s) => `<a href="${hashOf("/shaft", {serial: s})}">${esc(s)}</a>`).join(", ")}</p>`;
      return;
    }
    // The shaft record with index errors when the service knows the shaft file; else the
    // lobes measured with this serial, from the run history.
    let why = "";
    const known = (await api("/api/health")).shafts || [];
    if (known.length > 0) {
      try {
        const record = await api("/api/shaft?" + apiQuery({serial: p.serial, shaft: p.shaft}));
        out.innerHTML = shaftRecordHtml(record);
        return;
      } catch (e) {
        if (!(e instanceof ApiError) || (e.status !== 404 && e.status !== 400)) throw e;
        why = e.message;
      }
    }
    const runs = await api("/api/runs?" + apiQuery({serial: p.serial, limit: 1000}));
    // The newest run of each lobe: the list is newest first.
    const lobes = new Map();
    for (const r of runs) {
      const k = r.part + "\u0000" + r.lobe;
      if (!lobes.has(k)) lobes.set(k, {run: r, count: 0});
      lobes.get(k).count += 1;
    }
    const rows = [...lobes.values()].sort((a, b) => a.run.lobe - b.run.lobe || a.run.part.localeCompare(b.run.part));
    if (rows.length === 0) { message(out, `No run of serial ${p.serial} is recorded.`); return; }
    const verdicts = rows.map((l) => l.run.verdict);
    const shaft = verdicts.includes("out") ? "out" : verdicts.every((v) => v === "in") ? "in" : "not_judged";
    out.innerHTML = `<h2 id="shaft-title">Serial ${esc(p.serial)}: ${rows.length} lobe${rows.length === 1 ? "" : "s"} measured, shaft ${verdict(shaft)}</h2>
      <div class="scroll"><table id="shaft-lobes"><thead><tr><th>Lobe</th><th>Part</th><th>Newest run</th><th>Started (UTC)</th><th>Machine</th>
        <th>Max raw error</th><th>Phase</th><th>Eccentricity</th><th>Verdict</th><th>Runs</th></tr></thead>
      <tbody>${rows.map(({run: r, count}) => `<tr><td>${r.lobe}</td><td>${esc(r.part)}</td><td>${runLink(r)}</td><td>${utc(r.started_utc)}</td>
        <td>${esc(r.machine)}</td><td class="num">${um(r.max_abs_error_um)}</td><td class="num">${deg(r.phase_error_deg)}</td>
        <td class="num">${um(r.base_circle_runout_um)}</td><td>${verdict(r.verdict)}</td><td class="num">${count}</td></tr>`).join("")}</tbody></table></div>
      <p class="muted" id="shaft-note">${why ? esc(why)
        : `Index errors against the shaft's nominal lobe angles: <code>gaugeloop runs shaft --shaft FILE --serial ${esc(p.serial)}</code>.`}</p>`;
  } catch (e) {
    message(out, errorText(e), "error");
  }
}

function shaftRecordHtml(rec) {
  const tol = rec.index_tolerance_deg === null ? "no index tolerance" : `index tolerance ±${fig(rec.index_tolerance_deg, "deg", 3)}`;
  return `<h2 id="shaft-title">Serial ${esc(rec.serial)} on ${esc(rec.shaft)}: shaft ${verdict(rec.verdict)}</h2>
    <p class="muted">Reference at C ${fig(rec.reference_c_deg, "deg", 3)}, ${tol}, datum lobe ${esc(rec.datum_lobe ?? "–")}.</p>
    <div class="scroll"><table id="shaft-lobes"><thead><tr><th>Lobe</th><th>Part</th><th>Nominal angle</th><th>Run</th><th>Started (UTC)</th>
      <th>Verdict</th><th>Phase</th><th>Nose at C</th><th>Index error</th><th>To the datum</th><th>Index</th><th>Note</th></tr></thead>
    <tbody>${rec.lobes.map((l) => `<tr><td>${l.lobe}</td><td>${esc(l.part)}</td><td class="num">${fig(l.angle_deg, "deg", 3)}</td>
      <td>${l.run_id === null ? "–" : `<a href="#/run/${l.run_id}">${l.run_id}</a>`}</td><td>${utc(l.started_utc)}</td><td>${verdict(l.verdict)}</td>
      <td class="num">${deg(l.phase_deg)}</td><td class="num">${fig(l.nose_c_deg, "deg", 3)}</td><td class="num">${fig(l.index_error_deg, "deg", 3)}</td>
      <td class="num">${fig(l.relative_error_deg, "deg", 3)}</td><td>${verdict(l.index_verdict)}</td><td>${esc(l.note)}</td></tr>`).join("")}</tbody></table></div>`;
}

// ---- NC history and diffs ----

function programOf(ncFile) { return String(ncFile).split("/").pop().replace(/\.spf$/i, ""); }

// Line diff by longest common subsequence: tables are a few hundred lines.
function diffLines(a, b) {
  const x = a.split(/\r?\n/), y = b.split(/\r?\n/);
  const n = x.length, m = y.length;
  const L = Array.from({length: n + 1}, () => new Uint32Array(m + 1));
  for (let i = n - 1; i >= 0; i--) for (let j = m - 1; j >= 0; j--) L[i][j] = x[i] === y[j] ? L[i + 1][j + 1] + 1 : Math.max(L[i + 1][j], L[i][j + 1]);
  const out = [];
  let i = 0, j = 0;
  while (i < n || j < m) {
    if (i < n && j < m && x[i] === y[j]) { out.push(["same", x[i]]); i++; j++; }
    else if (j < m && (i === n || L[i][j + 1] >= L[i + 1][j])) { out.push(["add", y[j]]); j++; }
    else { out.push(["del", x[i]]); i++; }
  }
  return out;
}

function diffHtml(a, b) {
  const d = diffLines(a, b);
  const changed = d.filter(([k]) => k !== "same").length;
  return `<p class="muted" id="diff-count">${changed} line${changed === 1 ? "" : "s"} differ (− removed, + added)</p>
    <pre class="diff" id="diff">${d.map(([k, t]) => `<span class="${k}">${k === "add" ? "+ " : k === "del" ? "− " : "  "}${esc(t)}</span>`).join("")}</pre>`;
}

async function ncPage(p) {
  page().innerHTML = `<h1>NC history</h1><div id="nc-programs"><p>Loading…</p></div><div id="nc-out"></div>`;
  let pushes;
  try {
    pushes = await api("/api/nc/history?limit=5000");
  } catch (e) {
    message(document.getElementById("nc-programs"), errorText(e), "error");
    return;
  }
  const programs = [...new Set(pushes.map((x) => programOf(x.nc_file)))].sort();
  const program = p.program || programs[0];
  document.getElementById("nc-programs").innerHTML = programs.length === 0 ? `<div class="message">No curve table was written yet.</div>`
    : `<div class="links">Program: ${programs.map((g) => g === program ? `<strong>${esc(g)}</strong>` : `<a href="${hashOf("/nc", {program: g})}">${esc(g)}</a>`).join(" ")}</div>`;
  if (!program) return;
  const out = document.getElementById("nc-out");
  let history;
  try {
    history = await api("/api/nc/history?" + apiQuery({program, limit: 1000}));
  } catch (e) {
    message(out, errorText(e), "error");
    return;
  }
  const newest = history.length ? history[0].table_version : 0;
  const a = p.a || (history.length > 1 ? history[1].table_version : newest), b = p.b || newest;
  out.innerHTML = `
    <h2 id="nc-title">${esc(program)}: ${history.length} version${history.length === 1 ? "" : "s"}, version ${newest} in force</h2>
    <form id="diff-form">
    <div class="scroll"><table id="nc-history"><thead><tr><th>Version</th><th>Written (UTC)</th><th>Run</th><th>Why</th><th>Interpolation</th><th>Blocks</th><th>Command error</th><th>Diff from</th><th>to</th><th></th></tr></thead>
    <tbody>${history.map((h) => `<tr data-version="${h.table_version}"><td>${h.table_version}</td><td>${utc(h.pushed_utc)}</td>
      <td>${h.run_id ? `<a href="#/run/${h.run_id}">${h.run_id}</a>` : "–"}</td><td>${esc(h.reason)}</td><td>${esc(h.interpolation ?? "–")}</td>
      <td class="num">${esc(h.block_count ?? "–")}</td><td class="num">${um(h.command_error_um)}</td>
      <td><input type="radio" name="a" value="${h.table_version}" ${String(a) === String(h.table_version) ? "checked" : ""}></td>
      <td><input type="radio" name="b" value="${h.table_version}" ${String(b) === String(h.table_version) ? "checked" : ""}></td>
      <td>${h.table_version === newest ? `<span class="muted">in force</span>` : `<button type="button" class="write rollback" data-version="${h.table_version}">${writeLabel("Roll back to this")}</button>`}</td></tr>`).join("")}</tbody></table></div>
    <div class="pager"><button type="submit">Show the diff</button></div></form>
    <div id="nc-message"></div>
    <h2>Version ${esc(a)} → version ${esc(b)}</h2><div id="nc-diff"><p>Loading…</p></div>`;
  document.getElementById("diff-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const f = new FormData(ev.target);
    location.hash = hashOf("/nc", {program, a: f.get("a"), b: f.get("b")});
  });
  const msg = document.getElementById("nc-message");
  if (notice && notice.page === "nc") message(msg, notice.text, "ok");
  notice = null;
  out.querySelectorAll("button.rollback").forEach((btn) => btn.addEventListener("click", async () => {
    const version = Number(btn.dataset.version);
    const by = askName();
    if (by === null) { message(msg, "A rollback needs your name.", "error"); return; }
    // With the token, the question names the versions as the service has them now; without it the
    // service refuses the write, and the page shows why.
    if (token()) {
      let now;
      try {
        now = (await api("/api/nc/history?" + apiQuery({program, limit: 1})))[0].table_version;
      } catch (e) {
        message(msg, errorText(e), "error");
        return;
      }
      if (!window.confirm(`Roll ${program} back to the table of version ${version}? It is written to the control again as version ${now + 1}; version ${now} is in force now.`)) {
        message(msg, "Not rolled back: nothing was written.");
        return;
      }
    }
    try {
      const r = await write("/api/nc/rollback", {program, version, by});
      // The history again from the service: the new version in force, its diff from the one restored.
      notice = {page: "nc", text: `Rolled back: version ${r.table_version} holds the table of version ${version}.`};
      show(hashOf("/nc", {program, a: version, b: r.table_version}));
    } catch (e) {
      message(msg, errorText(e), "error");
    }
  }));
  try {
    const [ta, tb] = await Promise.all([api("/api/nc/table?" + apiQuery({program, version: a})), api("/api/nc/table?" + apiQuery({program, version: b}))]);
    const layer = tb.layer ? `<div class="message" id="nc-layer">${esc(program)} is a correction layer: the control adds it (X from the virtual axis SIM1, following C) to the design table ${esc(tb.layer.design_program)} (table ${esc(tb.layer.design_table_number)}), written from the drawing and never by a push.
      ${tb.layer.design_problem ? `<strong>That design table cannot be used now:</strong> ${esc(tb.layer.design_problem)}` : `<details><summary>The design table as the control holds it</summary><pre>${esc(tb.layer.design_text)}</pre></details>`}</div>` : "";
    document.getElementById("nc-diff").innerHTML = layer + (ta.program_text === null || tb.program_text === null
      ? `<div class="message">The text of one of these versions was not kept (written by an older gaugeloop).</div>`
      : diffHtml(ta.program_text, tb.program_text));
  } catch (e) {
    message(document.getElementById("nc-diff"), errorText(e), "error");
  }
}

// Who decides: asked once per browser session, like the token.
function askName() {
  let by = sessionStorage.getItem(BY_KEY) || "";
  const field = document.getElementById("decided-by");
  if (field && field.value.trim()) by = field.value.trim();
  if (!by) {
    by = (window.prompt("Your name, recorded with the decision:") || "").trim();
    if (!by) return null;
  }
  sessionStorage.setItem(BY_KEY, by);
  return by;
}

// ---- Pending tables ----

// What approving pending table `t` (GET /api/nc/pending/{id}) would change, from the service's
// comparison of its curve table with the one in force; `plain` for a question's text.
function changeText(t, plain) {
  const b = (x, cls) => plain ? x : `<strong class="${cls}">${esc(x)}</strong>`;
  if (!t.change && t.in_force_version === null) return `No table of ${plain ? t.program : esc(t.program)} is in force yet: this would be its first.`;
  if (!t.change) return `Change from the table in force: not computed (${plain ? t.change_problem : esc(t.change_problem)}).`;
  const c = t.change;
  return `Change from version ${c.against_version} in force: at most ${b(um(c.max_abs_um), "change-max")} at ${b(`C ${c.at_c_deg}°`, "change-at")}; `
    + `${b(String(c.degrees_over), "change-over")} of ${c.degrees} degrees change by more than ${fig(c.threshold_um, "µm", 1)}.`;
}

function pendingCardHtml(t) {
  return `<div class="card pending" data-id="${t.id}" style="margin-bottom:10px">
      <h2>Table ${t.id} for ${esc(programOf(t.nc_file))} ${verdict(t.status)}</h2>
      <dl class="kv">${t.gear_run_id ? `<dt>Gear run</dt><dd>${t.gear_run_id} (a gear's stroke: \`gaugeloop gear runs show ${t.gear_run_id}\`)</dd>`
                       : `<dt>Run</dt><dd><a href="#/run/${t.run_id}">${t.run_id}</a></dd>`}<dt>Made (UTC)</dt><dd>${utc(t.created_utc)}</dd>
        <dt>Why it waits</dt><dd>${t.verdict === "hold" ? "held: " + esc(t.reason) : "every table needs approval"}</dd>
        <dt>Correction</dt><dd>${um(t.correction_max_um)} at most; ${esc(t.block_count ?? "–")} blocks, command error ${um(t.command_error_um)}</dd>
        ${t.decided_by ? `<dt>Decided</dt><dd>by ${esc(t.decided_by)} at ${utc(t.decided_utc)} ${esc(t.note)}</dd>` : ""}</dl>
      ${t.status === "pending" && !t.gear_run_id ? `<div class="change-summary"><span class="muted">Comparing with the table in force…</span></div>` : ""}
      ${t.status === "pending" ? `<div class="decide" style="margin-top:6px">
        <input class="note" placeholder="note (optional)">
        ${t.gear_run_id ? `<span class="muted">a gear's stroke: approve it with <code>gaugeloop nc approve ${t.id}</code>, which writes its main program's gearbox</span>`
                        : `<button class="write approve" data-id="${t.id}">${writeLabel("Approve and write")}</button>`}
        <button class="danger reject" data-id="${t.id}">${writeLabel("Reject")}</button>
        ${t.gear_run_id ? "" : `<button class="show-diff" data-id="${t.id}">Diff from the table in force</button>`}</div>` : ""}
      <div class="result"></div><div class="pending-diff"></div>
    </div>`;
}

async function pendingPage(p) {
  const all = p.all === "true";
  page().innerHTML = `<h1>Pending tables</h1>
    <p class="muted">A table waits here when the service holds it (a large change, poor repeatability) or every table needs approval.
      Approve writes it to the control; reject keeps the table in force. With the token, each asks first, naming the table, the version
      it would become and its change.</p>
    <p id="pending-count" class="muted"></p>
    <div class="decide"><label>Decided by <input id="decided-by" value="${esc(sessionStorage.getItem(BY_KEY) || "")}" placeholder="your name"></label>
      <a href="${hashOf("/pending", all ? {} : {all: "true"})}">${all ? "Show only pending" : "Show decided ones too"}</a></div>
    <div id="pending-message"></div><div id="pending-out"><p>Loading…</p></div>`;
  const out = document.getElementById("pending-out");
  // How many wait now, from the service: after each decision too.
  const count = async () => {
    const el = document.getElementById("pending-count");
    try {
      const n = (await api("/api/nc/pending?limit=200")).length;
      if (el) el.textContent = n === 0 ? "No table waits for a decision." : `${n} table${n === 1 ? " waits" : "s wait"} for a decision.`;
    } catch (e) {
      if (el) el.textContent = errorText(e);
    }
  };
  let tables;
  try {
    tables = await api("/api/nc/pending?" + apiQuery({all: all ? "true" : "", limit: 200}));
  } catch (e) {
    message(out, errorText(e), "error");
    return;
  }
  count();
  if (tables.length === 0) { out.innerHTML = `<div class="message" id="no-pending">No table is waiting for a decision.</div>`; return; }
  out.innerHTML = tables.map(pendingCardHtml).join("");
  const bind = (cardEl) => {
    const id = cardEl.dataset.id;
    const program = programOf(tables.find((t) => String(t.id) === id)?.nc_file ?? "");
    const result = cardEl.querySelector(".result");
    const summary = cardEl.querySelector(".change-summary");
    if (summary) {
      api("/api/nc/pending/" + id).then((t) => { summary.innerHTML = changeText(t, false); })
        .catch((e) => { summary.textContent = errorText(e); });
    }
    const decide = async (verb) => {
      const by = askName();
      if (by === null) { message(result, "A decision needs your name.", "error"); return; }
      const note = cardEl.querySelector(".note").value;
      // With the token, the question names what the service says now; without it the service
      // refuses the write, and the page shows why.
      if (token()) {
        let t;
        try {
          t = await api("/api/nc/pending/" + id);
        } catch (e) {
          message(result, errorText(e), "error");
          return;
        }
        if (t.status !== "pending") {
          message(result, `Table ${id} is no longer pending: it was ${t.status}. Reload the page for the tables that wait now.`, "error");
          return;
        }
        const question = verb === "approve"
          ? `Approve table ${id} for ${t.program} and write it to the control as version ${t.next_version}? (${
            t.in_force_version ? `Version ${t.in_force_version} is in force now.` : `No table of ${t.program} is in force yet.`})`
          : `Reject table ${id} for ${t.program}, which would have become version ${t.next_version}? Nothing is written${
            t.in_force_version ? `: version ${t.in_force_version} stays in force` : ""}.`;
        if (!window.confirm(`${question}\n\n${changeText(t, true)}`)) {
          message(result, `Not ${verb === "approve" ? "approved" : "rejected"}: nothing was written.`);
          return;
        }
      }
      let text;
      try {
        const r = await write(`/api/nc/${verb}/${id}`, {by, note});
        text = verb === "approve" ? `Approved: version ${r.table_version} of ${programOf(r.nc_file)} written to the control.`
                                  : `Rejected: the table in force of ${program} stays.`;
      } catch (e) {
        message(result, errorText(e), "error");
        return;
      }
      // The card again as the service has it now: its status, who decided, no buttons.
      try {
        const fresh = await api("/api/nc/pending/" + id);
        cardEl.outerHTML = pendingCardHtml(fresh);
      } catch (e) {
        cardEl.querySelectorAll("button.approve, button.reject").forEach((b) => { b.disabled = true; });
      }
      const now = out.querySelector(`.card.pending[data-id="${id}"] .result`);
      message(now, text, "ok");
      if (verb === "approve") {
        now.insertAdjacentHTML("beforeend", `<a class="nc-link" href="${hashOf("/nc", {program})}">NC history of ${esc(program)}</a>`);
      }
      count();
    };
    cardEl.querySelector("button.approve")?.addEventListener("click", () => decide("approve"));
    cardEl.querySelector("button.reject")?.addEventListener("click", () => decide("reject"));
    cardEl.querySelector("button.show-diff")?.addEventListener("click", async () => {
      const target = cardEl.querySelector(".pending-diff");
      try {
        const t = await api("/api/nc/pending/" + id);
        let inForce = "";
        try { inForce = (await api("/api/nc/table?" + apiQuery({program: t.nc_file}))).program_text || ""; } catch (e) { if (!(e instanceof ApiError && e.status === 404)) throw e; }
        target.innerHTML = diffHtml(inForce, t.program_text);
      } catch (e) {
        message(target, errorText(e), "error");
      }
    });
  };
  out.querySelectorAll(".card.pending").forEach(bind);
}

// ---- New program ----

// The first program of a configured part, from its drawing: previewed here, written to the
// control only when a person with the token asks.
async function newPage(p) {
  page().innerHTML = `<h1>New program</h1>
    <p class="muted">The first program of a part from its drawing: the table(s), the speed program and the main program with its passes,
      written as a push writes them. Preview it first; nothing goes to the control until you write it.</p>
    <form class="filters" id="new-form"><label>Part<select name="part-of" id="new-part"></select></label>
      <button type="submit">Preview</button></form>
    <div id="new-out"></div>`;
  const select = document.getElementById("new-part");
  try {
    const h = await api("/api/health");
    const parts = Array.isArray(h.parts) ? h.parts : [];
    select.innerHTML = parts.map((x) => `<option value="${esc(x.part)}|${x.lobe}" ${x.part === p.part && String(x.lobe) === String(p.lobe) ? "selected" : ""}>${esc(x.part)} lobe ${x.lobe}</option>`).join("");
  } catch (e) {
    message(document.getElementById("new-out"), "The service does not answer: " + errorText(e), "error");
    return;
  }
  document.getElementById("new-form").addEventListener("submit", (ev) => {
    ev.preventDefault();
    const [part, lobe] = (new FormData(ev.target).get("part-of") || "|").split("|");
    location.hash = hashOf("/new", {part, lobe});
  });
  if (!p.part || !p.lobe) return;
  const out = document.getElementById("new-out");
  message(out, "Computing the preview…");
  const q = apiQuery({part: p.part, lobe: p.lobe});
  let v;
  try {
    v = await api("/api/nc/new?" + q);
  } catch (e) {
    message(out, errorText(e), "error");
    return;
  }
  const t = v.table;
  const tableText = (x) => `${x.blocks} blocks ${esc(x.interpolation)}, seam C${fig(x.seam_c_deg, "", 3)}`;
  const umCmd = (x) => fig(x, "µm", 3);  // the command error beside its bound: 0.499 is not 0.50
  const passes = v.passes.map((x) => `${esc(x.name)} ${x.turns} turn${x.turns === 1 ? "" : "s"}${x.infeed_mm > 0 ? " " + fig(x.infeed_mm, "mm", 4) : ""}`).join(", ");
  out.innerHTML = `<h2 id="new-title">${esc(v.program)}: ${esc(v.part)} ${esc(v.kind)} ${esc(v.lobe)}</h2>
    <div class="cards" id="new-cards">
      ${card(v.y_table ? "X table" : "Table", tableText(t))}
      ${card("Command position error", `${umCmd(t.command_error_um)} <span class="muted">bound ${umCmd(v.command_error_bound_um)}</span>`)}
      ${v.y_table ? card("Y table", `${tableText(v.y_table)}; ${umCmd(v.y_table.command_error_um)}`) : ""}
      ${card("Work spindle", v.speed_program ? `speed program, ${v.speed_program.feed_blocks} blocks` : fig(v.work_speed_rpm, "rpm", 0))}
      ${card("Cycle", `${v.turns} turns, ${fig(v.cycle_time_s, "s", 1)}`)}
      ${card("Start offset", `${fig(v.start_offset_mm, "mm", 4)} <span class="muted">stock ${fig(v.stock_mm, "", 4)} + air ${fig(v.air_gap_mm, "", 4)}</span>`)}
    </div>
    <p class="muted">Passes: ${passes || "none"}. Written to ${esc(v.nc_file)}.</p>
    <div id="new-plot"><p>Loading the picture…</p></div>
    <h2>Tables weighed</h2>
    <div class="scroll"><table id="new-choices"><thead><tr><th>Axis</th><th>Writer</th><th>Interpolation</th><th>Seam C</th><th>Blocks</th><th>Command error</th><th></th></tr></thead>
    <tbody>${v.choices.map((c) => c.refused !== undefined
      ? `<tr><td>${esc(c.axis)}</td><td>${esc(c.writer)}</td><td colspan="5" class="muted">refused: ${esc(c.refused)}</td></tr>`
      : `<tr class="${c.chosen ? "chosen" : ""}"><td>${esc(c.axis)}</td><td>${esc(c.writer)}</td><td>${esc(c.interpolation)}</td><td class="num">${fig(c.seam_c_deg, "", 3)}</td>
         <td class="num">${c.blocks}</td><td class="num">${umCmd(c.command_error_um)}${c.command_error_um > v.command_error_bound_um ? " <span class=\"muted\">over the bound</span>" : ""}</td>
         <td>${c.chosen ? "<strong>chosen</strong>" : ""}</td></tr>`).join("")}</tbody></table></div>
    <h2>Write it to the control</h2>
    <div class="decide"><label>Written by <input id="decided-by" value="${esc(sessionStorage.getItem(BY_KEY) || "")}" placeholder="your name"></label>
      <label><input type="checkbox" id="new-replace"> replace a program that has a history</label>
      <button class="write" id="new-write">${writeLabel("Write the new program")}</button></div>
    <div id="new-message"></div>`;
  showSvg(document.getElementById("new-plot"), "/api/nc/new/plot.svg?" + q);
  document.getElementById("new-write").addEventListener("click", async () => {
    const msg = document.getElementById("new-message");
    const by = askName();
    if (by === null) { message(msg, "Writing a program needs your name.", "error"); return; }
    const replace = document.getElementById("new-replace").checked;
    if (replace && !window.confirm(`Start ${v.program} again from the drawing? Its history stays; what the loop has learnt is no longer in force.`)) return;
    message(msg, "Writing…");
    try {
      const r = await write("/api/nc/new", {part: v.part, lobe: Number(v.lobe), by, replace});
      message(msg, `Written: version ${r.table_version} of ${programOf(r.nc_file)}, ${r.files.length} files, each read back.`, "ok");
      msg.insertAdjacentHTML("beforeend", `<a id="new-history" href="${hashOf("/nc", {program: programOf(r.nc_file)})}">NC history of ${esc(programOf(r.nc_file))}</a>`);
    } catch (e) {
      message(msg, errorText(e), "error");
    }
  });
}

// ---- Service state ----

function kvList(obj) {
  if (obj === null || obj === undefined) return `<span class="muted">not configured</span>`;
  if (typeof obj !== "object") return esc(obj);
  return `<dl class="kv">${Object.entries(obj).map(([k, v]) => `<dt>${esc(k.replaceAll("_", " "))}</dt><dd>${
    v !== null && typeof v === "object" ? (Array.isArray(v) ? esc(JSON.stringify(v)) : kvList(v)) : esc(v ?? "–")}</dd>`).join("")}</dl>`;
}

async function statePage() {
  page().innerHTML = `<h1>Service</h1><div id="state-out"><p>Loading…</p></div>
    <h2>Measure now</h2><form class="filters" id="measure-form"><label>Lobe<select name="lobe-of" id="measure-lobe"></select></label>
      <label>Serial<input name="serial"></label><label>Operator<input name="operator"></label>
      <label>Part °C<input name="part_temperature_c" inputmode="decimal" size="6"></label><label>Note<input name="note"></label>
      <button type="submit" class="write" id="measure-button">${writeLabel("Measure")}</button></form><div id="measure-message"></div>`;
  let lobesFilled = false;
  const refresh = async () => {
    const out = document.getElementById("state-out");
    if (!out) return;
    try {
      const [h, last] = await Promise.all([api("/api/health"), api("/api/runs?limit=1").catch(() => [])]);
      const r = last[0];
      out.innerHTML = `<div class="cards" id="state-cards">
          ${card("State", esc(h.state ?? "–"))}${card("Machine", esc(h.machine ?? "–"))}
          ${card("Gauge", esc(h.gauge ?? "–"))}
          ${card("PLC link", h.plc ? esc(h.plc.connected === false ? "down" : h.plc.connected === true ? "up" : "configured") : "not configured")}
          ${card("Last run", r ? `<a href="#/run/${r.id}">${r.id}</a> ${verdict(r.verdict)} <span class="muted">${utc(r.started_utc)}</span>` : "none yet")}
          ${card("Database", h.database && h.database.available ? "available" : "not available")}
          ${card("Writes", esc(h.writes))}
          ${card("Version", esc(h.version))}
        </div>
        <p class="muted" id="state-time">As of ${utc(h.time_utc)} UTC; refreshed every 5 s.</p>
        <h2>PLC</h2>${kvList(h.plc)}
        <h2>Outbox (plant broker)</h2>${kvList(h.outbox)}
        <h2>Central history sync</h2>${kvList(h.central)}
        <h2>Database</h2>${kvList(h.database)}`;
      if (!lobesFilled && Array.isArray(h.parts)) {
        lobesFilled = true;
        document.getElementById("measure-lobe").innerHTML = h.parts.map((x) => `<option value="${esc(x.part)}|${x.lobe}">${esc(x.part)} lobe ${x.lobe}</option>`).join("");
      }
    } catch (e) {
      message(out, "The service does not answer: " + errorText(e), "error");
    }
  };
  document.getElementById("measure-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const f = Object.fromEntries(new FormData(ev.target).entries());
    const [part, lobe] = (f["lobe-of"] || "|").split("|");
    const msg = document.getElementById("measure-message");
    const button = document.getElementById("measure-button");
    message(msg, "Measuring…");
    button.disabled = true;  // one measurement at a time: the service refuses a second (409)
    try {
      // Empty: not given; text that is no number goes as it is, for the service to refuse by name.
      const t = (f.part_temperature_c || "").trim();
      const part_temperature_c = t === "" ? null : Number.isFinite(Number(t)) ? Number(t) : t;
      const r = await write("/api/measure", {part, lobe: Number(lobe), serial: f.serial, operator: f.operator, part_temperature_c, note: f.note});
      // What became of its table, from the answer: written, waiting for approval, or neither and why.
      const table = r.pushed ? `version ${r.table_version} of ${programOf(r.nc_file)} written to the control`
        : r.pending_id ? `its table waits for approval (table ${r.pending_id})`
        : `no table written: ${r.not_pushed_reason ?? "the service gave no reason"}`;
      message(msg, `Measured: run ${r.run_id} — ${table}.`, "ok");
      msg.insertAdjacentHTML("beforeend", `<div class="links"><a href="#/run/${r.run_id}">Show run ${r.run_id}</a>${
        r.pending_id ? `<a id="measure-pending" href="#/pending">Pending tables</a>` : ""}${
        r.pushed ? `<a href="${hashOf("/nc", {program: programOf(r.nc_file)})}">NC history of ${esc(programOf(r.nc_file))}</a>` : ""}</div>`);
      refresh();
    } catch (e) {
      message(msg, errorText(e), "error");
    } finally {
      button.disabled = false;
    }
  });
  await refresh();
  refreshTimer = setInterval(refresh, 5000);
}

// ---- Token and routing ----

// The token's state beside its field; `said`: what checking it last found, when that is more than
// "accepted" ({text, why}).
function showToken(said) {
  const on = token() !== "";
  const state = document.getElementById("token-state");
  state.textContent = said ? said.text : on ? "writes enabled" : "read-only";
  state.title = said ? said.why : on ? "the service accepted this token" : "enter the token to approve, reject, roll back and measure";
  state.classList.toggle("on", on && !said);
  state.classList.toggle("refused", !on && !!said);
  document.getElementById("token-input").hidden = on;
  document.getElementById("token-use").hidden = on;
  document.getElementById("token-forget").hidden = !on;
}

// Asks the service whether `candidate` is its token (GET /api/token: nothing is written). Kept
// for the session only when accepted, or when the service did not answer; null when accepted,
// otherwise what to show beside the field.
async function checkToken(candidate) {
  let r;
  try {
    r = await fetch("/api/token", {cache: "no-store", headers: {"Authorization": "Bearer " + candidate}});
  } catch (e) {
    sessionStorage.setItem(TOKEN_KEY, candidate);
    return {text: "token kept, not checked", why: `the service did not answer: ${e.message}`};
  }
  if (r.ok) {
    sessionStorage.setItem(TOKEN_KEY, candidate);
    return null;
  }
  sessionStorage.removeItem(TOKEN_KEY);
  let why = `HTTP ${r.status}`;
  try { why = (await r.json()).error || why; } catch (e) { /* the status says it */ }
  return {text: r.status === 403 ? "writes disabled" : "token refused", why};
}

document.getElementById("token-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const input = document.getElementById("token-input");
  const candidate = input.value.trim();
  input.value = "";
  if (!candidate) return;
  document.getElementById("token-state").textContent = "checking…";
  showToken(await checkToken(candidate));
  route();
});
document.getElementById("token-forget").addEventListener("click", () => {
  sessionStorage.removeItem(TOKEN_KEY);
  showToken();
  route();
});

// Shows the page at `hash`, drawn again when it is the one shown.
function show(hash) {
  if (location.hash === hash) route();
  else location.hash = hash;
}

function route() {
  if (refreshTimer) { clearInterval(refreshTimer); refreshTimer = null; }
  const hash = location.hash.replace(/^#/, "") || "/runs";
  const [path, query] = hash.split("?");
  const p = params(query);
  const parts = path.split("/").filter((x) => x);
  const name = parts[0] || "runs";
  if (notice && notice.page !== name) notice = null;
  document.querySelectorAll("nav a").forEach((a) => a.classList.toggle("current", a.dataset.page === (name === "run" ? "runs" : name === "gear" ? "gears" : name)));
  const pages = {
    runs: () => runsPage(p),
    run: () => runPage(parts[1] || ""),
    gears: () => gearRunsPage(p),
    gear: () => gearRunPage(parts[1] || ""),
    trend: () => trendPage(p),
    shaft: () => shaftPage(p),
    nc: () => ncPage(p),
    pending: () => pendingPage(p),
    new: () => newPage(p),
    state: () => statePage(),
  };
  if (!pages[name]) {
    page().innerHTML = `<h1>No such page</h1><p><a href="#/runs">The run history</a></p>`;
    return;
  }
  pages[name]();
}

window.addEventListener("hashchange", route);
showToken();
route();
// A token kept from earlier in the session is checked again: the service's may have changed.
if (token()) checkToken(token()).then((said) => { if (said) { showToken(said); route(); } });
