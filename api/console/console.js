// The operator console: one page, no build step, no library, nothing fetched from outside the
// service. Every action is a call to the REST API with the signed-in token; the API decides what
// the token may do (the console only hides what the role cannot use).
"use strict";

const ROLE_ORDER = ["viewer", "operator", "rig-operator", "admin"];
const LIVE_GROUPS = [
  // [title, unit, [[channel key, label, scale]]]
  ["Joint torque and load torque", "kN·m", [["torque", "T", 1e-3], ["torque_load", "τL", 1e-3]]],
  ["Joint angle", "rad", [["q", "q", 1]]],
  ["Motor currents", "A", [["i_m1", "i1", 1], ["i_m2", "i2", 1], ["i_m3", "i3", 1]]],
  ["Motor speeds", "rad/s", [["w_m1", "w1", 1], ["w_m2", "w2", 1], ["w_m3", "w3", 1]]],
  ["Hydraulic pressure", "bar", [["p_hyd", "p", 1e-5]]],
];
const COLORS = ["#1f5fbf", "#c0392b", "#1e7b34", "#8e44ad", "#d35400", "#16a085"];
const LIVE_WINDOW = 3000;          // points kept per live series

const state = { token: sessionStorage.getItem("rig-token") || "", me: null, acqs: [],
                acqId: null, stream: null, runsOffset: 0, run: null, kinds: {} };

const $ = (id) => document.getElementById(id);
const el = (tag, attrs = {}, ...kids) => {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") e.className = v; else if (k === "text") e.textContent = v;
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
  }
  for (const k of kids) e.append(k);
  return e;
};
const fmt = (v, d = 4) => (v === null || v === undefined) ? "—"
  : (typeof v === "number" ? Number(v.toPrecision(d)).toString() : String(v));
const hasRole = (need) => state.me && ROLE_ORDER.indexOf(state.me.role) >= ROLE_ORDER.indexOf(need);

// --- the API ---------------------------------------------------------------------------------
class ApiError extends Error {
  constructor(status, body) { super(ApiError.text(status, body)); this.status = status; this.body = body; }
  static text(status, body) {
    const d = body && body.detail;
    if (Array.isArray(d)) return d.map((e) => `${(e.loc || []).join(".")}: ${e.msg}`).join("\n");
    return `${status}: ${typeof d === "string" ? d : JSON.stringify(body)}`;
  }
}

async function api(path, opts = {}) {
  const headers = Object.assign({ Authorization: `Bearer ${state.token}` }, opts.headers || {});
  if (opts.json !== undefined) { headers["Content-Type"] = "application/json"; opts.body = JSON.stringify(opts.json); }
  const r = await fetch(path, { method: opts.method || "GET", headers, body: opts.body });
  if (opts.raw) { if (!r.ok) throw new ApiError(r.status, await r.json().catch(() => null)); return r; }
  const body = r.status === 204 ? null : await r.json().catch(() => null);
  if (!r.ok) { if (r.status === 401) signOut("the token was refused (401): sign in again"); throw new ApiError(r.status, body); }
  return body;
}

