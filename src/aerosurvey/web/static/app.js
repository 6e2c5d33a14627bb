// aerosurvey planner page: edits the spec and the area on an OpenLayers map, asks the server to
// plan, draws what it returns. No planning happens here; every number shown comes from the server.
// The map library is the bundle in /static/vendor/olb.js (OpenLayers and proj4, see web-src/).
"use strict";

const SORTIE_COLOURS = ["#1565c0", "#ef6c00", "#6a1b9a", "#00897b", "#c2185b", "#5d4037", "#3949ab", "#7cb342",
  "#f9a825", "#00838f", "#8e24aa", "#d84315"];
const WEB = "EPSG:3857", WGS84 = "EPSG:4326";
// what the page writes in WGS84 is rounded to 1e-8° (about a millimetre): the map's Web Mercator round trip adds noise
// in the last digits (14.9517319 comes back as 14.951731900000002), which rounding removes
const DEGREE_DECIMALS = 8;
const TO_WGS84 = { dataProjection: WGS84, featureProjection: WEB, decimals: DEGREE_DECIMALS };
function lonLatOf(coord) { return olb.toLonLat(coord).map((v) => Math.round(v * 10 ** DEGREE_DECIMALS) / 10 ** DEGREE_DECIMALS); }
const DEFAULT_CORRIDOR_WIDTH_M = 50;  // a first centreline's corridor, until the pilot sets its width

const S = {
  spec: {},            // the spec being edited: the source of truth for the form
  specPath: null,
  zones: null,         // drawn exclusion zones as WKT (WGS84); null: the spec's zone files
  view: null,          // the last plan's result
  planned: null,       // what that plan was made of: {spec, zones, drawn}; a cancelled plan goes back to it
  job: null,           // the running plan job's id
  seq: 0,              // plan request counter: stale results are dropped
  timer: null,
  tileUrl: "",
  basemap: null,       // the server's own basemap (--basemap FILE), or null
  lan: false,          // files can be shared on the local network (serve --lan): a QR button per sortie file
  flown: null,
  tool: "edit",
  history: [], pos: -1, // undo stack of the drawn geometry
  touched: new Set(),  // roles the user has edited (area, zone, launch): only those are written into the spec
  stats: { plans: 0, lastMs: 0, firstMapMs: null },
};
window.aerosurvey = S;  // for tests and the curious

const $ = (sel) => document.querySelector(sel);
const $$ = (sel) => Array.from(document.querySelectorAll(sel));
const wkt = new olb.WKT();

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
/** A spec value as its field shows it: a wind table ({speed_ms, from_deg, gust_ms}) as the text --wind takes (6@240G9),
 * which the spec reads the same. */
function fieldText(v) {
  if (v && typeof v === "object" && "speed_ms" in v && "from_deg" in v) return `${v.speed_ms}@${v.from_deg}${v.gust_ms ? `G${v.gust_ms}` : ""}`;
  return String(v);
}
function fillForm() {
  for (const el of $$("[data-key]")) {
    const v = getKey(S.spec, el.dataset.key);
    if (el.dataset.type === "bool") el.checked = v === true;
    else if (el.tagName === "SELECT" && el.dataset.key === "camera.model" && v && typeof v === "object") el.value = "__inline__";
    else el.value = v === undefined || v === null ? "" : fieldText(v);
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
  showChosenFields();
}

// ---- the pattern: area grid, corridor along a drawn centreline, oblique ------------------------------
function patternKind() { return (S.spec.pattern && S.spec.pattern.kind) || "area"; }
/** The patterns the server's registry has: kind → {title, area_is_centreline, fields} (GET /api/state). */
S.patterns = {};
/** Whether the chosen pattern flies along a centreline drawn as the area (a corridor). */
function centrelineKind() { return !!(S.patterns[patternKind()] || {}).area_is_centreline; }
/** The pattern box from the registry: a choice of kind, and each kind's fields (shown for that kind only). */
function buildPatternBox(patterns) {
  const select = $("#pattern-kind"), box = $("#pattern-fields");
  for (const p of patterns) {
    S.patterns[p.kind] = p;
    const o = document.createElement("option"); o.value = p.kind; o.textContent = p.title; select.appendChild(o);
    for (const f of p.fields) {
      const label = document.createElement("label"); label.dataset.pattern = p.kind;
      let input;
      if (f.type === "choice") {
        input = document.createElement("select");
        const none = document.createElement("option"); none.value = ""; none.textContent = `default (${f.default})`; input.appendChild(none);
        for (const [value, text] of f.choices) { const c = document.createElement("option"); c.value = value; c.textContent = text; input.appendChild(c); }
        input.dataset.type = "text";
      } else {
        input = document.createElement("input"); input.type = "number"; input.step = "any"; input.dataset.type = "number";
        if (f.min !== null) input.min = String(f.min);
        if (f.max !== null) input.max = String(f.max);
        input.placeholder = f.default === null ? "none" : String(f.default);
      }
      input.dataset.key = `pattern.${f.key}`;
      if (f.hint) input.title = f.hint;
      label.append(`${f.label} `, input);
      box.appendChild(label);
    }
    const err = document.createElement("div"); err.className = "err"; err.dataset.pattern = p.kind;
    err.dataset.for = p.fields.map((f) => `pattern.${f.key}`).join(" ");
    box.appendChild(err);
  }
}
/** Only the fields of the chosen pattern and trigger are shown. */
function showChosenFields() {
  const kind = patternKind(), trigger = (S.spec.camera && S.spec.camera.trigger) || "distance";
  for (const el of $$("[data-pattern]")) el.hidden = el.dataset.pattern !== kind;
  for (const el of $$("[data-centreline]")) el.hidden = !centrelineKind();
  for (const el of $$("[data-trigger]")) el.hidden = el.dataset.trigger !== trigger;
}
/** The pattern's kind changed: keys of other kinds go, a corridor is not cross-hatched, and the spec's area
 * follows the kind when the other geometry is drawn (a corridor's area is its centreline, other kinds' polygons). */
function onKind() {
  const kind = patternKind();
  L.area.changed();  // area polygons are drawn faint under a corridor
  const keys = ((S.patterns[kind] || {}).fields || []).map((f) => f.key);
  for (const k of Object.keys(S.spec.pattern || {})) if (k !== "kind" && !keys.includes(k)) delete S.spec.pattern[k];
  if (centrelineKind() && S.spec.flight) delete S.spec.flight.cross_hatch;
  const role = centrelineKind() ? "centreline" : "area";
  const holds = /^\s*(MULTI)?LINESTRING/i.test((S.spec.area && S.spec.area.wkt) || "") ? "centreline" : "area";
  if (holds !== role && editFeatures(role).length) { S.touched.add(role); writeArea(); }
  fillForm();
}
/** A pattern field changed: keys of another kind go, a width replaces left and right (and back). */
function onPatternField(key) {
  const p = S.spec.pattern;
  if (!p) return;
  if (key === "pattern.kind") onKind();
  else {  // the other way of giving the width is emptied (the field being typed in is left alone)
    const others = key === "pattern.width_m" ? ["left_m", "right_m"] : ["width_m"];
    if (p[key.split(".")[1]] !== undefined) {
      for (const k of others) { delete p[k]; $(`[data-key='pattern.${k}']`).value = ""; }
    }
  }
  if (!Object.keys(p).length) delete S.spec.pattern;
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
  if (el.dataset.key.startsWith("pattern.")) onPatternField(el.dataset.key);
  if (el.dataset.key === "camera.trigger") showChosenFields();
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
    S.spec.battery = S.spec.battery || S.savedBattery || {};
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
  if (S.touched.has("launch")) writeLaunch();
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
  const field = key ? $(`[data-key='${key}']`) : null;
  if (field) field.classList.add("bad");
  // a field's error inside a hidden tab: the general line says where to look
  if (box.closest(".tab") && box.closest(".tab").hidden) $("#general-error").textContent = message;
}
function clearError(key) {
  const box = errorBox(key);
  if (box) box.textContent = "";
  $("#general-error").textContent = "";
}
function clearAllErrors() {
  for (const e of $$(".err")) if (!["flight", "tiles", "refly resume"].includes(e.dataset.for)) e.textContent = "";
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

function planBody() {
  const body = { spec: S.spec };
  if (S.zones !== null) body.zones = S.zones;
  return body;
}

async function replan() {
  const seq = ++S.seq;
  if (S.job) { api("DELETE", `/api/jobs/${S.job}`).catch(() => {}); S.job = null; }
  if (!S.spec.area) { setStatus("draw an area or drop an area file to start"); return; }
  const started = performance.now();
  setStatus("planning…");
  const submitted = { spec: structuredClone(S.spec), zones: S.zones === null ? null : [...S.zones], drawn: snapshot() };
  let job;
  try {
    job = (await api("POST", "/api/plan", planBody())).job;
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
        S.planned = submitted;
        const dropped = render(st.result);
        setStatus(`planned in ${(st.elapsed_s).toFixed(2)} s` + (dropped ? "; the flight loaded on the last plan was cleared" : ""));
        break;
      }
      if (st.state === "error") {
        clearAllErrors();
        showError(st.error.key, st.error.message);
        setStatus("the last change could not be planned; the map shows the previous plan");
        break;
      }
      if (st.state === "cancelled") {
        backToPlanned();
        setStatus(S.view ? "cancelled; the form and the map are back to the plan shown" : "cancelled; nothing planned yet");
        break;
      }
    }
  } catch (e) {
    if (seq === S.seq) { showError(e.key, e.message); setStatus("error"); }
  } finally {
    clearTimeout(progressTimer);
    if (seq === S.seq) { $("#progress").hidden = true; S.job = null; }
  }
}

function setStatus(text) { $("#status").textContent = text; }

/** A plan cancelled: the spec, the zones and the drawn geometry go back to what the plan on the map was made of (the
 * spec the page started with before any plan), so that the form shows, and Save writes, only what was planned.
 * Undo (Ctrl+Z) brings a cancelled drawing back. */
function backToPlanned() {
  const p = S.planned;
  S.spec = structuredClone(p.spec);
  S.zones = p.zones === null ? null : [...p.zones];
  fillForm();
  L.area.changed();  // a corridor's area polygons are drawn faint
  S.touched = new Set(p.drawn.touched);  // the roles written into that spec
  if (JSON.stringify(p.drawn.features) !== JSON.stringify(snapshot().features)) {
    restore(p.drawn);
    S.history = S.history.slice(0, S.pos + 1); S.history.push(snapshot()); S.pos = S.history.length - 1;
    updateUndo();
  }
}

