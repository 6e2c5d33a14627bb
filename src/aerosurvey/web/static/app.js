// aerosurvey planner page: edits the spec, asks the server to plan, draws what it returns.
// No planning happens here; every number shown comes from the server's plan.
"use strict";

const R = 6378137.0;
const SVGNS = "http://www.w3.org/2000/svg";
const SORTIE_COLOURS = ["#1565c0", "#ef6c00", "#6a1b9a", "#00897b", "#c2185b", "#5d4037", "#3949ab", "#7cb342",
  "#f9a825", "#00838f", "#8e24aa", "#d84315"];

const S = {
  spec: {},            // the spec being edited: the source of truth for the form
  specPath: null,
  view: null,          // the last plan's result
  job: null,           // the running plan job's id
  seq: 0,              // plan request counter: stale results are dropped
  timer: null,
  cam: { cx: 0, cy: 0, u: 1 },  // map centre (frame metres) and metres per screen pixel
  fittedFor: null,
  tileUrl: "",
  flown: null,
  stats: { plans: 0, lastMs: 0 },
};
window.aerosurvey = S;  // for tests and the curious

const $ = (sel) => document.querySelector(sel);
const $$ = (sel) => Array.from(document.querySelectorAll(sel));

// ---- spec access -------------------------------------------------------------------------
function getKey(spec, key) {
  const [t, k] = key.split(".");
  return spec[t] === undefined ? undefined : spec[t][k];
}
function setKey(spec, key, value) {
  const [t, k] = key.split(".");
  if (value === undefined) {
    if (spec[t]) delete spec[t][k];
    return;
  }
  if (!spec[t] || typeof spec[t] !== "object") spec[t] = {};
  spec[t][k] = value;
}

// ---- form ----------------------------------------------------------------------------------
function fillForm() {
  for (const el of $$("[data-key]")) {
    const v = getKey(S.spec, el.dataset.key);
    if (el.dataset.type === "bool") el.checked = v === true;
    else if (el.tagName === "SELECT" && el.dataset.key === "camera.model" && v && typeof v === "object") el.value = "__inline__";
    else el.value = v === undefined || v === null ? "" : String(v);
  }
  const t = S.spec.targets || {};
  const mode = t.height_m !== undefined ? "height_m" : "gsd_cm";
  for (const r of $$("input[name=target-mode]")) r.checked = r.value === mode;
  $("#target-value").value = t[mode] === undefined ? "" : t[mode];
  const h = (S.spec.flight || {}).heading;
  $("#heading-auto").checked = h === undefined || h === "auto";
  $("#heading-value").disabled = $("#heading-auto").checked;
  $("#heading-value").value = typeof h === "number" ? h : "";
  $("#battery-on").checked = S.spec.battery !== undefined;
  for (const el of $$("[data-key^='battery.']")) el.disabled = !$("#battery-on").checked;
  const profiles = ((S.spec.rules || {}).profiles) || [];
  for (const cb of $$("#profiles input")) cb.checked = profiles.includes(cb.value);
}

function parseField(el) {
  const raw = el.dataset.type === "bool" ? el.checked : el.value.trim();
  if (el.dataset.type === "bool") return { value: raw };
  if (raw === "") return { value: undefined };
  if (el.dataset.type === "number" || el.dataset.type === "int") {
    const v = Number(raw);
    if (!Number.isFinite(v)) return { error: `${el.dataset.key}: ${JSON.stringify(raw)} is not a number` };
    if (el.dataset.type === "int" && !Number.isInteger(v)) return { error: `${el.dataset.key}: ${raw} is not a whole number` };
    return { value: v };
  }
  return { value: raw };
}

function onField(el) {
  if (el.dataset.key === "camera.model" && el.value === "__inline__") return;
  const p = parseField(el);
  clearError(el.dataset.key);
  if (p.error) { el.classList.add("bad"); showError(el.dataset.key, p.error); return; }
  el.classList.remove("bad");
  setKey(S.spec, el.dataset.key, p.value);
  schedule();
}