// --- a small line plot on a canvas ---------------------------------------------------------
class Plot {
  constructor(parent, title, unit, labels, opts = {}) {
    this.unit = unit; this.labels = labels; this.opts = opts;
    this.series = labels.map(() => ({ x: [], y: [] }));
    this.canvas = el("canvas");
    this.legend = el("div", { class: "legend" }, ...labels.map((l, i) =>
      el("span", { style: `color:${COLORS[i % COLORS.length]}`, text: `■ ${l}` })));
    this.box = el("div", { class: "plot" }, el("h4", { text: `${title} [${unit}]` }), this.canvas, this.legend);
    parent.append(this.box);
    this.marks = [];          // [[x, label]] vertical markers (phases)
    this.xlim = null;
    if (opts.onZoom) this.enableZoom(opts.onZoom);
  }
  push(i, x, y) {
    const s = this.series[i]; s.x.push(x); s.y.push(y);
    if (s.x.length > LIVE_WINDOW) { s.x.splice(0, s.x.length - LIVE_WINDOW); s.y.splice(0, s.y.length - LIVE_WINDOW); }
  }
  set(i, xs, ys) { this.series[i] = { x: xs, y: ys }; }
  points() { return this.series.reduce((n, s) => n + s.x.length, 0); }
  enableZoom(onZoom) {
    let x0 = null;
    const xAt = (ev) => { const r = this.canvas.getBoundingClientRect(); return this.invX(ev.clientX - r.left); };
    this.canvas.addEventListener("mousedown", (ev) => { x0 = xAt(ev); });
    this.canvas.addEventListener("mouseup", (ev) => {
      if (x0 === null) return; const x1 = xAt(ev);
      if (Math.abs(x1 - x0) > 1e-9) onZoom(Math.min(x0, x1), Math.max(x0, x1)); x0 = null;
    });
    this.canvas.addEventListener("dblclick", () => onZoom(null, null));
  }
  draw() {
    const c = this.canvas, dpr = window.devicePixelRatio || 1;
    const w = c.clientWidth || 400, h = c.clientHeight || 200;
    if (c.width !== w * dpr || c.height !== h * dpr) { c.width = w * dpr; c.height = h * dpr; }
    const g = c.getContext("2d"); g.setTransform(dpr, 0, 0, dpr, 0, 0); g.clearRect(0, 0, w, h);
    let xmin = Infinity, xmax = -Infinity, ymin = Infinity, ymax = -Infinity;
    for (const s of this.series) for (let k = 0; k < s.x.length; k++) {
      const y = s.y[k]; if (y === null || !isFinite(y)) continue;
      if (s.x[k] < xmin) xmin = s.x[k]; if (s.x[k] > xmax) xmax = s.x[k];
      if (y < ymin) ymin = y; if (y > ymax) ymax = y;
    }
    const L = 56, R = 8, T = 6, B = 20;
    this.frame = { L, R, T, B, w, h, xmin, xmax };
    g.strokeStyle = "#d5d9e0"; g.strokeRect(L, T, w - L - R, h - T - B);
    if (!isFinite(xmin)) { g.fillStyle = "#5d6677"; g.fillText("no data yet", L + 8, T + 16); return; }
    if (xmax === xmin) xmax = xmin + 1;
    if (ymax === ymin) { ymax += 1; ymin -= 1; }
    const pad = 0.05 * (ymax - ymin); ymin -= pad; ymax += pad;
    const X = (x) => L + (x - xmin) / (xmax - xmin) * (w - L - R);
    const Y = (y) => T + (ymax - y) / (ymax - ymin) * (h - T - B);
    this.frame.X = X;
    g.fillStyle = "#5d6677"; g.font = "11px sans-serif";
    for (let k = 0; k <= 4; k++) {
      const yv = ymin + k * (ymax - ymin) / 4, yy = Y(yv);
      g.fillText(fmt(yv, 3), 2, yy + 4); g.strokeStyle = "#eef0f4";
      g.beginPath(); g.moveTo(L, yy); g.lineTo(w - R, yy); g.stroke();
    }
    g.fillText(`${fmt(xmin, 4)} s`, L, h - 6); g.fillText(`${fmt(xmax, 4)} s`, w - R - 60, h - 6);
    g.strokeStyle = "#aab"; g.setLineDash([3, 3]);
    for (const [mx, lab] of this.marks) {
      if (mx < xmin || mx > xmax) continue; const xx = X(mx);
      g.beginPath(); g.moveTo(xx, T); g.lineTo(xx, h - B); g.stroke(); g.fillText(lab, xx + 2, T + 10);
    }
    g.setLineDash([]);
    this.series.forEach((s, i) => {
      g.strokeStyle = COLORS[i % COLORS.length]; g.lineWidth = 1.3; g.beginPath();
      let pen = false;
      for (let k = 0; k < s.x.length; k++) {
        const y = s.y[k]; if (y === null || !isFinite(y)) { pen = false; continue; }
        if (pen) g.lineTo(X(s.x[k]), Y(y)); else { g.moveTo(X(s.x[k]), Y(y)); pen = true; }
      }
      g.stroke();
    });
  }
  invX(px) { const f = this.frame; if (!f) return 0; return f.xmin + (px - f.L) / (f.w - f.L - f.R) * (f.xmax - f.xmin); }
}

// --- sign-in, tabs, role ----------------------------------------------------------------------
async function signIn(token) {
  state.token = token;
  try { state.me = await api("/me"); }
  catch (e) { state.token = ""; $("signin-error").textContent = `Sign-in refused: ${e.message}`; return; }
  sessionStorage.setItem("rig-token", token);
  $("signin").hidden = true; $("tabs").hidden = false; $("signout").hidden = false;
  $("who").textContent = `${state.me.name} · ${state.me.role}`;
  $("who").dataset.role = state.me.role;
  for (const e of document.querySelectorAll("[data-needs]")) if (!hasRole(e.dataset.needs)) e.remove();
  showTab("live");
  pollAcquisitions();
  setInterval(pollAcquisitions, 2000);
  setInterval(redrawLive, 250);
}

function signOut(why) {
  sessionStorage.removeItem("rig-token");
  if (why) sessionStorage.setItem("rig-signout", why);
  location.reload();
}

function showTab(name) {
  for (const s of document.querySelectorAll("section.tab")) s.hidden = s.id !== name;
  for (const b of document.querySelectorAll("nav button")) b.classList.toggle("active", b.dataset.tab === name);
  if (name === "runs") loadRuns();
  if (name === "jobs") loadJobs();
  if (name === "schemes") buildSchemeForm();
}

function banner(text, bad = false) {
  const b = $("banner"); b.hidden = !text; b.textContent = text || ""; b.classList.toggle("bad", bad);
}

// --- live view --------------------------------------------------------------------------------
const live = { plots: [], t0: null, lastEvent: 0, away: null };

function buildLivePlots() {
  const box = $("live-plots"); box.replaceChildren();
  live.twin = new Plot(box, "Live twin: joint torque measured vs the rig model's prediction", "kN·m",
                       ["measured", "predicted", "residual"]);
  live.twin.box.id = "twin-plot";
  live.plots = LIVE_GROUPS.map(([title, unit, chans]) =>
    ({ plot: new Plot(box, title, unit, chans.map((c) => c[1])), chans }));
  loadRigModel();
}

async function loadRigModel() {
  try {
    state.rigModel = await api("/rig-model");
    $("rig-model").textContent = `rig model: fit ${state.rigModel.fit_id} (${state.rigModel.model}, ${state.rigModel.method}), marked by ${state.rigModel.marked_by}`;
  } catch (e) {
    state.rigModel = null;
    $("rig-model").textContent = "no rig model marked (mark a fit on the Jobs tab): the live twin is off";
  }
}