// ---- map: layers and styles --------------------------------------------------------------------
function colour(sortie) { return sortie ? SORTIE_COLOURS[(sortie - 1) % SORTIE_COLOURS.length] : SORTIE_COLOURS[0]; }
const st = {
  area: new olb.Style({ stroke: new olb.Stroke({ color: "#2e7d32", width: 2 }), fill: new olb.Fill({ color: "rgba(46,125,50,0.10)" }) }),
  zone: new olb.Style({ stroke: new olb.Stroke({ color: "#c62828", width: 1.5, lineDash: [5, 3] }), fill: new olb.Fill({ color: "rgba(198,40,40,0.22)" }) }),
  uncovered: new olb.Style({ stroke: new olb.Stroke({ color: "#e65100", width: 1.5 }), fill: new olb.Fill({ color: "rgba(255,128,0,0.55)" }) }),
  failing: new olb.Style({ stroke: new olb.Stroke({ color: "#b71c1c", width: 2 }), fill: new olb.Fill({ color: "rgba(255,23,68,0.40)" }),
    image: new olb.CircleStyle({ radius: 7, fill: new olb.Fill({ color: "rgba(255,23,68,0.8)" }), stroke: new olb.Stroke({ color: "#fff", width: 1.5 }) }) }),
  gcp: new olb.Style({ image: new olb.CircleStyle({ radius: 6, fill: new olb.Fill({ color: "#fff" }), stroke: new olb.Stroke({ color: "#d81b60", width: 3 }) }) }),
  check: new olb.Style({ image: new olb.CircleStyle({ radius: 4.5, fill: new olb.Fill({ color: "#1565c0" }), stroke: new olb.Stroke({ color: "#fff", width: 1.5 }) }) }),
  label: new olb.Style({ text: new olb.Text({ font: "11px system-ui, sans-serif", offsetY: -12, fill: new olb.Fill({ color: "#1d2630" }),
    stroke: new olb.Stroke({ color: "#fff", width: 3 }) }) }),
  flown: new olb.Style({ image: new olb.CircleStyle({ radius: 2.4, fill: new olb.Fill({ color: "#111" }), stroke: new olb.Stroke({ color: "#fff", width: 0.8 }) }) }),
  highlight: new olb.Style({ stroke: new olb.Stroke({ color: "rgba(255,23,68,0.8)", width: 6 }), fill: new olb.Fill({ color: "rgba(255,23,68,0.45)" }),
    image: new olb.CircleStyle({ radius: 10, stroke: new olb.Stroke({ color: "#ff1744", width: 3 }) }) }),
  refly: new olb.Style({ stroke: new olb.Stroke({ color: "#00c853", width: 3, lineDash: [8, 5] }) }),
  corridor: new olb.Style({ stroke: new olb.Stroke({ color: "#6a1b9a", width: 1.5, lineDash: [8, 4] }), fill: new olb.Fill({ color: "rgba(106,27,154,0.08)" }) }),
  measure: new olb.Style({ stroke: new olb.Stroke({ color: "#0d47a1", width: 2, lineDash: [6, 4] }), fill: new olb.Fill({ color: "rgba(13,71,161,0.12)" }),
    image: new olb.CircleStyle({ radius: 4, fill: new olb.Fill({ color: "#0d47a1" }) }) }),
};
const lineStyles = new Map(), stationStyles = new Map();
function lineStyle(f) {
  const s = f.get("sortie");
  if (!lineStyles.has(s)) lineStyles.set(s, new olb.Style({ stroke: new olb.Stroke({ color: colour(s), width: 1.8 }) }));
  return lineStyles.get(s);
}
function stationStyle(f) {
  const s = f.get("sortie");
  if (!stationStyles.has(s)) stationStyles.set(s, new olb.Style({ image: new olb.CircleStyle({ radius: 2.2, fill: new olb.Fill({ color: colour(s) }) }) }));
  return stationStyles.get(s);
}
function siteStyle(f) {
  return new olb.Style({
    image: new olb.CircleStyle({ radius: 8, fill: new olb.Fill({ color: "#1d2630" }), stroke: new olb.Stroke({ color: "#fff", width: 1.5 }) }),
    text: new olb.Text({ text: f.get("label"), fill: new olb.Fill({ color: "#fff" }), font: "bold 10px system-ui, sans-serif" }),
  });
}
const launchStyle = new olb.Style({
  image: new olb.RegularShape({ points: 3, radius: 9, fill: new olb.Fill({ color: "#ffb300" }), stroke: new olb.Stroke({ color: "#1d2630", width: 1.5 }) }),
});
const centrelineStyle = [new olb.Style({ stroke: new olb.Stroke({ color: "#fff", width: 6 }) }),
  new olb.Style({ stroke: new olb.Stroke({ color: "#6a1b9a", width: 3 }) })];
const rallyStyle = new olb.Style({
  image: new olb.RegularShape({ points: 4, radius: 8, angle: Math.PI / 4, fill: new olb.Fill({ color: "#00acc1" }), stroke: new olb.Stroke({ color: "#1d2630", width: 1.5 }) }),
  text: new olb.Text({ text: "R", fill: new olb.Fill({ color: "#fff" }), font: "bold 9px system-ui, sans-serif" }),
});
/** A pass's start: a triangle at its first run's first station, pointing the way it is flown. */
function startStyle(f) {
  return new olb.Style({
    image: new olb.RegularShape({ points: 3, radius: 9, rotation: f.get("rotation"), fill: new olb.Fill({ color: "#2e7d32" }),
      stroke: new olb.Stroke({ color: "#fff", width: 1.5 }) }),
  });
}
const fenceStyle = new olb.Style({ stroke: new olb.Stroke({ color: "#c62828", width: 1.5, lineDash: [8, 4] }) });
const EDIT_STYLES = { zone: st.zone, launch: launchStyle, rally: rallyStyle, centreline: centrelineStyle };
const unusedAreaStyle = new olb.Style({ stroke: new olb.Stroke({ color: "rgba(46,125,50,0.45)", width: 1.5, lineDash: [4, 4] }) });
/** The drawn geometry by role; area polygons a corridor does not use are drawn faint. */
function editStyle(f) {
  if (f.get("role") === "area" && centrelineKind()) return unusedAreaStyle;
  return EDIT_STYLES[f.get("role")] || st.area;
}

/** A point style with the feature's id written above it once the map is zoomed in (under 0.8 m a pixel). */
function labelled(style) {
  return (f, resolution) => {
    if (resolution > 0.8) return style;
    st.label.getText().setText(f.get("id"));
    return [style, st.label];
  };
}

function vector(name, style, z) {
  const layer = new olb.VectorLayer({ source: new olb.VectorSource(), style, zIndex: z });
  layer.set("name", name);
  return layer;
}
// a vector basemap (--basemap FILE of Mapbox Vector Tiles): a default style by the layer's and feature's names, read
// the same way for the common schemas (OpenMapTiles, Shortbread, Protomaps, GDAL's own layers with a class field):
// water, green, land use, buildings (zoomed in), roads by rank with casings, paths, railways, boundaries; names along
// roads and rivers, on water and parks, and at places
const VT_KINDS = [["water", /water|ocean|river|lake|pond|sea|reservoir|canal|stream|ditch/],
  ["building", /building/], ["rail", /rail|train|tram|subway|funicular/],
  ["major", /motorway|trunk|primary|highway|major/], ["medium", /secondary|tertiary|medium/],
  ["path", /path|track|footway|cycleway|steps|bridleway|pedestrian/],
  ["road", /road|street|minor|service|residential_road|unclassified|living|transport/],
  ["green", /park|wood|forest|grass|landcover|green|farm|meadow|orchard|vineyard|scrub|wetland|cemetery/],
  ["boundary", /boundary|admin/], ["landuse", /landuse|residential|industrial|commercial|retail/]];
const vtStroke = (color, width, lineDash) => new olb.Stroke({ color, width, lineDash });
const vtText = (font, color, placement) => new olb.Text({ font, placement, fill: new olb.Fill({ color }), overflow: false,
  stroke: new olb.Stroke({ color: "rgba(255,255,255,0.9)", width: 3 }) });
/** Road styles by rank: a casing under the fill, both widening as the map zooms in (`w`: pixels a line). */
const VT_ROADS = { major: ["#e39b54", "#fcd6a4", 1.6], medium: ["#c5c28a", "#f7fabf", 1.25], road: ["#b8b8b8", "#ffffff", 1] };
const VT = {
  water: new olb.Style({ fill: new olb.Fill({ color: "#aad3df" }), stroke: vtStroke("#7fb5c9", 1.5), zIndex: 1 }),
  green: new olb.Style({ fill: new olb.Fill({ color: "#d6eccb" }), zIndex: 0 }),
  landuse: new olb.Style({ fill: new olb.Fill({ color: "rgba(224,218,208,0.5)" }), zIndex: 0 }),
  building: new olb.Style({ fill: new olb.Fill({ color: "#e3d9cc" }), stroke: vtStroke("#c9bba9", 1), zIndex: 2 }),
  path: new olb.Style({ stroke: vtStroke("#a0522d", 1, [4, 3]), zIndex: 3 }),
  rail: new olb.Style({ stroke: vtStroke("#707070", 1.5, [8, 4]), zIndex: 6 }),
  boundary: new olb.Style({ stroke: vtStroke("#9c6fb6", 1, [6, 4]), zIndex: 7 }),
  other: new olb.Style({ fill: new olb.Fill({ color: "rgba(120,120,120,0.06)" }), stroke: vtStroke("#c8c8c8", 1), zIndex: 0 }),
  place: new olb.Style({ text: vtText("bold 12px system-ui, sans-serif", "#222", "point"), zIndex: 10 }),
  poi: new olb.Style({ text: vtText("11px system-ui, sans-serif", "#444", "point"), zIndex: 9 }),
  roadName: new olb.Style({ text: vtText("11px system-ui, sans-serif", "#333", "line"), zIndex: 9 }),
  waterName: new olb.Style({ text: vtText("italic 11px system-ui, sans-serif", "#2a6f97", "point"), zIndex: 9 }),
  riverName: new olb.Style({ text: vtText("italic 11px system-ui, sans-serif", "#2a6f97", "line"), zIndex: 9 }),
  greenName: new olb.Style({ text: vtText("italic 11px system-ui, sans-serif", "#3b7a2a", "point"), zIndex: 9 }),
};
const vtRoadStyles = new Map();
function vtRoad(kind, resolution) {
  const [casing, fill, rank] = VT_ROADS[kind];
  const w = Math.round(2 * rank * Math.min(4, Math.max(1, 8 / Math.sqrt(resolution)))) / 2;  // 1 px at zoom 12, 4 at 17
  const key = `${kind}${w}`;
  if (!vtRoadStyles.has(key)) {
    vtRoadStyles.set(key, [new olb.Style({ stroke: vtStroke(casing, w + 2), zIndex: 4 }), new olb.Style({ stroke: vtStroke(fill, w), zIndex: 5 })]);
  }
  return vtRoadStyles.get(key);
}
/** The name a feature carries in the common schemas, or "". */
function vtName(f) { return String(f.get("name") || f.get("name:latin") || f.get("name_en") || f.get("name_int") || ""); }
function vectorBasemapStyle(f, resolution) {
  const type = f.getType();
  const words = `${f.get("layer") || ""} ${f.get("class") || ""} ${f.get("subclass") || ""} ${f.get("kind") || ""} ${f.get("type") || ""}`.toLowerCase();
  const found = VT_KINDS.find(([, re]) => re.test(words));
  const kind = found ? found[0] : "other";
  const name = vtName(f);
  const label = (style) => { style.getText().setText(name); return style; };
  if (type === "Point" || type === "MultiPoint") {
    if (!name) return null;
    return label(/place|city|town|village|hamlet|suburb|locality/.test(words) ? VT.place : kind === "water" ? VT.waterName : VT.poi);
  }
  const line = type === "LineString" || type === "MultiLineString";
  if (kind === "building" && resolution > 4) return null;  // buildings from zoom 15: below it they are only noise
  let styles;
  if (line && VT_ROADS[kind]) styles = vtRoad(kind, resolution);
  else styles = [VT[kind] || VT.other];
  if (!name) return styles;
  if (line && (VT_ROADS[kind] || kind === "path")) return [...styles, label(VT.roadName)];
  if (kind === "water") return [...styles, label(line ? VT.riverName : VT.waterName)];
  if (kind === "green" && !line) return [...styles, label(VT.greenName)];
  return styles;
}