function onTarget() {
  const mode = $$("input[name=target-mode]").find((r) => r.checked).value;
  const raw = $("#target-value").value.trim();
  clearError("targets.gsd_cm");
  if (!S.spec.targets) S.spec.targets = {};
  delete S.spec.targets.gsd_cm;
  delete S.spec.targets.height_m;
  if (raw !== "") {
    const v = Number(raw);
    if (!Number.isFinite(v)) { showError(`targets.${mode}`, `targets.${mode}: ${JSON.stringify(raw)} is not a number`); return; }
    S.spec.targets[mode] = v;
  }
  schedule();
}

function onHeading() {
  const auto = $("#heading-auto").checked;
  $("#heading-value").disabled = auto;
  clearError("flight.heading");
  if (auto) setKey(S.spec, "flight.heading", "auto");
  else {
    const raw = $("#heading-value").value.trim();
    if (raw === "") return;
    const v = Number(raw);
    if (!Number.isFinite(v)) { showError("flight.heading", `flight.heading: ${JSON.stringify(raw)} is not a number`); return; }
    setKey(S.spec, "flight.heading", v);
  }
  schedule();
}

function onBattery() {
  const on = $("#battery-on").checked;
  for (const el of $$("[data-key^='battery.']")) el.disabled = !on;
  if (on) {
    S.spec.battery = S.spec.battery || {};
    for (const el of $$("[data-key^='battery.']")) {
      const p = parseField(el);
      if (!p.error && p.value !== undefined) S.spec.battery[el.dataset.key.split(".")[1]] = p.value;
    }
    if (S.spec.battery.usable_min === undefined && S.spec.battery.capacity_wh === undefined) {
      S.spec.battery.usable_min = 25;
      $("[data-key='battery.usable_min']").value = "25";
    }
  } else {
    S.savedBattery = S.spec.battery;
    delete S.spec.battery;
  }
  schedule();
}

function onProfiles() {
  const ids = $$("#profiles input").filter((c) => c.checked).map((c) => c.value);
  if (!S.spec.rules) S.spec.rules = {};
  S.spec.rules.profiles = ids;
  schedule();
}

// ---- errors -------------------------------------------------------------------------------
function errorBox(key) {
  if (!key) return null;
  const table = key.split(".")[0];
  return $$(".err[data-for]").find((e) => e.dataset.for.split(" ").includes(key))
    || $$(".err[data-for]").find((e) => e.dataset.for.split(" ").includes(table));
}
function showError(key, message) {
  const box = errorBox(key) || $("#general-error");
  box.textContent = message;
  box.dataset.key = key || "";
  const field = key ? $(`[data-key='${key}']`) : null;
  if (field) field.classList.add("bad");
}
function clearError(key) {
  const box = errorBox(key);
  if (box) box.textContent = "";
  $("#general-error").textContent = "";
}
function clearAllErrors() {
  for (const e of $$(".err")) if (e.dataset.for !== "flight" && e.dataset.for !== "tiles") e.textContent = "";
  for (const e of $$(".bad")) e.classList.remove("bad");
}

// ---- planning -------------------------------------------------------------------------------
function schedule() {
  clearTimeout(S.timer);
  S.timer = setTimeout(replan, 250);
}

async function api(method, url, body) {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    if (body instanceof FormData) opts.body = body;
    else { opts.body = JSON.stringify(body); opts.headers["Content-Type"] = "application/json"; }
  }
  const r = await fetch(url, opts);
  const type = r.headers.get("content-type") || "";
  const data = type.includes("json") ? await r.json() : await r.blob();
  if (!r.ok) {
    const err = new Error((data && data.error) || `${method} ${url}: HTTP ${r.status}`);
    err.key = data && data.key;
    throw err;
  }
  return data;
}