function redrawLive() {
  if ($("live").hidden) return;
  rigStaleCheck();
  for (const p of live.plots) p.plot.draw();
  if (live.twin) { live.twin.draw(); $("twin-plot").dataset.points = String(live.twin.points()); }
  $("live-plots").dataset.points = String(live.plots.reduce((n, p) => n + p.plot.points(), 0));
}

const ACTIVE = ["starting", "running", "stopping"];

async function pollAcquisitions() {
  try { state.acqs = await api("/acquisitions"); } catch (e) { return; }
  const sel = $("acq-select"), cur = sel.value;
  sel.replaceChildren(...state.acqs.map((a) => el("option", { value: a.id,
    text: `scheme ${a.scheme} · ${a.target} · ${a.state}${a.run_id ? " · run " + a.run_id : ""}` })));
  $("estop").disabled = !state.acqs.some((a) => ACTIVE.includes(a.state));
  const active = state.acqs.find((a) => ACTIVE.includes(a.state));
  const want = (active && active.id !== state.acqId && (!state.acqId || !ACTIVE.includes(acqState(state.acqId))))
    ? active.id : (cur || (state.acqs[0] && state.acqs[0].id));
  if (want) sel.value = want;
  if (want && want !== state.acqId) follow(want);
  else if (state.acqId) {
    // the list is the fallback truth: a state the event stream has not delivered (e.g. the end of
    // a run while the stream was reconnecting) is shown from it
    const cur = state.acqs.find((a) => a.id === state.acqId);
    if (cur && $("acq-state").textContent !== cur.state) showAcq(cur);
  }
}

function acqState(id) { const a = state.acqs.find((x) => x.id === id); return a ? a.state : null; }

function showAcq(a) {
  const s = $("acq-state"); s.textContent = a.state; s.className = `pill ${a.state}`;
  $("acq-run").replaceChildren();
  if (a.run_id) $("acq-run").append(el("a", { href: "#", text: `run ${a.run_id}`, onclick: (ev) => { ev.preventDefault(); showTab("runs"); openRun(a.run_id); } }));
  if (a.state === "ended") {
    $("acq-run").append(` ended ${a.run_status || ""}${a.reason ? " — " + a.reason : ""}`);
    $("acq-run").dataset.final = a.run_status || "";
    $("acq-run").dataset.reason = a.reason || "";
    if (a.run_id && state.rigModel && hasRole("operator"))
      $("acq-run").append(" ", el("button", { id: "diagnose-run", text: "Diagnose against the rig model",
        onclick: () => diagnoseAgainstRigModel(a.run_id) }));
  }
  const stop = $("stop"); if (stop) stop.disabled = !ACTIVE.includes(a.state);
  if (!ACTIVE.includes(a.state)) {   // not live: the last known rig state, the newest one seen
    const r = a.progress && a.progress.rig;
    showRigState(r && (!rigView.state || r.at >= rigView.state.at) ? r : null, false);
  }
  const rows = [["target", a.target], ["operator", a.operator], ["parameters", JSON.stringify(a.params)],
                ["stand-in", a.standin ? JSON.stringify(a.standin) : "—"], ["requests", (a.requests || []).map((r) => `${r.command} by ${r.by}${r.at ? " at " + r.at : ""}`).join("; ") || "—"]];
  $("acq-details").replaceChildren(...rows.map(([k, v]) => el("tr", {}, el("td", { text: k }), el("td", { text: v }))));
}

// --- the rig's state: PLC, drives, interlocks, e-stop latch (every progress event carries it) ---
const PLC_MODE_LEVEL = { run: "ok", ready: "ok", startup: "warn", safe: "bad" };
const PLC_BITS_SHOWN = ["pump_running", "cooling_on", "homing", "homed", "drives_stopped", "fault_latched", "watchdog_fault"];
const RIG_STALE_MS = 2000;        // no event for this long while running: the panel says it is not live
const rigView = { state: null, received: 0, sig: "" };

const lamp = (kind, name, text, level, stateText, title) => el("span", { class: `lamp ${level}`, "data-kind": kind,
  "data-name": name, "data-state": stateText, "data-level": level, title: title || "", text });

function drawRigState(r) {
  const plc = r.plc;
  const plcLamps = [
    lamp("plc", "mode", `mode ${plc.mode}`, plc.link ? (PLC_MODE_LEVEL[plc.mode] || "warn") : "bad", plc.mode,
         `plc_mode ${plc.mode_code}, status word 0x${(plc.status_bits || 0).toString(16).padStart(4, "0")}`),
    lamp("plc", "fault", `fault ${plc.fault}`, plc.fault_code ? "bad" : (plc.fault_code === 0 ? "ok" : "warn"), plc.fault),
    lamp("plc", "link", plc.link ? "link" : "link down", plc.link ? "ok" : "bad", plc.link ? "up" : "down",
         plc.age_s === null ? "no status yet" : `latest status ${fmt(plc.age_s, 2)} s old`),
    lamp("plc", "safe", r.safe ? "rig safe (latched)" : "rig armed", r.safe ? "bad" : "ok", r.safe ? "safe" : "armed"),
    ...PLC_BITS_SHOWN.filter((b) => plc.bits[b]).map((b) =>
      lamp("plc-bit", b, b.replace(/_/g, " "), ["drives_stopped", "fault_latched", "watchdog_fault"].includes(b) ? "bad" : "ok", "set")),
  ];
  $("rs-plc").replaceChildren(...plcLamps);
  $("rs-drives").replaceChildren(...(r.drives.length ? r.drives.map((d) => lamp("drive", `m${d.motor}`,
    `M${d.motor} ${d.active ? d.state : "dropped"}`, d.fault || !d.active ? "bad" : (d.enabled ? "ok" : "warn"), d.state,
    `node ${d.node_id}, statusword ${d.statusword === null ? "—" : "0x" + d.statusword.toString(16).padStart(4, "0")}` +
    `${d.temperature === null ? "" : ", " + fmt(d.temperature, 3) + " °C"}${d.dropped_reason ? ", dropped: " + d.dropped_reason : ""}`))
    : [el("span", { class: "hint", text: "no drives configured" })]));
  $("rs-interlocks").replaceChildren(...r.interlocks.map((i) => lamp("interlock", i.name,
    i.tripped ? `${i.name} TRIPPED` : i.name, i.tripped ? "bad" : "ok", i.tripped ? "tripped" : "ok", i.message || "")));
  const e = $("rs-estop");
  e.dataset.latched = String(r.estop_latched);
  e.className = `latch ${r.estop_latched ? "bad" : "ok"}`;
  e.textContent = r.estop_latched ? `E-STOP LATCHED${r.estop_reason ? " — " + r.estop_reason : ""}` : "E-stop released";
}