const L = {
  basemap: new olb.TileLayer({ zIndex: 0 }),
  vbasemap: new olb.VectorTileLayer({ zIndex: 0, style: vectorBasemapStyle, declutter: true }),
  coverage: new olb.ImageLayer({ zIndex: 1 }),
  corridor: vector("corridor", st.corridor, 2),
  uncovered: vector("uncovered", st.uncovered, 3),
  lines: vector("lines", lineStyle, 4),
  stations: vector("stations", stationStyle, 5),
  area: vector("area", editStyle, 6),
  gaps: vector("gaps", st.uncovered, 7),
  flown: vector("flown", st.flown, 7),
  failing: vector("failing", st.failing, 8),
  refly: vector("refly", st.refly, 8),
  fence: vector("fence", fenceStyle, 4),
  starts: vector("starts", startStyle, 9),
  sites: vector("sites", siteStyle, 9),
  gcps: vector("gcps", labelled(st.gcp), 10),
  checks: vector("checks", labelled(st.check), 11),
  highlight: vector("highlight", st.highlight, 12),
  measure: vector("measure", st.measure, 13),
};
const edit = L.area.getSource();  // the drawn geometry: features with role area, zone, launch or rally
const map = new olb.Map({
  target: "map",
  layers: Object.values(L),
  view: new olb.View({ center: [0, 0], zoom: 2, maxZoom: 22 }),
  controls: [new olb.Zoom(), new olb.ScaleLine({ units: "metric" }), new olb.Attribution({ collapsible: true })],
});
S.map = map;
S.layers = L;

// ---- the plan on the map ------------------------------------------------------------------------
function frameXY(xy) { const [ox, oy] = S.view.frame.origin; return [xy[0] + ox, xy[1] + oy]; }
function polygonOf(rings) { return new olb.Polygon(rings.map((r) => r.map(frameXY))); }
function pointFeature(x, y, props) { const f = new olb.Feature({ geometry: new olb.Point(frameXY([x, y])), ...props }); return f; }

function render(view) {
  S.view = view;
  vehicleFiles(view);
  registerPlanCrs(view.frame);
  const V = view.layers;
  const put = (layer, feats) => { const s = layer.getSource(); s.clear(true); s.addFeatures(feats); };
  put(L.uncovered, (V.uncovered || []).map((p) => new olb.Feature(polygonOf(p))));
  put(L.corridor, view.area_is_centreline ? V.area.map((p) => new olb.Feature(polygonOf(p))) : []);  // the planned band
  put(L.lines, V.lines.map((l) => new olb.Feature({ geometry: new olb.LineString(l.xy.map(frameXY)), id: l.id, sortie: l.sortie })));
  put(L.stations, V.stations.ids.map((id, i) => pointFeature(V.stations.x[i], V.stations.y[i], { id, sortie: V.stations.sortie[i] })));
  const sites = V.launch.length ? V.launch : [{ id: "home", ...V.home }];
  put(L.sites, sites.map((s, i) => pointFeature(s.x, s.y, { id: s.id, label: sites.length > 1 ? String(i + 1) : "H" })));
  put(L.fence, (V.fence || []).map((p) => new olb.Feature(polygonOf(p))));
  const firsts = new Map();  // each pass's first run (the lines are in flight order)
  for (const l of V.lines) if (!firsts.has(l.pass)) firsts.set(l.pass, l);
  put(L.starts, [...firsts.values()].map((l) => {
    const [a, b] = [l.xy[0], l.xy[1] || l.xy[0]];
    return pointFeature(a[0], a[1], { pass: l.pass, rotation: Math.atan2(b[0] - a[0], b[1] - a[1]) });
  }));
  put(L.gcps, V.control_points.filter((p) => p.role === "gcp").map((p) => pointFeature(p.x, p.y, { id: p.id, note: p.note, images: p.images })));
  put(L.checks, V.control_points.filter((p) => p.role !== "gcp").map((p) => pointFeature(p.x, p.y, { id: p.id, note: p.note, images: p.images })));
  L.highlight.getSource().clear();
  for (const x of $$("#rule-list li.selected")) x.classList.remove("selected");
  if (!edit.getFeatures().length) loadEditable();
  if (!S.fitted) { S.fitted = true; fitAll(); }  // the first plan's lines reach beyond the area
  renderLegend(view);
  renderSummary(view);
  renderProfile(view);
  renderRules(view);
  renderFly(view);
  const dropped = S.flown && S.flown.plan_id !== view.plan_id;
  if (dropped) dropFlown();
  noteFirstMap();
  return dropped;
}

/** The plan changed under a loaded flight: its layers go (they were matched to the last plan), with the reason and a
 * button that loads the same files on the new plan. */
function dropFlown() {
  const files = S.flown.files;
  clearFlown();
  const p = document.createElement("p");
  p.textContent = "The flight loaded on the last plan was cleared: the plan changed (re-planned after an edit), and the "
    + "flight's photos, coverage and rules were matched to the last plan's stations. ";
  const again = document.createElement("button"); again.type = "button"; again.id = "reload-flight";
  again.textContent = "Load it on this plan";
  again.addEventListener("click", () => loadFlight(files));
  p.appendChild(again);
  $("#flight-summary").appendChild(p);
}

function registerPlanCrs(frame) {
  if (!frame.proj4 || olb.proj4.defs(frame.crs)) return;
  olb.proj4.defs(frame.crs, frame.proj4);
}

function fitAll() {
  const ext = olb.emptyExtent();
  for (const s of [edit, L.lines.getSource(), L.gcps.getSource()]) if (s.getFeatures().length) olb.extendExtent(ext, s.getExtent());
  if (!olb.extentIsEmpty(ext)) map.getView().fit(olb.bufferExtent(ext, 30), { padding: [48, 20, 40, 20], maxZoom: 19 });
}

function noteFirstMap() {
  if (S.stats.firstMapMs !== null) return;
  // from the navigation's start (performance.now()'s origin): what the user waits for
  map.once("rendercomplete", () => { if (S.stats.firstMapMs === null) S.stats.firstMapMs = Math.round(performance.now()); });
  map.render();
}

function renderLegend(view) {
  const box = $("#sortie-legend"); box.textContent = "";
  for (const [i, s] of view.sorties.entries()) {
    const span = document.createElement("span");
    span.style.background = colour(i + 1);
    span.textContent = s.id;
    box.appendChild(span);
  }
}

function fmtRange(r, unit) { return r[0] === r[1] ? `${r[0]} ${unit}` : `${r[0]}…${r[1]} ${unit}`; }

/** The route over the terrain (view.profile: the whole mission as the clearance check models it): the ground filled,
 * the height flown, the minimum clearance dashed over the ground, red where the route comes nearer the ground. */