async function replan() {
  const seq = ++S.seq;
  if (S.job) { api("DELETE", `/api/jobs/${S.job}`).catch(() => {}); S.job = null; }
  const started = performance.now();
  setStatus("planning…");
  let job;
  try {
    job = (await api("POST", "/api/plan", { spec: S.spec })).job;
  } catch (e) { if (seq === S.seq) { showError(e.key, e.message); setStatus("error"); } return; }
  S.job = job;
  const progressTimer = setTimeout(() => { if (seq === S.seq) $("#progress").hidden = false; }, 400);
  try {
    for (;;) {
      const st = await api("GET", `/api/jobs/${job}?wait=0.25`);
      if (seq !== S.seq) return;
      $("#progress-bar").value = st.progress;
      $("#progress-stage").textContent = st.stage;
      if (st.state === "done") {
        clearAllErrors();
        S.stats.plans += 1;
        S.stats.lastMs = Math.round(performance.now() - started);
        render(st.result);
        setStatus(`planned in ${(st.elapsed_s).toFixed(2)} s`);
        break;
      }
      if (st.state === "error") {
        clearAllErrors();
        showError(st.error.key, st.error.message);
        setStatus("the last change could not be planned; the map shows the previous plan");
        break;
      }
      if (st.state === "cancelled") { setStatus("cancelled; the map shows the previous plan"); break; }
    }
  } catch (e) {
    if (seq === S.seq) { showError(e.key, e.message); setStatus("error"); }
  } finally {
    clearTimeout(progressTimer);
    if (seq === S.seq) { $("#progress").hidden = true; S.job = null; }
  }
}

function setStatus(text) { $("#status").textContent = text; }

// ---- map ------------------------------------------------------------------------------------
function svgEl(tag, attrs, parent) {
  const el = document.createElementNS(SVGNS, tag);
  for (const [k, v] of Object.entries(attrs || {})) el.setAttribute(k, v);
  if (parent) parent.appendChild(el);
  return el;
}
function clear(g) { while (g.firstChild) g.removeChild(g.firstChild); }
function ringPath(rings) {
  return rings.map((r) => "M" + r.map(([x, y]) => `${x},${-y}`).join("L") + "Z").join("");
}

function render(view) {
  S.view = view;
  const L = view.layers;
  const area = $("#layer-area"); clear(area);
  for (const p of L.area) svgEl("path", { d: ringPath(p) }, area);
  const ex = $("#layer-exclusions"); clear(ex);
  for (const p of L.exclusions) svgEl("path", { d: ringPath(p) }, ex);
  const un = $("#layer-uncovered"); clear(un);
  for (const p of L.uncovered || []) svgEl("path", { d: ringPath(p) }, un);
  const lines = $("#layer-lines"); clear(lines);
  for (const l of L.lines) {
    svgEl("line", { "data-id": l.id, x1: l.xy[0][0], y1: -l.xy[0][1], x2: l.xy[1][0], y2: -l.xy[1][1],
      stroke: colour(l.sortie), "data-sortie": l.sortie }, lines);
  }
  const st = $("#layer-stations"); clear(st);
  const frag = document.createDocumentFragment();
  for (let i = 0; i < L.stations.ids.length; i++) {
    svgEl("circle", { "data-id": L.stations.ids[i], cx: L.stations.x[i], cy: -L.stations.y[i],
      fill: colour(L.stations.sortie[i]) }, frag);
  }
  st.appendChild(frag);
  const la = $("#layer-launch"); clear(la);
  const sites = L.launch.length ? L.launch : [{ id: "home", ...L.home }];
  sites.forEach((s, i) => {
    svgEl("circle", { "data-id": s.id, cx: s.x, cy: -s.y }, la);
    const t = svgEl("text", { x: s.x, y: -s.y }, la);
    t.textContent = sites.length > 1 ? String(i + 1) : "H";
  });
  const g = $("#layer-gcps"); clear(g);
  const c = $("#layer-checks"); clear(c);
  for (const p of L.control_points) {
    const el = svgEl("circle", { "data-id": p.id, cx: p.x, cy: -p.y }, p.role === "gcp" ? g : c);
    const tip = svgEl("title", {}, el);
    tip.textContent = `${p.id} (${p.role}): on ${p.images} planned photos${p.note ? "; " + p.note : ""}`;
  }
  clear($("#layer-highlight"));
  renderLegend(view);
  renderSummary(view);
  renderRules(view);
  renderFiles(view);
  const key = JSON.stringify(L.area);
  if (S.fittedFor !== key) { S.fittedFor = key; fit(); } else applyView();
  if (S.flown && S.flown.plan_id !== view.plan_id) { S.flown = null; clear($("#layer-flown")); clear($("#layer-coverage")); $("#flight-summary").textContent = ""; }
}