// Shows the rig's state `r` (null: none known). live: it came from a running acquisition just now.
function showRigState(r, live) {
  if (r) {
    const sig = JSON.stringify(r, (k, v) => (k === "at" || k === "age_s") ? undefined : v);
    if (sig !== rigView.sig) { rigView.sig = sig; drawRigState(r); }
    rigView.state = r;
  }
  setRigLive(live);
}

function setRigLive(live) {
  const box = $("rig-state"), r = rigView.state;
  box.dataset.live = String(!!(live && r));
  if (!r) { $("rs-live").textContent = "no acquisition has reported the rig's state since the service started"; return; }
  const when = new Date(r.at * 1000).toLocaleTimeString();
  $("rs-live").textContent = live ? `live · ${when}` : `NOT LIVE — last known state at ${when}`;
}

function rigStaleCheck() {
  if (!rigView.state) return;
  setRigLive(ACTIVE.includes($("acq-state").textContent) && Date.now() - rigView.received < RIG_STALE_MS);
}

function onProgress(p) {
  if (p.sent_at) {          // the event's delivery latency (one machine, one clock), kept for the load bench
    (window.__latencies = window.__latencies || []).push(Date.now() / 1000 - p.sent_at);
    (window.__received = window.__received || []).push(Date.now() / 1000);
    if (window.__latencies.length > 100000) { window.__latencies.shift(); window.__received.shift(); }
  }
  if (p.rig) {
    rigView.received = Date.now();
    showRigState(p.rig, ACTIVE.includes($("acq-state").textContent));
  }
  $("acq-phase").textContent = p.phase ? `phase ${p.phase}` : "";
  $("acq-progress").value = p.fraction || 0;
  const ch = p.channels || {};
  if (p.twin && live.twin) {
    if (p.twin.measured !== undefined) live.twin.push(0, p.t, p.twin.measured * 1e-3);
    live.twin.push(1, p.t, p.twin.predicted * 1e-3);
    if (p.twin.residual !== undefined) live.twin.push(2, p.t, p.twin.residual * 1e-3);
  }
  for (const { plot, chans } of live.plots) chans.forEach(([key, , scale], i) => {
    if (key in ch && ch[key] !== null) plot.push(i, p.t, ch[key] * scale);
  });
}

async function follow(id) {
  state.acqId = id;
  if (state.stream) state.stream.abort();
  buildLivePlots();
  const ctl = new AbortController(); state.stream = ctl;
  let wait = 500;
  while (!ctl.signal.aborted) {
    try {
      const a = await api(`/acquisitions/${id}`); showAcq(a);
      const r = await fetch(`/acquisitions/${id}/events`, { headers: { Authorization: `Bearer ${state.token}` }, signal: ctl.signal });
      if (!r.ok) throw new Error(`events: ${r.status}`);
      if (live.away) { banner(`Reconnected: the live view was away from ${live.away.toLocaleTimeString()} to ${new Date().toLocaleTimeString()}; samples of that time are in the stored run.`); live.away = null; }
      wait = 500;
      const ended = await readEvents(r.body, (ev, data) => {
        if (ev === "progress") onProgress(data);
        else if (ev === "state") { const x = state.acqs.find((q) => q.id === id); if (x) { x.state = data.state; x.run_id = data.run_id; showAcq(x); } }
        else if (ev === "end") { showAcq(data); pollAcquisitions(); }
      });
      if (ended) return;
    } catch (e) {
      if (ctl.signal.aborted) return;
      if (e instanceof ApiError && e.status === 404) return;
    }
    if (ctl.signal.aborted) return;
    if (!live.away) live.away = new Date();
    banner(`Connection to the service lost at ${live.away.toLocaleTimeString()}; reconnecting…`, true);
    await new Promise((res) => setTimeout(res, wait)); wait = Math.min(wait * 2, 5000);
  }
}

// Reads a server-sent event stream; returns true after an `end` event.
async function readEvents(body, onEvent) {
  const reader = body.getReader(), dec = new TextDecoder();
  let buf = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return false;
    buf += dec.decode(value, { stream: true }).replace(/\r\n/g, "\n");
    let k;
    while ((k = buf.indexOf("\n\n")) >= 0) {
      const block = buf.slice(0, k); buf = buf.slice(k + 2);
      let ev = "message", data = "";
      for (const line of block.split("\n")) {
        if (line.startsWith("event:")) ev = line.slice(6).trim();
        else if (line.startsWith("data:")) data += line.slice(5).trim();
      }
      if (!data) continue;
      let parsed; try { parsed = JSON.parse(data); } catch (e) { continue; }
      onEvent(ev, parsed);
      if (ev === "end") return true;
    }
  }
}