function renderProfile(view) {
  const svg = $("#profile"), text = $("#profile-text");
  svg.textContent = "";
  const P = view.profile;
  if (!P || !P.distance_m.length) { text.textContent = "No DEM: give terrain.dem (Setup, Terrain) to see the route over the terrain."; return; }
  const W = 1000, H = 200, pad = 4;
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`); svg.setAttribute("preserveAspectRatio", "none");
  const d = P.distance_m, a = P.amsl_m, g = P.ground_m, m = P.min_clearance_m;
  const lo = Math.min(...g), top = Math.max(...a, ...g.map((v) => v + m)), len = Math.max(d[d.length - 1], 1);
  const hi = profileTop(P.bands, lo, top), span = Math.max(hi - lo, 1);
  const X = (v) => (v / len) * W, Y = (v) => H - pad - ((v - lo) / span) * (H - 2 * pad);
  const path = (ys) => d.map((v, i) => `${i ? "L" : "M"}${X(v).toFixed(1)},${Y(ys[i]).toFixed(1)}`).join("");
  const ns = "http://www.w3.org/2000/svg";
  const add = (dd, cls) => { const p = document.createElementNS(ns, "path"); p.setAttribute("d", dd); p.setAttribute("class", cls); svg.appendChild(p); return p; };
  renderZoneBands(svg, P.bands, X, Y, lo, hi);
  add(`${path(g)}L${W},${H}L0,${H}Z`, "ground");
  add(path(g.map((v) => v + m)), "min-clearance");
  add(path(a), "flown");
  let low = Infinity, where = 0, below = 0;
  for (let i = 0; i < d.length; i++) {
    if (!P.checked[i]) continue;  // the legs to and from the ground
    const c = a[i] - g[i];
    if (c < low) { low = c; where = d[i]; }
    if (i && P.checked[i - 1] && c < m - 0.05 && a[i - 1] - g[i - 1] < m - 0.05) {
      add(`M${X(d[i - 1]).toFixed(1)},${Y(a[i - 1]).toFixed(1)}L${X(d[i]).toFixed(1)},${Y(a[i]).toFixed(1)}`, "below");
      below++;
    }
  }
  text.textContent = `${(len / 1000).toFixed(2)} km flown; ground ${lo.toFixed(0)} to ${Math.max(...g).toFixed(0)} m AMSL; `
    + `lowest clearance ${low.toFixed(1)} m at ${(where / 1000).toFixed(2)} km (minimum ${m} m)`
    + (below ? `; below the minimum on ${below} stretch(es), in red` : "")
    + zonesCrossed(P.bands);
}

/** The zones the route crosses, one each: its band, how many stretches and how far inside. */
function zonesCrossed(bands) {
  const by = new Map();
  for (const b of bands) {
    const z = by.get(b.name) || { band: b.band, n: 0, m: 0 };
    z.n++; z.m += b.distance_m[b.distance_m.length - 1] - b.distance_m[0];
    by.set(b.name, z);
  }
  return [...by].map(([name, z]) => `; ${name} (${z.band}): crossed ${z.n} time(s), ${(z.m / 1000).toFixed(2)} km inside`).join("");
}

/** The profile's top: the route's, raised to show the lower limits of the zones' bands up to twice its height range
 * (a band starting far above the route is drawn from the top). */
function profileTop(bands, lo, top) {
  const lowers = bands.flatMap((b) => b.lower_m);
  return lowers.length ? Math.max(top, Math.min(Math.max(...lowers) + 10, top + (top - lo))) : top;
}

/** The zones the route crosses (view.profile.bands): each band a shaded box along its stretch, from its lower to its
 * upper limit (to the top without a ceiling), clipped to the drawing, labelled with the zone and its band. */
function renderZoneBands(svg, bands, X, Y, lo, hi) {
  const ns = "http://www.w3.org/2000/svg";
  const clip = (v) => Math.min(Math.max(v, lo), hi);
  const labelled = new Map();  // each zone's name once, at its first stretch, one line a zone
  for (const b of bands) {
    const d = b.distance_m, up = b.upper_m || d.map(() => hi);
    const pts = [...d.map((v, i) => [X(v), Y(clip(up[i]))]), ...d.map((v, i) => [X(v), Y(clip(b.lower_m[i]))]).reverse()];
    const box = document.createElementNS(ns, "path");
    box.setAttribute("d", pts.map(([x, y], i) => `${i ? "L" : "M"}${x.toFixed(1)},${y.toFixed(1)}`).join("") + "Z");
    box.setAttribute("class", `zone-band ${b.kind}`);
    const title = document.createElementNS(ns, "title");
    title.textContent = `${b.name}: ${b.band}`;
    box.appendChild(title);
    svg.appendChild(box);
    if (labelled.has(b.name)) continue;
    labelled.set(b.name, labelled.size);
    const label = document.createElementNS(ns, "text");
    const x = X(d[0]);
    label.setAttribute("x", x.toFixed(1)); label.setAttribute("y", String(14 + 14 * (labelled.size - 1)));
    if (x > svg.viewBox.baseVal.width / 2) label.setAttribute("text-anchor", "end");  // kept inside the drawing
    label.setAttribute("class", "zone-label");
    label.textContent = b.name.split(" (")[0];
    svg.appendChild(label);
  }
}

function renderSummary(view) {
  const s = view.summary;
  const failing = view.rules.filter((r) => r.status === "fail");
  // the summary's own rules line when the server gives one (the text `plan` and `check` print)
  const rules = s.rules && s.rules.text ? s.rules.text
    : view.rules.length ? (failing.length ? `${failing.length} of ${view.rules.length} fail` : `${view.rules.length} pass`) : "none chosen";
  // a plan that takes no photo straight down (an orbit, a facade) by the heights its photos are taken at and its faces
  const f = s.faces;
  const ground = !f || f.nadir_photos ? [
    ["height AGL", s.height_range_m[0] === s.height_range_m[1] ? `${s.height_agl_m} m` : fmtRange(s.height_range_m, "m")],
    ["GSD", fmtRange(s.gsd_cm, "cm")],
  ] : [["photos taken", f.station_agl_m ? `${fmtRange(f.station_agl_m, "m")} AGL, none straight down` : "none"]];
  const faces = !f ? [] : [
    ["faces", `${Math.round(f.area_m2)} m², ${f.short_m2} m² short of ${f.min_images} photos (fewest ${f.fewest_images})`],
    ["GSD on faces", f.gsd_cm ? fmtRange(f.gsd_cm, "cm") : "no point seen"],
  ];
  const rows = [
    ["area", `${s.area_ha} ha (${s.crs})`],
    ...ground,
    ...faces,
    ["photos", `${s.photos}`],
    ["lines", `${s.lines} (${s.runs} runs)`],
    ["time", `${s.time_min} min`],
    ["distance", `${s.distance_km} km`],
    ["sorties", s.sorties ? String(s.sorties) : "1 (no battery set)"],
    ["rules", rules],
  ];
  const dl = $("#summary"); dl.textContent = "";
  for (const [k, v] of rows) {
    const dt = document.createElement("dt"); dt.textContent = k;
    const dd = document.createElement("dd"); dd.textContent = v; dd.dataset.summary = k;
    if (k === "rules" && view.rules.length) dd.className = failing.length ? "fail" : "pass";
    dl.append(dt, dd);
  }
  dl.title = `camera ${s.camera}; heading ${s.heading_deg}°; spacing ${s.spacing_m} m; photo base ${s.photo_base_m} m; `
    + `speed ${s.speed_ms} m/s (${s.speed_limited_by}); ${s.mission_items} mission items`;
  const badge = $("#rules-badge");
  badge.textContent = failing.length ? `(${failing.length} ✗)` : view.rules.length ? "✓" : "";
  badge.className = failing.length ? "fail" : "";
  const w = $("#warnings"); w.textContent = "";
  for (const text of view.warnings) { const li = document.createElement("li"); li.textContent = text; w.appendChild(li); }
}

function ruleItem(r, onClick) {
  const li = document.createElement("li");
  li.className = r.status;
  li.dataset.rule = r.rule;
  const status = document.createElement("span"); status.className = "status"; status.textContent = r.status;
  const name = document.createElement("b"); name.textContent = r.rule;
  const detail = document.createElement("div"); detail.className = "detail";
  detail.textContent = `measured ${r.measured}; required ${r.required}` + ((r.evidence || []).length ? "\n" + r.evidence.slice(0, 6).join("\n") : "");
  li.append(status, name, detail);
  li.title = r.statement || "";
  if (onClick) {  // a rule with places to show: a button, reached by Tab and pressed with Enter or Space
    li.tabIndex = 0; li.setAttribute("role", "button");
    li.addEventListener("click", () => onClick(r, li));
    li.addEventListener("keydown", (e) => { if (e.key === "Enter" || e.key === " ") { e.preventDefault(); onClick(r, li); } });
  }
  return li;
}

function renderRules(view) {
  const ul = $("#rule-list"); ul.textContent = "";
  if (!view.rules.length) { const li = document.createElement("li"); li.textContent = "no rule profile chosen"; ul.appendChild(li); }
  // failing rules first: they are what the pilot has to act on
  const order = { fail: 0, warning: 1 };
  const rules = [...view.rules].sort((a, b) => (order[a.status] ?? 2) - (order[b.status] ?? 2));
  for (const r of rules) ul.appendChild(ruleItem(r, r.where.length ? highlight : null));
}

function highlight(rule, li) {
  for (const x of $$("#rule-list li.selected")) x.classList.remove("selected");
  li.classList.add("selected");
  const src = L.highlight.getSource(); src.clear();
  const byId = (layer) => new Map(layer.getSource().getFeatures().map((f) => [f.get("id"), f]));
  const lines = byId(L.lines), stations = byId(L.stations), cps = new Map([...byId(L.gcps), ...byId(L.checks)]);
  const add = (f) => { if (f) src.addFeature(new olb.Feature({ geometry: f.getGeometry().clone(), id: f.get("id") })); };
  for (const w of rule.where) {
    if (w.run) add(lines.get(w.run));
    if (w.runs) w.runs.forEach((id) => add(lines.get(id)));
    if (w.station) add(stations.get(w.station));
    if (w.point) add(cps.get(w.point));
    if (w.xy) src.addFeature(new olb.Feature(new olb.Point(frameXY(w.xy))));
  }
  if (src.getFeatures().length) map.getView().fit(olb.bufferExtent(src.getExtent(), 40), { padding: [60, 40, 40, 40], maxZoom: 19, duration: 200 });
}

// ---- fly blocks and downloads ---------------------------------------------------------------
function fileLink(name, label) {
  const a = document.createElement("a");
  a.href = `/api/plans/${S.view.plan_id}/files/${encodeURIComponent(name)}`;
  a.textContent = label || name; a.setAttribute("download", name); a.dataset.file = name;
  return a;
}

/** `aerosurvey brief` of the plan shown, for the time chosen (the browser's own time zone). */
async function makeBrief() {
  const out = $("#brief-out"); out.textContent = "";
  clearError("brief");
  const value = $("#brief-at").value;
  if (!value || !S.view) { showError("brief", "choose the date and time of the first launch"); return; }
  try {
    const r = await api("POST", `/api/plans/${S.view.plan_id}/brief`, { at: new Date(value).toISOString() });
    const head = document.createElement("div"); head.className = `brief-verdict ${r.verdict}`;
    head.textContent = `${r.verdict.toUpperCase()}: ${new Date(r.start).toLocaleString()} to ${new Date(r.end).toLocaleTimeString()}`;
    const list = document.createElement("ul"); list.id = "brief-items";
    for (const i of r.items) {
      const li = document.createElement("li"); li.className = i.verdict; li.dataset.topic = i.topic;
      li.textContent = `${i.verdict.toUpperCase()} ${i.topic}: ${i.text}`;
      list.appendChild(li);
    }
    out.append(head, list);
  } catch (e) { showError("brief", e.message); }
}

// ---- the vehicle (serve --connect): checks, upload, read-back -------------------------------------
const vehicleStyles = {
  vehicle: new olb.Style({ image: new olb.CircleStyle({ radius: 8, fill: new olb.Fill({ color: "#1565c0" }), stroke: new olb.Stroke({ color: "#fff", width: 2 }) }) }),
  home: new olb.Style({ image: new olb.CircleStyle({ radius: 6, fill: new olb.Fill({ color: "#fff" }), stroke: new olb.Stroke({ color: "#1565c0", width: 3 }) }) }),
};
const vehicleLayer = vector("vehicle", (f) => vehicleStyles[f.get("role")], 14);
L.vehicle = vehicleLayer;  // window.aerosurvey.layers.vehicle
map.addLayer(vehicleLayer);
const V = { checked: null, busy: false };  // the file whose check passed, a job under way

async function vehicleStart() {
  const r = await api("GET", "/api/vehicle");
  if (!r.url) return;
  $("#vehicle-box").hidden = false;
  $("#vehicle-url").textContent = `Vehicle: ${r.url}. A check only reads it; nothing is sent until you click Upload.`;
  $("#vehicle-check").addEventListener("click", () => vehicleRun(false));
  $("#vehicle-upload").addEventListener("click", () => vehicleRun(true));
  $("#vehicle-file").addEventListener("change", vehicleReset);
}

/** The plan's mission files in the vehicle's file list (a new plan: checked again before an upload). */
function vehicleFiles(view) {
  const sel = $("#vehicle-file"), was = sel.value;
  sel.textContent = "";
  for (const n of view.files.filter((f) => f.endsWith(".plan"))) {
    const o = document.createElement("option"); o.value = n; o.textContent = n; sel.appendChild(o);
  }
  if ([...sel.options].some((o) => o.value === was)) sel.value = was;
  vehicleReset();
}

function vehicleReset() {
  V.checked = null;
  $("#vehicle-upload").disabled = true;
}

async function vehicleRun(send) {
  if (V.busy || !S.view) return;
  const file = $("#vehicle-file").value;
  clearError("vehicle");
  $("#vehicle-checks").textContent = ""; $("#vehicle-verdict").textContent = ""; $("#vehicle-verdict").className = "";
  $("#vehicle-held").hidden = true;
  V.busy = true; $("#vehicle-check").disabled = true; $("#vehicle-upload").disabled = true;
  $("#vehicle-progress").hidden = false; $("#vehicle-progress-bar").value = 0;
  $("#vehicle-stage").textContent = send ? "connecting, checking" : "connecting";
  try {
    const job = (await api("POST", `/api/plans/${S.view.plan_id}/vehicle/${encodeURIComponent(file)}`, { send })).job;
    for (;;) {
      const st = await api("GET", `/api/jobs/${job}?wait=0.25`);
      $("#vehicle-progress-bar").value = st.progress;
      $("#vehicle-stage").textContent = `${st.stage} ${Math.round(st.progress * 100)} %`;
      if (st.state === "done") { vehicleShow(st.result, st.elapsed_s); break; }
      if (st.state !== "queued" && st.state !== "running") {
        const v = $("#vehicle-verdict"); v.className = "no-go";
        v.textContent = send ? "NOT UPLOADED: do not fly it" : "NO-GO";
        showError("vehicle", st.error ? st.error.message : `the job ended ${st.state}`);
        break;
      }
    }
  } catch (e) { showError("vehicle", e.message); }
  V.busy = false; $("#vehicle-check").disabled = false;
  $("#vehicle-upload").disabled = V.checked !== $("#vehicle-file").value;
}

function vehicleShow(r, seconds) {
  const list = $("#vehicle-checks");
  for (const line of r.refusals) { const li = document.createElement("li"); li.className = "no-go"; li.textContent = `NO-GO ${line}`; list.appendChild(li); }
  for (const line of r.sent ? r.report : r.checks) { const li = document.createElement("li"); li.textContent = line; list.appendChild(li); }
  const v = $("#vehicle-verdict");
  if (r.sent) {
    v.className = r.verified ? "go" : "no-go";
    v.textContent = r.verified ? `VERIFIED: ${r.file} uploaded, read back and compared in ${seconds.toFixed(1)} s` : `${r.file} uploaded, not verified`;
  } else {
    v.className = r.refusals.length ? "no-go" : "go";
    v.textContent = r.refusals.length ? `NO-GO: ${r.refusals.length} check(s) refuse ${r.file}` : `GO: every check passes for ${r.file}; Upload sends it`;
  }
  V.checked = !r.sent && !r.refusals.length ? r.file : V.checked;
  const src = vehicleLayer.getSource(); src.clear();
  const at = (latlon, role) => src.addFeature(new olb.Feature({ geometry: new olb.Point(olb.fromLonLat([latlon[1], latlon[0]])), role }));
  if (r.position) at(r.position, "vehicle");
  at(r.held_home || r.launch, "home");
  if (r.held_waypoints) {
    const a = $("#vehicle-held");
    if (a.href) URL.revokeObjectURL(a.href);
    a.href = URL.createObjectURL(new Blob([r.held_waypoints], { type: "text/plain" }));
    a.download = `${r.file.replace(/\.plan$/, "")}-vehicle.waypoints`; a.hidden = false;
  }
}

/** A button that shares one file on the local network (serve --lan) and shows its QR code in its fly block. */
function qrButton(name) {
  const b = document.createElement("button");
  b.type = "button"; b.className = "qr-button"; b.textContent = "QR"; b.dataset.share = name;
  b.title = `Show a QR code a phone or a DJI remote controller on this network downloads ${name} from`;
  b.addEventListener("click", async () => {
    const box = b.closest(".fly").querySelector(".qr");
    box.textContent = "";
    try {
      const r = await api("POST", `/api/plans/${S.view.plan_id}/share/${encodeURIComponent(name)}`);
      const img = document.createElement("img");
      img.src = `data:image/png;base64,${r.qr_png}`; img.alt = `QR code of ${r.url}`;
      const url = document.createElement("div"); url.className = "hint"; url.textContent = `${name}: ${r.url}`;
      box.append(img, url);
    } catch (e) { box.textContent = e.message; box.classList.add("err"); }
  });
  return b;
}

function lonlatText(lon, lat) {
  return `${Math.abs(lat).toFixed(6)}° ${lat >= 0 ? "N" : "S"} ${Math.abs(lon).toFixed(6)}° ${lon >= 0 ? "E" : "W"}`;
}

function renderFly(view) {
  const box = $("#fly-blocks"); box.textContent = "";
  const s = view.summary;
  const blocks = view.sorties.length ? view.sorties.map((x, i) => ({ ...x, n: i + 1 })) : [{
    id: "mission", n: 0, files: ["mission.plan", "mission.waypoints"], photos: s.photos, time_s: s.time_min * 60,
    distance_m: s.distance_km * 1000, launch: null,
  }];
  for (const b of blocks) {
    const div = document.createElement("div"); div.className = "fly"; div.dataset.sortie = b.id;
    div.style.setProperty("--c", colour(b.n || 1));
    const h = document.createElement("h4");
    const title = document.createElement("span");
    title.textContent = b.n ? `${b.n}. sortie ${b.id}` : "One flight (no battery split)";
    const time = document.createElement("span"); time.textContent = `${(b.time_s / 60).toFixed(1)} min`;
    h.append(title, time);
    const facts = document.createElement("div"); facts.className = "facts";
    facts.textContent = `${b.photos} photos · ${(b.distance_m / 1000).toFixed(2)} km`;
    const launch = document.createElement("div"); launch.className = "launch";
    if (b.launch) {  // without a DEM the manifest's ground is 0 m: no height is known
      launch.textContent = `launch point ${b.launch.index}: ${lonlatText(b.launch.lon, b.launch.lat)}, `
        + (view.dem ? `ground ${b.launch.ground_amsl_m} m AMSL` : "no DEM");
    }
    else { const H = view.layers.home; const [lon, lat] = olb.toLonLat(frameXY([H.x, H.y])); launch.textContent = `take-off (home): ${lonlatText(lon, lat)}`; }
    const parts = [facts, launch];
    if (b.usable_used_pct !== undefined) {
      const bat = document.createElement("div"); bat.className = "battery";
      bat.textContent = `battery: ${b.usable_used_pct.toFixed(1)} % of the usable charge (${b.battery_used_pct.toFixed(1)} % of the pack)`
        + (b.wind_used_pct ? `, of which the wind takes ${b.wind_used_pct.toFixed(1)} %` : "");
      parts.push(bat);
    }
    const files = document.createElement("div"); files.className = "files";
    // the sortie's files for every fleet the plan exports (.plan, .waypoints, a DJI camera's .kmz): those of its stems
    const stem = (f) => f.replace(/\.[^.]+$/, "");
    const stems = new Set(b.files.map(stem));
    for (const f of view.files.filter((n) => stems.has(stem(n)))) {
      files.appendChild(fileLink(f));
      if (S.lan) files.appendChild(qrButton(f));
    }
    parts.push(files);
    if (S.lan) { const qr = document.createElement("div"); qr.className = "qr"; parts.push(qr); }
    div.append(h, ...parts);
    box.appendChild(div);
  }
  renderFiles(view);
}

function renderFiles(view) {
  const groups = [
    ["Whole mission", (f) => f.startsWith("mission.") || f.endsWith(".kml")],
    ["Control points", (f) => f.startsWith("control_points") || f === "gcp_list.txt"],
    ["Sorties", (f) => f.startsWith("sortie-")],
    ["Records and preview", () => true],
  ];
  const box = $("#file-groups"); box.textContent = "";
  const left = new Set(view.files);
  const zip = document.createElement("a");
  zip.href = `/api/plans/${view.plan_id}/archive.zip`; zip.textContent = "all files (.zip)"; zip.setAttribute("download", "");
  box.appendChild(zip);
  for (const [title, test] of groups) {
    const names = [...left].filter(test);
    if (!names.length) continue;
    names.forEach((n) => left.delete(n));
    const h = document.createElement("h4"); h.textContent = title;
    const ul = document.createElement("ul");
    for (const n of names) { const li = document.createElement("li"); li.appendChild(fileLink(n)); ul.appendChild(li); }
    box.append(h, ul);
  }
}

// ---- the drawn geometry: area polygons (with holes), exclusion zones, launch points ------------
function editFeatures(role) { return edit.getFeatures().filter((f) => f.get("role") === role); }
/** Polygons (or lines: a corridor's centreline) as one WKT geometry in WGS84. */
function toWkt(geoms) {
  const multi = geoms[0].getType() === "LineString" ? "MultiLineString" : "MultiPolygon";
  const g = geoms.length === 1 ? geoms[0] : geojson.readGeometry({ type: multi, coordinates: geoms.map((p) => p.getCoordinates()) });
  return wkt.writeGeometry(g, TO_WGS84);
}
function readWkt(text) {
  const g = wkt.readGeometry(text, { dataProjection: WGS84, featureProjection: WEB });
  return g.getType() === "MultiPolygon" ? g.getPolygons() : g.getType() === "MultiLineString" ? g.getLineStrings() : [g];
}
/** The spec's area geometry drawn with its role: polygons are the area, lines a corridor's centreline. */
function addArea(text, add) {
  readWkt(text).forEach((g) => add(g, g.getType() === "LineString" ? "centreline" : "area"));
}

/** The editable features from the spec (area WKT, launch points) and the zones (drawn WKT or the server's preview of the files). */
function loadEditable() {
  edit.clear(true);
  const add = (geom, role) => edit.addFeature(new olb.Feature({ geometry: geom, role }));
  const area = S.spec.area || {};
  // the spec's WKT, else the server's reading of its files; else (a spec that could not be read at the start) the plan's
  const planned = (key) => (S.view ? S.view.layers[key] : []).map(polygonOf);
  if (area.wkt && (!area.wkt_crs || area.wkt_crs === WGS84)) addArea(area.wkt, add);
  else if (S.preview && S.preview.area) addArea(S.preview.area, add);
  else if (!S.view || !S.view.area_is_centreline) planned("area").forEach((g) => add(g, "area"));  // not a corridor's band
  if (S.zones !== null) S.zones.forEach((z) => readWkt(z).forEach((g) => add(g, "zone")));
  else if (S.preview) S.preview.zones.forEach((z) => readWkt(z).forEach((g) => add(g, "zone")));
  else planned("exclusions").forEach((g) => add(g, "zone"));
  for (const p of launchPoints()) add(new olb.Point(olb.fromLonLat(p)), "launch");
  for (const p of (S.spec.flight && S.spec.flight.rally_points) || []) add(new olb.Point(olb.fromLonLat(p)), "rally");
  S.history = [snapshot()]; S.pos = 0; S.touched.clear();
  updateUndo();
}

function launchPoints() {
  const b = S.spec.battery && S.spec.battery.launch_points;
  if (Array.isArray(b) && b.length) return b;
  const a = S.spec.area && S.spec.area.launch;
  return Array.isArray(a) ? [a] : [];
}

/** The area into the spec: a corridor's centreline (pattern.kind = "corridor"), else the area polygons. */
function writeArea() {
  const polys = editFeatures(centrelineKind() ? "centreline" : "area").map((f) => f.getGeometry());
  if (!polys.length) { delete S.spec.area; return; }
  if (!S.spec.camera && S.defaults) { S.spec = { ...structuredClone(S.defaults), ...S.spec }; fillForm(); }  // a page started without a spec
  const { file, wkt, wkt_crs, ...rest } = S.spec.area || {};  // the zone files and the launch point stay
  S.spec.area = { ...rest, wkt: toWkt(polys) };
}
function writeZones() {
  S.zones = editFeatures("zone").map((f) => toWkt([f.getGeometry()]));
  if (S.spec.area) delete S.spec.area.exclusions;
}
function writeLaunch() {
  const pts = editFeatures("launch").map((f) => lonLatOf(f.getGeometry().getCoordinates()));
  if (S.spec.area) delete S.spec.area.launch;
  if (S.spec.battery) { S.spec.battery.launch_points = pts; if (!pts.length) delete S.spec.battery.launch_points; }
  else if (pts.length && S.spec.area) S.spec.area.launch = pts[pts.length - 1];
}

/** The rally points drawn into the spec's flight.rally_points (every launch site is a rally point too). */
function writeRally() {
  const pts = editFeatures("rally").map((f) => lonLatOf(f.getGeometry().getCoordinates()));
  S.spec.flight = { ...(S.spec.flight || {}), rally_points: pts };
  if (!pts.length) delete S.spec.flight.rally_points;
}

/** The user changed the drawn geometry of these roles: into the spec, onto the undo stack, re-plan. */
function geometryChanged(roles) {
  for (const r of roles) S.touched.add(r);
  S.history = S.history.slice(0, S.pos + 1); S.history.push(snapshot()); S.pos = S.history.length - 1;
  writeGeometry();
}
function writeGeometry() {
  if (S.touched.has("area") || S.touched.has("centreline")) writeArea();
  if (S.touched.has("zone")) writeZones();
  if (S.touched.has("launch")) writeLaunch();
  if (S.touched.has("rally")) writeRally();
  updateUndo();
  clearError("area");
  if (!S.spec.area) {  // nothing left to plan: the last plan's layers go too
    S.seq++;
    for (const l of [L.corridor, L.uncovered, L.lines, L.stations, L.sites, L.fence, L.gcps, L.checks, L.highlight]) l.getSource().clear();
    setStatus("draw an area to plan");
    return;
  }
  schedule();
}

const geojson = new olb.GeoJSON();
function snapshot() { return { touched: [...S.touched], features: geojson.writeFeaturesObject(edit.getFeatures()) }; }
function restore(snap) {
  edit.clear(true);
  edit.addFeatures(geojson.readFeatures(snap.features));
  for (const r of snap.touched) S.touched.add(r);
}
function undo() { if (S.pos > 0) { S.pos--; restore(S.history[S.pos]); writeGeometry(); } }
function redo() { if (S.pos < S.history.length - 1) { S.pos++; restore(S.history[S.pos]); writeGeometry(); } }
function updateUndo() { $("#undo").disabled = S.pos <= 0; $("#redo").disabled = S.pos >= S.history.length - 1; }

// interactions: modify and snap on the drawn geometry, one drawing tool at a time
const modify = new olb.Modify({ source: edit, pixelTolerance: 12 });
modify.on("modifyend", (e) => geometryChanged(new Set(e.features.getArray().map((f) => f.get("role")))));
map.addInteraction(modify);
const translate = new olb.Translate({ layers: [L.area] });
translate.on("translateend", (e) => geometryChanged(new Set(e.features.getArray().map((f) => f.get("role")))));
map.addInteraction(translate);
let draw = null;
const snap = new olb.Snap({ source: edit, pixelTolerance: 12 });

function setTool(tool) {
  S.tool = tool;
  for (const b of $$("#tools [data-tool]")) { b.classList.toggle("on", b.dataset.tool === tool); b.setAttribute("aria-pressed", String(b.dataset.tool === tool)); }
  if (draw) { map.removeInteraction(draw); draw = null; }
  map.removeInteraction(snap);
  modify.setActive(tool === "edit");
  translate.setActive(tool === "move");
  $("#measure-out").hidden = !tool.startsWith("measure");
  if (!tool.startsWith("measure")) L.measure.getSource().clear();
  const type = { area: "Polygon", hole: "Polygon", zone: "Polygon", launch: "Point", rally: "Point", centreline: "LineString", measure: "LineString",
    "measure-area": "Polygon" }[tool];
  if (type) {
    draw = new olb.Draw({ type, source: tool.startsWith("measure") ? L.measure.getSource() : undefined, stopClick: true });
    draw.on("drawstart", (e) => { if (tool.startsWith("measure")) { L.measure.getSource().clear(); measureLive(e.feature); } });
    draw.on("drawend", (e) => onDrawn(tool, e.feature));
    map.addInteraction(draw);
  }
  map.addInteraction(snap);  // after the others, as OpenLayers asks
}

function onDrawn(tool, feature) {
  const geom = feature.getGeometry();
  if (tool === "area" || tool === "zone" || tool === "launch" || tool === "rally" || tool === "centreline") {
    const role = tool;
    edit.addFeature(new olb.Feature({ geometry: geom, role }));
    if (role === "centreline" && !centrelineKind()) {  // a centreline makes the plan one along it (a corridor)
      const along = Object.values(S.patterns).find((p) => p.area_is_centreline);
      S.spec.pattern = { kind: along.kind };
      if (along.fields.some((f) => f.key === "width_m")) S.spec.pattern.width_m = DEFAULT_CORRIDOR_WIDTH_M;
      onKind();
    }
    geometryChanged([role]);
  } else if (tool === "hole") {
    const inside = editFeatures("area").find((f) => f.getGeometry().intersectsCoordinate(geom.getInteriorPoint().getCoordinates()));
    if (!inside) { showError("area", "a hole must be drawn inside an area polygon"); return; }
    const poly = inside.getGeometry();
    poly.setCoordinates([...poly.getCoordinates(), geom.getCoordinates()[0]]);
    geometryChanged(["area"]);
  }
}

function measureLive(feature) {
  const out = $("#measure-out");
  const show = () => {
    const g = feature.getGeometry();
    if (g.getType() === "LineString") {
      const m = olb.getLength(g);
      out.textContent = m >= 1000 ? `${(m / 1000).toFixed(3)} km` : `${m.toFixed(1)} m`;
    } else {
      const a = olb.getArea(g);
      out.textContent = `${(a / 1e4).toFixed(3)} ha (${Math.round(a)} m²), perimeter ${olb.getLength(new olb.LineString(g.getCoordinates()[0])).toFixed(1)} m`;
    }
  };
  feature.getGeometry().on("change", show);
}

/** The start tool: the line end nearest the click becomes its pass's start (flight.pass_start), then re-plan. */
function startAt(pixel) {
  if (!S.view) return;
  let best = null;
  for (const l of S.view.layers.lines) {
    for (const xy of [l.xy[0], l.xy[l.xy.length - 1]]) {
      const p = map.getPixelFromCoordinate(frameXY(xy));
      const d = Math.hypot(p[0] - pixel[0], p[1] - pixel[1]);
      if (!best || d < best.d) best = { d, xy, pass: l.pass };
    }
  }
  if (!best || best.d > 40) { showError("area", "click near the end of a line: its pass will start there"); return; }
  const [lon, lat] = lonLatOf(frameXY(best.xy));
  S.spec.flight = { ...(S.spec.flight || {}), pass_start: { ...((S.spec.flight || {}).pass_start || {}), [String(best.pass)]: [lon, lat] } };
  schedule();
}

function deleteAt(pixel) {
  const hits = map.getFeaturesAtPixel(pixel, { layerFilter: (l) => l === L.area, hitTolerance: 6 });
  const coord = map.getCoordinateFromPixel(pixel);
  // a hole under the click is taken out of its polygon; else the topmost launch point, zone or area polygon goes
  for (const f of editFeatures("area")) {
    const rings = f.getGeometry().getCoordinates();
    const k = rings.findIndex((r, i) => i > 0 && new olb.Polygon([r]).intersectsCoordinate(coord));
    if (k > 0) { rings.splice(k, 1); f.getGeometry().setCoordinates(rings); geometryChanged(["area"]); return; }
  }
  const rank = { launch: 0, rally: 0, centreline: 1, zone: 2, area: 3 };
  const f = hits.sort((a, b) => rank[a.get("role")] - rank[b.get("role")])[0];
  if (f) { edit.removeFeature(f); geometryChanged([f.get("role")]); }
}

// ---- cursor readout, layer toggles, basemap ----------------------------------------------------
function onPointer(e) {
  const [lon, lat] = olb.toLonLat(e.coordinate);
  let text = `WGS84 ${lonlatText(lon, lat)}`;
  const crs = S.view && S.view.frame.crs;
  if (crs && olb.proj4.defs(crs)) {
    const [x, y] = olb.proj4(crs, [lon, lat]);
    text += `   ·   ${crs} x ${x.toFixed(2)} y ${y.toFixed(2)}`;
  }
  $("#cursor").textContent = text;
}

// An XYZ template, or a WMTS REST template of the Web Mercator tile matrix set (GoogleMapsCompatible),
// whose {TileMatrix}/{TileCol}/{TileRow} are XYZ's z/x/y; the empty string for anything else.
const WMTS_KEYS = { "{TileMatrix}": "{z}", "{TileCol}": "{x}", "{TileRow}": "{y}" };
function xyzTemplate(url) {
  const xyz = Object.entries(WMTS_KEYS).reduce((u, [w, k]) => u.replaceAll(w, k), url || "");
  return ["{z}", "{x}", "{y}"].every((k) => xyz.includes(k)) ? xyz : "";
}

function basemapSource() {
  const url = xyzTemplate(S.tileUrl) || (S.basemap && S.basemap.url);
  if (!url) return null;
  const own = !S.tileUrl;
  return new olb.XYZ({
    url, crossOrigin: own ? undefined : "anonymous", maxZoom: own ? S.basemap.maxzoom : 19, minZoom: own ? S.basemap.minzoom : 0,
    attributions: own ? S.basemap.attribution || S.basemap.name : undefined,
  });
}
function updateBasemap() {
  const vector = !S.tileUrl && S.basemap && S.basemap.vector;
  L.basemap.setSource(vector ? null : basemapSource());
  L.vbasemap.setSource(vector ? new olb.VectorTileSource({
    format: new olb.MVT(), url: S.basemap.url, minZoom: S.basemap.minzoom, maxZoom: S.basemap.maxzoom,
    attributions: S.basemap.attribution || S.basemap.name,
  }) : null);
  $("#basemap-note").textContent = S.tileUrl ? `tiles from ${S.tileUrl}`
    : S.basemap ? `offline basemap ${S.basemap.name} (${S.basemap.format}, zoom ${S.basemap.minzoom}–${S.basemap.maxzoom}), served by this page`
      : "No tile server is contacted unless a URL is set.";
}

// ---- uploads -----------------------------------------------------------------------------------
/** A GeoTIFF DEM picked on the page: the server checks it as the loader opens a DEM and stores it in the mission's
 * folder (dem/NAME.tif); its path becomes terrain.dem and the mission is planned over it. */
async function uploadDem(file) {
  clearError("terrain.dem");
  const fd = new FormData();
  fd.append("file", file, file.name);
  setStatus(`uploading ${file.name}…`);
  try {
    const r = await api("POST", "/api/dem", fd);
    setKey(S.spec, "terrain.dem", r.path);
    fillForm();
    setStatus(`DEM ${file.name} stored as ${r.path} (${r.size[0]} × ${r.size[1]} cells, ${r.crs})`);
    replan();
  } catch (e) {
    showError("terrain.dem", e.message);
    setStatus(`DEM ${file.name} refused`);
  }
}

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
    S.zones = null; S.preview = { area: null, zones: [] }; S.fitted = false;  // the new place has no zones
    fillForm();
    loadEditable(); fitAll();
    setStatus(`area ${r.file_name} loaded`);
    replan();
  } catch (e) { showError(e.key || "area.file", e.message); setStatus("the area file could not be used"); }
}

function clearFlown() {
  S.flown = null;
  for (const l of [L.flown, L.failing, L.gaps, L.refly]) l.getSource().clear();
  L.coverage.setSource(null);
  $("#flight-summary").textContent = ""; $("#flown-rules").textContent = "";
  $("#refly-box").hidden = true; $("#refly-files").textContent = "";
}

async function loadFlight(files) {
  const box = $(".err[data-for='flight']"); box.textContent = "";
  if (!S.view) { box.textContent = "plan first: the flight is drawn against the plan"; return; }
  const fd = new FormData();
  for (const f of files) if (FLIGHT_FILES.includes(f.name)) fd.append("files", f, f.name);
  try {
    const r = await api("POST", `/api/plans/${S.view.plan_id}/flight`, fd);
    clearFlown();
    S.flown = { ...r, plan_id: S.view.plan_id, files };
    drawFlown();
  } catch (e) { box.textContent = e.message; }
}
const FLIGHT_FILES = ["events.csv", "coverage.tif", "log_report.json", "failing_places.geojson"];

function drawFlown() {
  const f = S.flown;
  const src = L.flown.getSource();
  src.addFeatures(f.events.x.map((x, i) => pointFeature(x, f.events.y[i], { event: f.events.event[i], station: f.events.station[i] })));
  if (f.coverage) {
    const [x0, y0, x1, y1] = f.coverage.bounds;
    const [ox, oy] = S.view.frame.origin;
    L.coverage.setSource(new olb.ImageStatic({ url: f.coverage.png, imageExtent: [x0 + ox, y0 + oy, x1 + ox, y1 + oy] }));
  }
  const read = (fc) => geojson.readFeatures(fc, { dataProjection: WGS84, featureProjection: WEB });
  if (f.failing) L.failing.getSource().addFeatures(read(f.failing));
  if (f.gaps) L.gaps.getSource().addFeatures(read(f.gaps));
  const rep = f.report || {};
  const parts = [`${f.events.x.length} camera events`];
  if (rep.planned !== undefined) parts.push(`${rep.matched} of ${rep.planned} stations matched, ${(rep.missed_stations || []).length} missed`);
  if (rep.coverage) parts.push(`at least ${rep.coverage.min_images_in_area} photos per cell, ${(100 * rep.coverage.uncovered_share).toFixed(2)} % uncovered`);
  if (f.gaps) {
    const m2 = f.gaps.features.reduce((a, g) => a + g.properties.area_m2, 0);
    parts.push(m2 ? `${(m2 / 1e4).toFixed(3)} ha seen by fewer photos than planned (orange)` : "no unphotographed ground");
  }
  if (!f.rules) parts.push("no failing_places.geojson: run `aerosurvey check` on the folder to see the rules as flown");
  $("#flight-summary").textContent = parts.join("; ");
  const ul = $("#flown-rules"); ul.textContent = "";
  for (const r of f.rules || []) ul.appendChild(ruleItem(r, showFlownFailure));
  if (f.rules && !f.rules.length) { const li = document.createElement("li"); li.className = "pass"; li.textContent = "every rule passes as flown"; ul.appendChild(li); }
  $("#refly-box").hidden = false;
}

/** A rule that fails as flown, clicked: its places in red (the others hidden) and the map on them. */
function showFlownFailure(rule, li) {
  for (const x of $$("#flown-rules li.selected")) x.classList.remove("selected");
  li.classList.add("selected");
  const src = L.highlight.getSource(); src.clear();
  for (const f of L.failing.getSource().getFeatures()) if (f.get("rule") === rule.rule) src.addFeature(new olb.Feature(f.getGeometry().clone()));
  if (src.getFeatures().length) map.getView().fit(olb.bufferExtent(src.getExtent(), 40), { padding: [60, 40, 40, 40], maxZoom: 19, duration: 200 });
}

/** The next flight from the loaded folder: `kind` refly (the gaps) or resume (the rest of a flight cut short). */
async function nextFlight(kind) {
  const box = $(".err[data-for~='refly']"); box.textContent = "";
  const fd = new FormData();
  for (const f of S.flown.files) if (FLIGHT_FILES.includes(f.name)) fd.append("files", f, f.name);
  setStatus(kind === "refly" ? "making the re-fly mission…" : "planning the rest of the flight…");
  L.refly.getSource().clear();
  try {
    const r = await api("POST", `/api/plans/${S.view.plan_id}/${kind}`, fd);
    const out = $("#refly-files"); out.textContent = "";
    for (const text of [r.summary, ...r.notes]) { const p = document.createElement("p"); p.textContent = text; out.appendChild(p); }
    if (r.lines) L.refly.getSource().addFeatures(geojson.readFeatures(r.lines, { dataProjection: WGS84, featureProjection: WEB }));
    for (const name of r.files) {
      const a = document.createElement("a");
      a.href = `/api/plans/${r.plan_id}/files/${encodeURIComponent(name)}`; a.textContent = name; a.setAttribute("download", name);
      a.dataset.file = name; out.append(a, " ");
    }
    setStatus(kind === "refly" ? "re-fly mission ready" : "the rest of the flight is ready");
  } catch (e) { box.textContent = e.message; setStatus(`the ${kind === "refly" ? "re-fly" : "resumed"} mission could not be made`); }
}

// ---- spec files ------------------------------------------------------------------------------
function downloadBlob(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob); a.download = name; a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}
async function downloadToml() {
  try {
    const blob = await api("POST", "/api/spec/toml", planBody());  // with drawn zones: a zip of the TOML and their GeoJSON
    downloadBlob(blob, `${(S.spec.mission || {}).name || "mission"}.${blob.type === "application/zip" ? "zip" : "toml"}`);
  } catch (e) { showError(e.key, e.message); }
}
function downloadDrawn() {
  const text = geojson.writeFeatures(edit.getFeatures(), TO_WGS84);
  downloadBlob(new Blob([text], { type: "application/geo+json" }), `${(S.spec.mission || {}).name || "mission"}-drawn.geojson`);
}
async function saveSpec() {
  try {
    const r = await api("POST", "/api/spec/save", planBody());
    $("#save-status").textContent = `saved to ${r.saved}` + (r.geometry.length ? ` with ${r.geometry.join(", ")}` : "");
    S.spec = r.spec; S.zones = null; S.preview = r.preview; S.touched.clear();
    schedule();  // the plan of the saved file (the same mission), which a re-fly starts from
  } catch (e) { showError(e.key, e.message); $("#save-status").textContent = ""; }
}

// ---- a campaign (serve --campaign): its blocks coloured by status, each opening its plan (read-only) -----------
const STATUS_COLOURS = { failed: "#757575", "rules-fail": "#c62828", planned: "#1565c0", uploaded: "#00838f", flown: "#ef6c00",
  compliance: "#f9a825", "re-fly": "#6a1b9a", qa: "#00897b", accepted: "#2e7d32" };
function statusColour(status) { return STATUS_COLOURS[status] || "#455a64"; }
/** A block: its status's colour (filled faintly), thicker when opened, its name once zoomed in. */
function blockStyle(f, resolution) {
  const c = statusColour(f.get("status")), open = S.block && S.block.name === f.get("name");
  return new olb.Style({
    stroke: new olb.Stroke({ color: c, width: open ? 4 : 2 }), fill: new olb.Fill({ color: `${c}${open ? "66" : "33"}` }),
    text: resolution < 5 ? new olb.Text({ text: f.get("name"), font: "11px system-ui, sans-serif", fill: new olb.Fill({ color: "#1d2630" }),
      stroke: new olb.Stroke({ color: "#fff", width: 3 }) }) : undefined,
  });
}
const blockRouteStyle = new olb.Style({ stroke: new olb.Stroke({ color: "#1d2630", width: 2, lineDash: [6, 3] }) });

async function startCampaign() {
  const c = await api("GET", "/api/campaign");
  S.campaign = c;
  L.campaign = vector("campaign", blockStyle, 1);
  L.blockRoute = vector("block-route", blockRouteStyle, 9);
  map.addLayer(L.campaign); map.addLayer(L.blockRoute);
  L.campaign.getSource().addFeatures(geojson.readFeatures(c.blocks, { dataProjection: WGS84, featureProjection: WEB }));
  const toggle = $("#layer-toggles input[data-layer='campaign']");
  toggle.closest("label").hidden = false;
  toggle.addEventListener("change", () => L.campaign.setVisible(toggle.checked));
  $("#campaign-name").textContent = `Campaign ${c.name}: ${c.blocks.features.length} blocks`;
  const legend = $("#campaign-legend"); legend.textContent = "";
  for (const status of c.statuses) {
    const li = document.createElement("li"), sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = statusColour(status);
    li.dataset.status = status;
    li.append(sw, `${status} ${c.counts[status]}`);
    legend.appendChild(li);
  }
  const sel = $("#campaign-block"); sel.textContent = "";
  const none = document.createElement("option"); none.value = ""; none.textContent = "(choose a block)"; sel.appendChild(none);
  for (const f of c.blocks.features) {
    const o = document.createElement("option");
    o.value = f.properties.name; o.textContent = `${f.properties.name} (${f.properties.status})`;
    sel.appendChild(o);
  }
  sel.addEventListener("change", () => { if (sel.value) openBlock(sel.value); });
  map.on("click", (e) => {
    if (S.tool !== "edit") return;
    const f = map.forEachFeatureAtPixel(e.pixel, (x) => x, { layerFilter: (l) => l === L.campaign });
    if (f) openBlock(f.get("name"));
  });
  $("#tabs button[data-tab='campaign']").hidden = false;
  showTab("campaign");
  if (!S.spec.area) map.getView().fit(L.campaign.getSource().getExtent(), { padding: [30, 30, 30, 30] });
}

/** A block's plan from its folder: its summary, its files to download and its route (mission.waypoints) on the map. */
async function openBlock(name) {
  const err = $(".err[data-for='campaign']"); err.textContent = "";
  const box = $("#block-plan"); box.textContent = "";
  L.blockRoute.getSource().clear();
  const f = L.campaign.getSource().getFeatures().find((x) => x.get("name") === name);
  S.block = { name };
  L.campaign.changed();
  $("#campaign-block").value = name;
  const p = f.getProperties();
  const dl = document.createElement("dl");
  const rows = [["block", name], ["status", p.status], ["next", p.next || "nothing: accepted"]];
  if (p.message) rows.push(["message", p.message]);
  if (p.status !== "failed") rows.push(["plan", `${p.area_ha.toFixed(1)} ha, ${p.photos} photos, ${p.time_min.toFixed(1)} min, ${p.sorties} sorties`]);
  if (p.rules_failing) rows.push(["rules failing", p.rules_failing]);
  for (const [k, v] of rows) { const dt = document.createElement("dt"), dd = document.createElement("dd"); dt.textContent = k; dd.textContent = v; dl.append(dt, dd); }
  box.appendChild(dl);
  map.getView().fit(f.getGeometry().getExtent(), { padding: [40, 40, 40, 40], maxZoom: 18, duration: 0 });
  try {
    S.block = await api("GET", `/api/campaign/blocks/${encodeURIComponent(name)}`);
  } catch (e) {
    err.textContent = e.message;
    return;
  }
  const ul = document.createElement("ul");
  for (const file of S.block.files) {
    const li = document.createElement("li"), a = document.createElement("a");
    a.href = `/api/campaign/blocks/${encodeURIComponent(name)}/files/${encodeURIComponent(file)}`;
    a.textContent = file; a.setAttribute("download", file); a.dataset.file = file;
    li.appendChild(a); ul.appendChild(li);
  }
  box.append(`files of blocks/${S.block.folder}:`, ul);
  if (S.block.route) {
    L.blockRoute.getSource().addFeature(geojson.readFeature({ type: "Feature", geometry: S.block.route, properties: { name } },
      { dataProjection: WGS84, featureProjection: WEB }));
  }
}

// ---- tabs ----------------------------------------------------------------------------------------
function showTab(name) {
  for (const b of $$("#tabs button")) { b.classList.toggle("on", b.dataset.tab === name); b.setAttribute("aria-selected", String(b.dataset.tab === name)); }
  for (const t of $$(".tab")) t.hidden = t.dataset.tab !== name;
}

// ---- start -----------------------------------------------------------------------------------
async function start() {
  const st = await api("GET", "/api/state");
  S.spec = st.spec || {};
  S.specPath = st.spec_path;
  S.preview = st.preview;
  S.basemap = st.basemap;
  S.lan = Boolean(st.lan);
  S.campaignName = st.campaign;  // serve --campaign: its blocks are shown once the page has started
  S.defaults = st.defaults;
  const saved = localStorage.getItem("aerosurvey.tileUrl");
  S.tileUrl = st.tile_url || saved || "";
  $("#tile-url").value = S.tileUrl;
  updateBasemap();
  const sel = $("#camera-select");
  for (const c of st.cameras) {
    const o = document.createElement("option");
    o.value = c.id; o.textContent = `${c.id} (${c.focal_mm} mm, ${c.pixel_pitch_um} µm)`; o.title = c.name;
    sel.appendChild(o);
  }
  const inline = document.createElement("option"); inline.value = "__inline__"; inline.textContent = "inline camera from the spec"; inline.disabled = true;
  sel.appendChild(inline);
  buildPatternBox(st.patterns);
  const pbox = $("#profiles");
  for (const p of st.profiles) {
    const l = document.createElement("label"); l.style.justifyContent = "flex-start";
    const cb = document.createElement("input"); cb.type = "checkbox"; cb.value = p.id;
    l.append(cb, ` ${p.id}`); l.title = `${p.name} (${p.rules} rules)`;
    pbox.appendChild(l);
  }
  if (S.specPath) { $("#save-spec").hidden = false; $("#save-spec").textContent = `Save to ${S.specPath.split("/").pop()}`; $("#save-spec").title = S.specPath; }
  fillForm();
  showTab(S.spec.area ? "fly" : "setup");

  for (const el of $$("[data-key]")) el.addEventListener(el.tagName === "SELECT" || el.dataset.type === "bool" ? "change" : "input", () => onField(el));
  for (const r of $$("input[name=target-mode]")) r.addEventListener("change", onTarget);
  $("#target-value").addEventListener("input", onTarget);
  $("#heading-auto").addEventListener("change", onHeading);
  $("#heading-value").addEventListener("input", onHeading);
  $("#battery-on").addEventListener("change", onBattery);
  $("#profiles").addEventListener("change", onProfiles);
  $("#cancel").addEventListener("click", () => { if (S.job) api("DELETE", `/api/jobs/${S.job}`).catch(() => {}); });
  $("#download-toml").addEventListener("click", downloadToml);
  $("#download-drawn").addEventListener("click", downloadDrawn);
  $("#save-spec").addEventListener("click", saveSpec);
  $("#make-refly").addEventListener("click", () => nextFlight("refly"));
  $("#make-resume").addEventListener("click", () => nextFlight("resume"));
  for (const b of $$("#tabs button")) b.addEventListener("click", () => showTab(b.dataset.tab));
  $("#area-file").addEventListener("change", (e) => { if (e.target.files[0]) uploadArea(e.target.files[0]); e.target.value = ""; });
  $("#flight-files").addEventListener("change", (e) => { loadFlight(Array.from(e.target.files)); e.target.value = ""; });
  $("#pick-area").addEventListener("click", () => $("#area-file").click());  // the file inputs are hidden: buttons open them
  $("#pick-flight").addEventListener("click", () => $("#flight-files").click());
  $("#pick-dem").addEventListener("click", () => $("#dem-file").click());
  $("#dem-file").addEventListener("change", (e) => { if (e.target.files[0]) uploadDem(e.target.files[0]); e.target.value = ""; });
  const drop = $("#drop");
  drop.addEventListener("keydown", (e) => {  // the drop zone itself, focused: Enter or Space picks a file
    if (e.target === drop && (e.key === "Enter" || e.key === " ")) { e.preventDefault(); $("#area-file").click(); }
  });
  for (const t of ["dragenter", "dragover"]) drop.addEventListener(t, (e) => { e.preventDefault(); drop.classList.add("over"); });
  for (const t of ["dragleave", "drop"]) drop.addEventListener(t, (e) => { e.preventDefault(); drop.classList.remove("over"); });
  drop.addEventListener("drop", (e) => { const f = e.dataTransfer.files[0]; if (f) uploadArea(f); });
  $("#tile-url").addEventListener("change", () => {
    const v = $("#tile-url").value.trim();
    const box = $(".err[data-for='tiles']"); box.textContent = "";
    if (v && !xyzTemplate(v)) { box.textContent = `${v} is not a tile URL template: it needs {z}, {x} and {y} (XYZ) or {TileMatrix}, {TileCol} and {TileRow} (WMTS REST)`; return; }
    S.tileUrl = v; localStorage.setItem("aerosurvey.tileUrl", v); updateBasemap();
  });
  for (const cb of $$("#layer-toggles input[data-layer]")) {
    const layers = cb.dataset.layer === "basemap" ? [L.basemap, L.vbasemap] : [L[cb.dataset.layer]];
    cb.addEventListener("change", () => layers.forEach((l) => l.setVisible(cb.checked)));
  }
  for (const b of $$("#tools [data-tool]")) b.addEventListener("click", () => setTool(b.dataset.tool));
  $("#undo").addEventListener("click", undo);
  $("#redo").addEventListener("click", redo);
  document.addEventListener("keydown", (e) => {  // while drawing: Escape abandons the drawing, Backspace removes its last point
    if (!draw || e.ctrlKey || e.metaKey || ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement.tagName)) return;
    if (e.key === "Escape") draw.abortDrawing();
    if (e.key === "Backspace") { e.preventDefault(); draw.removeLastPoint(); }
  });
  document.addEventListener("keydown", (e) => {
    if (!(e.ctrlKey || e.metaKey) || ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement.tagName)) return;
    if (e.key === "z" && !e.shiftKey) { e.preventDefault(); undo(); }
    if (e.key === "y" || (e.key === "z" && e.shiftKey)) { e.preventDefault(); redo(); }
  });
  map.on("pointermove", onPointer);
  $("#make-brief").addEventListener("click", makeBrief);
  vehicleStart().catch((e) => showError("vehicle", e.message));  // the page starts whatever the vehicle's state
  map.on("click", (e) => { if (S.tool === "delete") deleteAt(e.pixel); else if (S.tool === "start") startAt(e.pixel); });
  setTool("edit");

  loadEditable();  // the spec's area on the map before its first plan arrives; without one, the first drawing can be undone
  S.planned = { spec: structuredClone(S.spec), zones: null, drawn: snapshot() };  // what a cancelled first plan goes back to
  if (S.spec.area) {
    fitAll(); noteFirstMap();
    replan();
  } else {
    setStatus("draw an area or drop an area file to start");
    const b = S.basemap && S.basemap.bounds;  // a page without a spec opens over its offline basemap
    if (b) map.getView().fit([...olb.fromLonLat([b[0], b[1]]), ...olb.fromLonLat([b[2], b[3]])], { maxZoom: S.basemap.maxzoom });
  }
}

start().then(() => S.campaignName && startCampaign()).catch((e) => { setStatus("could not start"); showError(null, e.message); });