function colour(sortie) { return sortie ? SORTIE_COLOURS[(sortie - 1) % SORTIE_COLOURS.length] : "#1565c0"; }

function renderLegend(view) {
  const box = $("#sortie-legend"); box.textContent = "";
  if (!view.sorties.length) return;
  for (const [i, s] of view.sorties.entries()) {
    const span = document.createElement("span");
    span.style.background = colour(i + 1);
    span.textContent = s.id;
    span.title = `${s.photos} photos, ${(s.time_s / 60).toFixed(1)} min, ${s.usable_used_pct} % of the usable battery`;
    box.appendChild(span);
  }
}

function renderSummary(view) {
  const s = view.summary;
  const rows = [
    ["area", `${s.area_ha} ha (${s.crs})`],
    ["camera", s.camera],
    ["height AGL", s.height_range_m[0] === s.height_range_m[1] ? `${s.height_agl_m} m` : `${s.height_range_m[0]}…${s.height_range_m[1]} m`],
    ["GSD", s.gsd_cm[0] === s.gsd_cm[1] ? `${s.gsd_cm[0]} cm` : `${s.gsd_cm[0]}…${s.gsd_cm[1]} cm`],
    ["heading", `${s.heading_deg}°`],
    ["lines", `${s.lines} (${s.runs} runs), spacing ${s.spacing_m} m`],
    ["photos", `${s.photos}, base ${s.photo_base_m} m`],
    ["speed", `${s.speed_ms} m/s (${s.speed_limited_by})`],
    ["distance", `${s.distance_km} km`],
    ["time", `${s.time_min} min`],
    ["sorties", s.sorties ? String(s.sorties) : "one flight (no battery set)"],
    ["mission items", String(s.mission_items)],
    ["rules", s.rules.text],
  ];
  const dl = $("#summary"); dl.textContent = "";
  for (const [k, v] of rows) {
    const dt = document.createElement("dt"); dt.textContent = k;
    const dd = document.createElement("dd"); dd.textContent = v; dd.dataset.summary = k;
    dl.append(dt, dd);
  }
  const w = $("#warnings"); w.textContent = "";
  for (const text of view.warnings) { const li = document.createElement("li"); li.textContent = text; w.appendChild(li); }
}

function renderRules(view) {
  const ul = $("#rule-list"); ul.textContent = "";
  if (!view.rules.length) { const li = document.createElement("li"); li.textContent = "no rule profile chosen"; ul.appendChild(li); }
  for (const r of view.rules) {
    const li = document.createElement("li");
    li.className = r.status;
    li.dataset.rule = r.rule;
    const status = document.createElement("span"); status.className = "status"; status.textContent = r.status;
    const name = document.createElement("b"); name.textContent = r.rule;
    const detail = document.createElement("div"); detail.className = "detail";
    detail.textContent = `measured ${r.measured}; required ${r.required}` + (r.evidence.length ? "\n" + r.evidence.slice(0, 6).join("\n") : "");
    detail.style.whiteSpace = "pre-wrap";
    li.append(status, name, detail);
    li.title = r.statement;
    if (r.where.length) li.addEventListener("click", () => highlight(r, li));
    ul.appendChild(li);
  }
}