async function estopAll() {
  // An e-stop must get through: a request lost on a connection that just dropped (a POST is never
  // retried by the browser itself) is sent again, up to 10 times over ~3 s, and a failure is said.
  const targets = state.acqs.filter((a) => ACTIVE.includes(a.state));
  const reason = `e-stop from the console by ${state.me ? state.me.name : "?"}`;
  const send = async (a) => {
    let last = null;
    for (let k = 0; k < 10; k++) {
      try { await api(`/acquisitions/${a.id}/estop`, { method: "POST", json: { reason } }); return null; }
      catch (e) { last = e; if (e instanceof ApiError && e.status !== 503) break; }
      await new Promise((res) => setTimeout(res, 300));
    }
    return `acquisition ${a.id.slice(0, 8)}: ${last ? last.message : "no answer"}`;
  };
  const failed = (await Promise.all(targets.map(send))).filter(Boolean);
  const when = new Date().toLocaleTimeString();
  if (failed.length) banner(`E-STOP FAILED at ${when} for ${failed.join("; ")} — use the rig's hardware e-stop`, true);
  else banner(`E-STOP sent to ${targets.length} acquisition(s) at ${when}.`, true);
  pollAcquisitions();
}

// --- run a scheme -----------------------------------------------------------------------------
let openapi = null;

function resolve(schema) {
  if (schema && schema.$ref) return openapi.components.schemas[schema.$ref.split("/").pop()];
  if (schema && schema.allOf && schema.allOf.length === 1) return resolve(schema.allOf[0]);
  return schema;
}

async function buildSchemeForm() {
  if (!openapi) openapi = await (await fetch("/openapi.json")).json();
  const n = $("scheme-select").value;
  const op = openapi.paths[`/schemes/${n}/runs`].post;
  const req = resolve(op.requestBody.content["application/json"].schema);
  const params = resolve(req.properties.params);
  const emu = resolve(req.properties.emulator);
  $("scheme-doc").textContent = params.description || "";
  const form = $("scheme-form"); form.replaceChildren();
  const field = (group, name, sch, value) => {
    const s = resolve(sch); const type = s.type || (s.anyOf ? s.anyOf[0].type : "string");
    let input;
    if (s.enum) input = el("select", {}, ...s.enum.map((v) => el("option", { value: v, text: v })));
    else if (type === "boolean") input = el("input", { type: "checkbox" });
    else input = el("input", { type: (type === "number" || type === "integer") ? "number" : "text", step: type === "integer" ? "1" : "any" });
    input.name = `${group}.${name}`; input.dataset.type = type;
    for (const [a, b] of [["minimum", "min"], ["maximum", "max"], ["exclusiveMinimum", "min"], ["exclusiveMaximum", "max"]]) if (s[a] !== undefined) input.setAttribute(b, s[a]);
    if (value !== undefined && value !== null) { if (type === "boolean") input.checked = !!value; else input.value = value; }
    const bounds = [s.minimum ?? s.exclusiveMinimum, s.maximum ?? s.exclusiveMaximum];
    return el("label", {}, el("span", { text: s.title || name }), input,
      el("small", { text: `${s.description || ""}${bounds[0] !== undefined || bounds[1] !== undefined ? `  (${fmt(bounds[0])} … ${fmt(bounds[1])})` : ""}` }),
      el("span", { class: "field-error", "data-for": `${group}.${name}` }));
  };
  const targets = hasRole("rig-operator") ? ["emulator", "rig"] : ["emulator"];
  form.append(el("fieldset", {}, el("legend", { text: "Run" }),
    el("label", {}, el("span", { text: "target" }), el("select", { name: "top.target" }, ...targets.map((t) => el("option", { value: t, text: t }))), el("small", { text: hasRole("rig-operator") ? "" : "the rig needs the rig-operator role" })),
    field("top", "operator", { type: "string", description: "who runs it" }, state.me.name),
    field("top", "notes", { type: "string" }, "")));
  form.append(el("fieldset", {}, el("legend", { text: `Scheme ${n} parameters` }),
    ...Object.entries(params.properties).map(([k, s]) => field("params", k, s, s.default))));
  form.append(el("fieldset", {}, el("legend", { text: "Emulator (target emulator)" }),
    ...Object.entries(emu.properties).filter(([k]) => k !== "effects").map(([k, s]) => field("emulator", k, s, s.default)),
    el("label", {}, el("span", { text: "effects" }), el("input", { name: "emulator.effects", size: 40, placeholder: "stribeck:f_s=800;time_delay:delay=0.01" }),
      el("small", { text: "NAME:k=v,k=v; separated by ‘;’ (rig params lists them)" }), el("span", { class: "field-error", "data-for": "emulator.effects" }))));
  form.append(el("button", { type: "submit", text: `Start scheme ${n}` }));
  form.onsubmit = (ev) => { ev.preventDefault(); startScheme(n); };
}

function parseEffects(text) {
  const out = {};
  for (const part of text.split(";").map((s) => s.trim()).filter(Boolean)) {
    const [name, kv = ""] = part.split(":");
    out[name.trim()] = {};
    for (const p of kv.split(",").map((s) => s.trim()).filter(Boolean)) {
      const [k, v] = p.split("="); out[name.trim()][k.trim()] = Number(v);
    }
  }
  return out;
}

async function startScheme(n) {
  const body = { params: {}, emulator: {} };
  for (const e of $("scheme-form").querySelectorAll("[name]")) {
    const [group, name] = e.name.split(".");
    let v = e.type === "checkbox" ? e.checked : e.value;
    if (name === "effects") { v = parseEffects(v); }
    else if (e.dataset.type === "number" || e.dataset.type === "integer") { if (v === "") continue; v = Number(v); }
    if (group === "top") body[name] = v; else body[group][name] = v;
  }
  for (const e of document.querySelectorAll(".field-error")) e.textContent = "";
  $("scheme-error").textContent = "";
  try {
    const a = await api(`/schemes/${n}/runs`, { method: "POST", json: body });
    showTab("live"); await pollAcquisitions(); follow(a.id); $("acq-select").value = a.id;
  } catch (e) {
    const d = e.body && e.body.detail;
    if (Array.isArray(d)) for (const x of d) {
      const loc = (x.loc || []).slice(1); const key = loc.length === 1 ? `top.${loc[0]}` : `${loc[0]}.${loc[1]}`;
      const slot = document.querySelector(`.field-error[data-for="${key}"]`);
      if (slot) slot.textContent = x.msg; else $("scheme-error").textContent += `${loc.join(".")}: ${x.msg}\n`;
    } else $("scheme-error").textContent = e.message;
  }
}

// --- runs -------------------------------------------------------------------------------------
const PAGE = 20;

async function loadRuns() {
  $("runs-list").hidden = false; $("run-page").hidden = true; $("compare-page").hidden = true;
  const f = new FormData($("runs-filter")); const q = new URLSearchParams();
  for (const [k, v] of f.entries()) if (v) q.set(k, k === "started_after" ? `${v}T00:00:00Z` : v);
  q.set("limit", PAGE); q.set("offset", state.runsOffset);
  let runs;
  try { runs = await api(`/runs?${q}`); } catch (e) { $("runs-body").replaceChildren(el("tr", {}, el("td", { class: "error", text: e.message }))); return; }
  $("runs-page").textContent = ` ${state.runsOffset + 1}–${state.runsOffset + runs.length} `;
  $("runs-next").disabled = runs.length < PAGE; $("runs-prev").disabled = state.runsOffset === 0;
  $("runs-body").replaceChildren(...runs.map((r) => {
    const box = el("input", { type: "checkbox", value: r.id, onclick: (ev) => { ev.stopPropagation(); updateCompare(); } });
    return el("tr", { class: "clickable", "data-run": r.id, onclick: () => openRun(r.id) },
      el("td", {}, box), el("td", { text: r.id }), el("td", { text: fmt(r.scheme) }),
      el("td", { text: r.started_at ? new Date(r.started_at).toLocaleString() : "—" }), el("td", { text: r.operator || "—" }),
      el("td", { text: fmt(r.motor_speed_rpm) }), el("td", { text: fmt(r.direction) }),
      el("td", { text: r.status }), el("td", { text: r.exit_status || "—" }), el("td", { text: r.n_samples }),
      el("td", { class: "na", "data-acceptance": r.id, text: r.status === "running" ? "running" : "…" }));
  }));
  updateCompare();
  // each finished run's acceptance verdict, filled in as it comes (the service caches it)
  for (const r of runs.filter((x) => x.status !== "running")) {
    api(`/runs/${r.id}/acceptance`).then((a) => {
      const td = document.querySelector(`td[data-acceptance="${r.id}"]`); if (!td) return;
      td.textContent = a.passed === null ? "not judged" : (a.passed ? "pass" : "fail");
      td.className = a.passed === null ? "na" : (a.passed ? "pass" : "fail");
    }).catch(() => {});
  }
}

function selectedRuns() { return [...$("runs-body").querySelectorAll("input:checked")].map((b) => Number(b.value)); }
function updateCompare() { $("runs-compare").disabled = selectedRuns().length < 2; }

async function fetchData(runId, channels, t0, t1, maxPoints = 2000) {
  const q = new URLSearchParams({ channels: channels.join(","), max_points: maxPoints });
  if (t0 !== null && t0 !== undefined) q.set("t_start", t0);
  if (t1 !== null && t1 !== undefined) q.set("t_end", t1);
  return api(`/runs/${runId}/data?${q}`);
}