function highlight(rule, li) {
  for (const x of $$("#rule-list li.selected")) x.classList.remove("selected");
  li.classList.add("selected");
  const g = $("#layer-highlight"); clear(g);
  const L = S.view.layers;
  const lineById = new Map(L.lines.map((l) => [l.id, l]));
  const stIndex = new Map(L.stations.ids.map((id, i) => [id, i]));
  const cpById = new Map(L.control_points.map((p) => [p.id, p]));
  const pts = [];
  const addLine = (id) => {
    const l = lineById.get(id);
    if (!l) return;
    svgEl("line", { "data-id": id, x1: l.xy[0][0], y1: -l.xy[0][1], x2: l.xy[1][0], y2: -l.xy[1][1] }, g);
    pts.push(l.xy[0], l.xy[1]);
  };
  for (const w of rule.where) {
    if (w.run) addLine(w.run);
    if (w.runs) w.runs.forEach(addLine);
    if (w.station && stIndex.has(w.station)) {
      const i = stIndex.get(w.station);
      svgEl("circle", { cx: L.stations.x[i], cy: -L.stations.y[i] }, g);
      pts.push([L.stations.x[i], L.stations.y[i]]);
    }
    if (w.point && cpById.has(w.point)) {
      const p = cpById.get(w.point);
      svgEl("circle", { cx: p.x, cy: -p.y }, g);
      pts.push([p.x, p.y]);
    }
    if (w.xy) {
      svgEl("rect", { x: w.xy[0] - 3, y: -w.xy[1] - 3, width: 6, height: 6 }, g);
      pts.push(w.xy);
    }
  }
  if (pts.length) fitTo(pts, 0.25);
}

function renderFiles(view) {
  const ul = $("#file-list"); ul.textContent = "";
  const add = (name, href) => {
    const li = document.createElement("li");
    const a = document.createElement("a"); a.href = href; a.textContent = name; a.setAttribute("download", name);
    li.appendChild(a); ul.appendChild(li);
  };
  add("all files (.zip)", `/api/plans/${view.plan_id}/archive.zip`);
  for (const f of view.files) add(f, `/api/plans/${view.plan_id}/files/${encodeURIComponent(f)}`);
}

// ---- view transform ---------------------------------------------------------------------------
function size() { const r = $("#map").getBoundingClientRect(); return [Math.max(r.width, 1), Math.max(r.height, 1)]; }

function applyView() {
  const [w, h] = size();
  const { cx, cy, u } = S.cam;
  const svg = $("#map");
  svg.setAttribute("viewBox", `${cx - (w / 2) * u} ${-cy - (h / 2) * u} ${w * u} ${h * u}`);
  svg.style.setProperty("--u", String(u));
  updateScale();
  drawTiles();
}

function fitTo(points, pad) {
  if (!points.length) return;
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const [x, y] of points) { x0 = Math.min(x0, x); y0 = Math.min(y0, y); x1 = Math.max(x1, x); y1 = Math.max(y1, y); }
  const [w, h] = size();
  const dx = Math.max(x1 - x0, 50), dy = Math.max(y1 - y0, 50);
  S.cam = { cx: (x0 + x1) / 2, cy: (y0 + y1) / 2, u: Math.max(dx / w, dy / h) * (1 + 2 * pad) };
  applyView();
}

function fit() {
  if (!S.view) return;
  const pts = [];
  for (const p of S.view.layers.area) for (const ring of p) for (const xy of ring) pts.push(xy);
  for (const p of S.view.layers.control_points) pts.push([p.x, p.y]);
  for (const l of S.view.layers.lines) pts.push(l.xy[0], l.xy[1]);
  fitTo(pts, 0.04);
}

function zoomAt(factor, sx, sy) {
  const [w, h] = size();
  const { cx, cy, u } = S.cam;
  const mx = cx + (sx - w / 2) * u, my = cy - (sy - h / 2) * u;
  const nu = Math.min(Math.max(u * factor, 0.01), 20000);
  S.cam = { cx: mx - (sx - w / 2) * nu, cy: my + (sy - h / 2) * nu, u: nu };
  applyView();
}