async function openRun(id) {
  $("runs-list").hidden = true; $("compare-page").hidden = true; $("run-page").hidden = false;
  const info = await api(`/runs/${id}`);
  state.run = { id, info, channels: [], range: [null, null] };
  $("run-title").textContent = `Run ${id} · scheme ${fmt(info.scheme)} · ${info.status}${info.exit_status ? " (" + info.exit_status + ")" : ""}${info.reason ? " — " + info.reason : ""}`;
  const names = (info.channels || []).map((c) => c.name).filter((n) => n !== "t" && n !== "phase");
  const defaults = ["torque", "torque_load", "q"].filter((n) => names.includes(n));
  state.run.channels = defaults.length ? defaults : names.slice(0, 2);
  $("run-channels").replaceChildren(...names.map((n) => {
    const b = el("input", { type: "checkbox", value: n }); b.checked = state.run.channels.includes(n);
    b.onchange = () => { state.run.channels = [...$("run-channels").querySelectorAll("input:checked")].map((x) => x.value); drawRun(); };
    return el("label", {}, b, ` ${n}`);
  }));
  drawRun();
  const meta = info.meta || {};
  $("run-meta").replaceChildren(...Object.entries(meta).map(([k, v]) => el("tr", {}, el("td", { text: k }), el("td", { text: typeof v === "object" ? JSON.stringify(v) : String(v) }))));
  $("run-interruptions").replaceChildren(...((info.interruptions || []).length ? info.interruptions.map((x) =>
    el("tr", {}, el("td", { text: fmt(x.t_start ?? x.t) }), el("td", { text: x.kind || "" }), el("td", { text: x.reason || JSON.stringify(x) })))
    : [el("tr", {}, el("td", { class: "na", text: "none" }))]));
  try {
    const acc = await api(`/runs/${id}/acceptance`);
    $("run-acceptance").replaceChildren(...acc.indicators.map((i) => {
      const req = i.kind === "error" ? `max |error| ≤ ${fmt(i.tolerance)} ${i.unit}`
        : (i.kind === "range" ? `0 … ${fmt(i.required)} ${i.unit}` : `${fmt(i.required)} ${i.unit} reached`);
      const value = i.kind === "error" ? i.max_abs : i.reached;
      const result = i.status || (i.passed === null || i.passed === undefined ? "not judged" : (i.passed ? "pass" : "fail"));
      return el("tr", {}, el("td", { text: `${i.item ? i.item + ". " : ""}${i.name}` }),
        el("td", { text: `${fmt(value)} ${i.unit}` }), el("td", { text: req }),
        el("td", { class: result === "pass" ? "pass" : (result === "fail" ? "fail" : "na"), text: result }),
        el("td", { class: "na", text: i.note || "" }));
    }));
  } catch (e) { $("run-acceptance").replaceChildren(el("tr", {}, el("td", { class: "error", text: e.message }))); }
}

async function drawRun() {
  const r = state.run; const box = $("run-plot"); box.replaceChildren();
  if (!r.channels.length) return;
  const want = ["phase", ...r.channels];
  let d;
  try { d = await fetchData(r.id, want.filter((c) => (r.info.channels || []).some((x) => x.name === c)), r.range[0], r.range[1]); }
  catch (e) { box.append(el("p", { class: "error", text: e.message })); return; }
  const t = d.channels.t || [];
  const marks = [];
  if (d.channels.phase) { let prev = null; d.channels.phase.forEach((p, k) => { if (p !== prev) { marks.push([t[k], String(p)]); prev = p; } }); }
  for (const c of r.channels) {
    const plot = new Plot(box, c, unitOf(c), [c], { onZoom: (a, b) => { r.range = [a, b]; drawRun(); } });
    plot.set(0, t, d.channels[c] || []); plot.marks = marks; plot.draw();
  }
  box.dataset.points = String(t.length);
  box.dataset.capped = String(!!d.capped);
}

function unitOf(c) { const ch = (state.run && state.run.info.channels || []).find((x) => x.name === c); return (ch && ch.unit) || ""; }

async function compareRuns() {
  const ids = selectedRuns(); if (ids.length < 2) return;
  $("runs-list").hidden = true; $("compare-page").hidden = false;
  $("compare-title").textContent = ids.join(", ");
  const infos = await Promise.all(ids.map((i) => api(`/runs/${i}`)));
  const common = infos.map((i) => (i.channels || []).map((c) => c.name)).reduce((a, b) => a.filter((x) => b.includes(x)));
  const sel = $("compare-channel");
  sel.replaceChildren(...common.filter((c) => c !== "t" && c !== "phase").map((c) => el("option", { value: c, text: c })));
  if (common.includes("torque")) sel.value = "torque";
  const draw = async () => {
    const c = sel.value; const box = $("compare-plot"); box.replaceChildren();
    const plot = new Plot(box, c, "", ids.map((i) => `run ${i}`));
    const data = await Promise.all(ids.map((i) => fetchData(i, [c], null, null)));
    data.forEach((d, k) => plot.set(k, d.channels.t, d.channels[c]));
    plot.draw(); box.dataset.series = String(ids.length);
  };
  sel.onchange = draw; draw();
}

async function downloadRun() {
  const id = state.run.id;
  const r = await api(`/runs/${id}/file?format=csv`, { raw: true });  // zip: samples + metadata
  const url = URL.createObjectURL(await r.blob());
  const a = el("a", { href: url, download: `run-${id}.zip` }); document.body.append(a); a.click(); a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

async function diagnoseAgainstRigModel(runId) {
  const m = state.rigModel;
  try {
    await api("/jobs", { method: "POST", json: { kind: "diagnosis", params: {
      run_ids: m.training_run_ids.filter((i) => i !== runId), test_run_ids: [runId], model: m.model } } });
    showTab("jobs");
  } catch (e) { banner(`Diagnosis job refused: ${e.message}`, true); }
}

// --- jobs -------------------------------------------------------------------------------------
let jobsTimer = null;

async function loadJobs() {
  if (hasRole("operator") && !Object.keys(state.kinds).length) {
    state.kinds = await api("/jobs/kinds");
    $("job-kind").replaceChildren(...Object.keys(state.kinds).map((k) => el("option", { value: k, text: k })));
    $("job-kind").onchange = jobFields; jobFields();
  }
  const jobs = await api("/jobs?limit=50");
  $("jobs-body").replaceChildren(...jobs.map((j) => el("tr", { "data-job": j.id, "data-state": j.state },
    el("td", { text: j.id }), el("td", { text: j.kind }), el("td", { text: j.state + (j.error ? ` — ${j.error}` : "") }),
    el("td", {}, el("progress", { max: 1, value: j.progress || 0 })),
    el("td", { text: j.created_at ? new Date(j.created_at).toLocaleString() : "" }),
    el("td", { text: [...(j.params.run_ids || []), ...(j.params.test_run_ids || []).map((x) => `${x}*`)].join(", ") }),
    el("td", {}, ...(j.state === "succeeded" ? [el("button", { text: "Report", onclick: () => openReport(j.id) })] : []),
      ...(j.state === "succeeded" && j.kind === "identification" && hasRole("operator") && j.result_ids.length
        ? [el("button", { text: "Mark as rig model", class: "mark-model", onclick: () => api("/rig-model", { method: "PUT", json: { fit_id: j.result_ids[0] } })
            .then((m) => { state.rigModel = m; banner(`Fit ${m.fit_id} is now the rig's model (the live twin predicts with it).`); })
            .catch((e) => banner(e.message, true)) })] : []),
      ...(hasRole("operator") && ["queued", "running"].includes(j.state) ? [el("button", { text: "Cancel", onclick: () => api(`/jobs/${j.id}/cancel`, { method: "POST" }).then(loadJobs) })] : [])))));
  clearTimeout(jobsTimer);
  if (!$("jobs").hidden) jobsTimer = setTimeout(loadJobs, 2000);
}

function jobFields() {
  const k = state.kinds[$("job-kind").value]; const box = $("job-fields"); box.replaceChildren();
  if (!k) return;
  const p = k.params; const defs = p.$defs || {};
  const res = (s) => (s && s.$ref) ? defs[s.$ref.split("/").pop()] : s;
  $("job-test-runs").parentElement.hidden = !("test_run_ids" in (p.properties || {}));
  for (const [name, s0] of Object.entries(p.properties || {})) {
    if (name === "run_ids" || name === "test_run_ids") continue;
    const s = res(s0.anyOf ? s0.anyOf.find((x) => x.type !== "null") || s0 : s0) || {};
    const input = s.enum ? el("select", { name }, ...s.enum.map((v) => el("option", { value: v, text: v })))
      : el("input", { name, size: 8, placeholder: s0.default !== undefined ? String(s0.default) : "" });
    if (s.enum && s0.default !== undefined) input.value = s0.default;
    input.dataset.type = s.type || ""; box.append(el("label", { title: s0.description || "" }, `${name} `, input));
  }
}

async function submitJob(ev) {
  ev.preventDefault(); $("job-error").textContent = "";
  const ids = (s) => s.split(/[ ,]+/).filter(Boolean).map(Number);
  const params = { run_ids: ids($("job-runs").value) };
  if (!$("job-test-runs").parentElement.hidden && $("job-test-runs").value) params.test_run_ids = ids($("job-test-runs").value);
  for (const e of $("job-fields").querySelectorAll("[name]")) {
    if (e.value === "") continue;
    params[e.name] = (e.dataset.type === "number" || e.dataset.type === "integer") ? Number(e.value)
      : (e.dataset.type === "array" ? e.value.split(",").map((s) => s.trim()) : e.value);
  }
  try { await api("/jobs", { method: "POST", json: { kind: $("job-kind").value, params } }); loadJobs(); }
  catch (e) { $("job-error").textContent = e.message; }
}

async function openReport(id) {
  const r = await api(`/reports/jobs/${id}/html`, { raw: true });
  $("report-frame").srcdoc = await r.text(); $("job-report").hidden = false;
  $("job-report").dataset.job = String(id);
}

// --- wiring -----------------------------------------------------------------------------------
document.addEventListener("DOMContentLoaded", () => {
  const why = sessionStorage.getItem("rig-signout");
  if (why) { $("signin-error").textContent = why; sessionStorage.removeItem("rig-signout"); }
  $("signin-form").onsubmit = (ev) => { ev.preventDefault(); signIn($("token").value.trim()); };
  $("signout").onclick = () => signOut();
  for (const b of document.querySelectorAll("nav button")) b.onclick = () => showTab(b.dataset.tab);
  $("estop").onclick = estopAll;
  document.addEventListener("keydown", (ev) => { if (ev.key === "Escape" && !$("estop").disabled) estopAll(); });
  $("acq-select").onchange = () => follow($("acq-select").value);
  if ($("stop")) $("stop").onclick = () => api(`/acquisitions/${state.acqId}/stop`, { method: "POST" }).then(pollAcquisitions)
    .catch((e) => banner(e.message, true));
  $("scheme-select").onchange = buildSchemeForm;
  $("runs-filter").onsubmit = (ev) => { ev.preventDefault(); state.runsOffset = 0; loadRuns(); };
  $("runs-prev").onclick = () => { state.runsOffset = Math.max(0, state.runsOffset - PAGE); loadRuns(); };
  $("runs-next").onclick = () => { state.runsOffset += PAGE; loadRuns(); };
  $("runs-compare").onclick = compareRuns;
  $("run-back").onclick = loadRuns; $("compare-back").onclick = loadRuns;
  $("run-download").onclick = () => downloadRun().catch((e) => banner(e.message, true));
  if ($("run-diagnose")) $("run-diagnose").onclick = () => { showTab("jobs"); setTimeout(() => { $("job-kind").value = "diagnosis"; jobFields(); $("job-test-runs").value = String(state.run.id); }, 300); };
  if ($("job-form")) $("job-form").onsubmit = submitJob;
  $("report-close").onclick = () => { $("job-report").hidden = true; };
  if (state.token) signIn(state.token);
});