function updateScale() {
  if (!S.view) return;
  $("#scale-bar").hidden = false;
  const lat = latOf(S.cam.cy);
  const groundPerPx = S.cam.u * Math.cos(lat * Math.PI / 180);
  const target = groundPerPx * 120;
  const p = Math.pow(10, Math.floor(Math.log10(target)));
  const nice = [5, 2, 1].map((m) => m * p).find((v) => v <= target) || p;
  $("#scale-line").style.width = `${nice / groundPerPx}px`;
  $("#scale-label").textContent = nice >= 1000 ? `${nice / 1000} km` : `${nice} m`;
}

function latOf(fy) {
  const y = fy + S.view.frame.origin[1];
  return (2 * Math.atan(Math.exp(y / R)) - Math.PI / 2) * 180 / Math.PI;
}
function lonOf(fx) { return (fx + S.view.frame.origin[0]) / R * 180 / Math.PI; }

function planXY(fx, fy) {
  const f = S.view.frame;
  const u = fx / f.half, v = fy / f.half;
  const t = [1, u, v, u * u, u * v, v * v, u * u * u, u * u * v, u * v * v, v * v * v];
  let x = 0, y = 0;
  for (let i = 0; i < t.length; i++) { x += f.cx[i] * t[i]; y += f.cy[i] * t[i]; }
  return [x, y];
}

function onMove(ev) {
  if (!S.view) return;
  const r = $("#map").getBoundingClientRect();
  const [w, h] = size();
  const fx = S.cam.cx + (ev.clientX - r.left - w / 2) * S.cam.u;
  const fy = S.cam.cy - (ev.clientY - r.top - h / 2) * S.cam.u;
  const lat = latOf(fy), lon = lonOf(fx);
  const [px, py] = planXY(fx, fy);
  $("#cursor").textContent = `WGS84 ${Math.abs(lat).toFixed(6)}° ${lat >= 0 ? "N" : "S"} ${Math.abs(lon).toFixed(6)}° ${lon >= 0 ? "E" : "W"}`
    + `   ·   ${S.view.frame.crs} x ${px.toFixed(2)} y ${py.toFixed(2)}`;
}

// ---- basemap tiles (only when a URL is set) ----------------------------------------------------
function drawTiles() {
  const g = $("#layer-tiles");
  if (!S.tileUrl || !S.view) { clear(g); return; }
  const [w, h] = size();
  const { cx, cy, u } = S.cam;
  const [ox, oy] = S.view.frame.origin;
  const world = 2 * Math.PI * R;
  const z = Math.max(0, Math.min(19, Math.round(Math.log2(world / (256 * u)))));
  const n = 2 ** z, ts = world / n;
  const X0 = cx + ox - (w / 2) * u, X1 = cx + ox + (w / 2) * u;
  const Y0 = cy + oy - (h / 2) * u, Y1 = cy + oy + (h / 2) * u;
  const tx0 = Math.max(0, Math.floor((X0 + world / 2) / ts)), tx1 = Math.min(n - 1, Math.floor((X1 + world / 2) / ts));
  const ty0 = Math.max(0, Math.floor((world / 2 - Y1) / ts)), ty1 = Math.min(n - 1, Math.floor((world / 2 - Y0) / ts));
  clear(g);
  if ((tx1 - tx0 + 1) * (ty1 - ty0 + 1) > 100) return;
  for (let tx = tx0; tx <= tx1; tx++) {
    for (let ty = ty0; ty <= ty1; ty++) {
      const url = S.tileUrl.replace("{z}", z).replace("{x}", tx).replace("{y}", ty);
      const left = tx * ts - world / 2 - ox, top = world / 2 - ty * ts - oy;
      svgEl("image", { href: url, x: left, y: -top, width: ts + u * 0.5, height: ts + u * 0.5, preserveAspectRatio: "none" }, g);
    }
  }
}

// ---- uploads -----------------------------------------------------------------------------------
async function uploadArea(file) {
  clearError("area.file");
  const fd = new FormData();
  fd.append("file", file, file.name);
  const { area, ...settings } = S.spec || {};  // the new area replaces the old one: no need to send it
  fd.append("spec", JSON.stringify(settings));
  setStatus(`reading ${file.name}…`);
  try {
    const r = await api("POST", "/api/area", fd);
    S.spec = r.spec;
    fillForm();
    setStatus(`area ${r.file_name} loaded`);
    replan();
  } catch (e) { showError(e.key || "area.file", e.message); setStatus("the area file could not be used"); }
}

async function loadFlight(files) {
  const box = $(".err[data-for='flight']"); box.textContent = "";
  if (!S.view) { box.textContent = "plan first: the flight is drawn against the plan"; return; }
  const fd = new FormData();
  for (const f of files) if (["events.csv", "coverage.tif", "log_report.json"].includes(f.name)) fd.append("files", f, f.name);
  try {
    const r = await api("POST", `/api/plans/${S.view.plan_id}/flight`, fd);
    S.flown = { ...r, plan_id: S.view.plan_id };
    drawFlown();
  } catch (e) { box.textContent = e.message; }
}

function drawFlown() {
  const g = $("#layer-flown"); clear(g);
  const c = $("#layer-coverage"); clear(c);
  const f = S.flown;
  if (!f) return;
  for (let i = 0; i < f.events.x.length; i++) {
    const el = svgEl("circle", { cx: f.events.x[i], cy: -f.events.y[i], "data-event": f.events.event[i] }, g);
    svgEl("title", {}, el).textContent = `event ${f.events.event[i]}${f.events.station[i] ? " → " + f.events.station[i] : " (no station)"}`;
  }
  if (f.coverage) {
    const [x0, y0, x1, y1] = f.coverage.bounds;
    svgEl("image", { href: f.coverage.png, x: x0, y: -y1, width: x1 - x0, height: y1 - y0, preserveAspectRatio: "none" }, c);
  }
  const rep = f.report || {};
  const parts = [`${f.events.x.length} camera events`];
  if (rep.planned !== undefined) parts.push(`${rep.matched} of ${rep.planned} stations matched, ${(rep.missed_stations || []).length} missed`);
  if (rep.coverage) parts.push(`at least ${rep.coverage.min_images_in_area} photos per cell, ${(100 * rep.coverage.uncovered_share).toFixed(2)} % uncovered`);
  $("#flight-summary").textContent = parts.join("; ");
}

// ---- spec files ------------------------------------------------------------------------------
async function downloadToml() {
  try {
    const blob = await api("POST", "/api/spec/toml", { spec: S.spec });
    const a = document.createElement("a");
    a.href = URL.createObjectURL(blob);
    a.download = `${(S.spec.mission || {}).name || "mission"}.toml`;
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  } catch (e) { showError(e.key, e.message); }
}

async function saveSpec() {
  try {
    const r = await api("POST", "/api/spec/save", { spec: S.spec });
    $("#save-status").textContent = `saved to ${r.saved}`;
  } catch (e) { showError(e.key, e.message); $("#save-status").textContent = ""; }
}

// ---- start -----------------------------------------------------------------------------------
async function start() {
  const st = await api("GET", "/api/state");
  S.spec = st.spec || {};
  S.specPath = st.spec_path;
  const saved = localStorage.getItem("aerosurvey.tileUrl");
  S.tileUrl = st.tile_url || saved || "";
  $("#tile-url").value = S.tileUrl;
  const sel = $("#camera-select");
  for (const c of st.cameras) {
    const o = document.createElement("option");
    o.value = c.id; o.textContent = `${c.id} (${c.focal_mm} mm, ${c.pixel_pitch_um} µm)`; o.title = c.name;
    sel.appendChild(o);
  }
  const inline = document.createElement("option"); inline.value = "__inline__"; inline.textContent = "inline camera from the spec"; inline.disabled = true;
  sel.appendChild(inline);
  const pbox = $("#profiles");
  for (const p of st.profiles) {
    const l = document.createElement("label"); l.style.justifyContent = "flex-start";
    const cb = document.createElement("input"); cb.type = "checkbox"; cb.value = p.id;
    l.append(cb, ` ${p.id}`); l.title = `${p.name} (${p.rules} rules)`;
    pbox.appendChild(l);
  }
  if (S.specPath) { $("#save-spec").hidden = false; $("#save-spec").textContent = `Save to ${S.specPath.split("/").pop()}`; $("#save-spec").title = S.specPath; }
  fillForm();

  for (const el of $$("[data-key]")) el.addEventListener(el.tagName === "SELECT" || el.dataset.type === "bool" ? "change" : "input", () => onField(el));
  for (const r of $$("input[name=target-mode]")) r.addEventListener("change", onTarget);
  $("#target-value").addEventListener("input", onTarget);
  $("#heading-auto").addEventListener("change", onHeading);
  $("#heading-value").addEventListener("input", onHeading);
  $("#battery-on").addEventListener("change", onBattery);
  $("#profiles").addEventListener("change", onProfiles);
  $("#cancel").addEventListener("click", () => { if (S.job) api("DELETE", `/api/jobs/${S.job}`).catch(() => {}); });
  $("#download-toml").addEventListener("click", downloadToml);
  $("#save-spec").addEventListener("click", saveSpec);
  $("#area-file").addEventListener("change", (e) => { if (e.target.files[0]) uploadArea(e.target.files[0]); e.target.value = ""; });
  $("#flight-files").addEventListener("change", (e) => { loadFlight(Array.from(e.target.files)); e.target.value = ""; });
  const drop = $("#drop");
  for (const t of ["dragenter", "dragover"]) drop.addEventListener(t, (e) => { e.preventDefault(); drop.classList.add("over"); });
  for (const t of ["dragleave", "drop"]) drop.addEventListener(t, (e) => { e.preventDefault(); drop.classList.remove("over"); });
  drop.addEventListener("drop", (e) => { const f = e.dataTransfer.files[0]; if (f) uploadArea(f); });
  $("#tile-url").addEventListener("change", () => {
    const v = $("#tile-url").value.trim();
    const box = $(".err[data-for='tiles']"); box.textContent = "";
    if (v && !["{z}", "{x}", "{y}"].every((k) => v.includes(k))) { box.textContent = `${v} is not an XYZ template: it needs {z}, {x} and {y}`; return; }
    S.tileUrl = v; localStorage.setItem("aerosurvey.tileUrl", v); drawTiles();
  });
  for (const cb of $$("#layer-toggles input[data-layer]")) {
    cb.addEventListener("change", () => { $(`#layer-${cb.dataset.layer}`).style.display = cb.checked ? "" : "none"; });
  }

  const svg = $("#map");
  let drag = null;
  svg.addEventListener("pointerdown", (e) => { drag = { x: e.clientX, y: e.clientY, cx: S.cam.cx, cy: S.cam.cy }; svg.setPointerCapture(e.pointerId); svg.classList.add("dragging"); });
  svg.addEventListener("pointermove", (e) => {
    onMove(e);
    if (!drag) return;
    S.cam.cx = drag.cx - (e.clientX - drag.x) * S.cam.u;
    S.cam.cy = drag.cy + (e.clientY - drag.y) * S.cam.u;
    applyView();
  });
  svg.addEventListener("pointerup", () => { drag = null; svg.classList.remove("dragging"); });
  svg.addEventListener("wheel", (e) => {
    e.preventDefault();
    const r = svg.getBoundingClientRect();
    zoomAt(Math.exp(e.deltaY * 0.0015), e.clientX - r.left, e.clientY - r.top);
  }, { passive: false });
  $("#zoom-in").addEventListener("click", () => { const [w, h] = size(); zoomAt(1 / 1.5, w / 2, h / 2); });
  $("#zoom-out").addEventListener("click", () => { const [w, h] = size(); zoomAt(1.5, w / 2, h / 2); });
  $("#zoom-fit").addEventListener("click", fit);
  window.addEventListener("resize", applyView);

  if (S.spec.area) replan();
  else setStatus("drop an area file to start");
}

start().catch((e) => { setStatus("could not start"); showError(null, e.message); });
