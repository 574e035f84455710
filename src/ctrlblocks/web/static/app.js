// ctrlblocks faceplate: loop list, live trend (uPlot), operator actions, history, audit.
// Plain JS, no build step. Live data arrives over the WebSocket /ws: the page tells the
// server which loops it shows (the table rows on screen and the open faceplate) and gets
// only what changed of them; actions are POST api/loops/NAME/command (the server and the
// block validate them, and the server enforces the roles and the engineering ranges; the
// page only shows them and asks before a large step).
"use strict";

const S = {
  info: null,            // GET api/info
  user: null,            // user name or null (not logged in)
  ws: null,              // the live WebSocket (null: not connected)
  states: {},            // loop name -> state (the pushes merged: a row, or the whole state)
  words: {},             // state code -> [severity, words] (from the server's hello)
  visible: new Set(),    // loops whose table rows are on screen
  data: {},              // loop name -> {t, sp, pv, mv, man} columns (live trend)
  order: [],             // loop names in configuration order
  selected: null,
  follow: true,          // the trend follows the live data
  windowSec: 120,
  view: null,            // [min, max] of x when not following
  chart: null,
  histChart: null,
  updates: 0,            // pushes received (for tests)
  lastMessage: null,     // last action result {ok, status, text}
  dirty: new Set(),      // input ids edited by the user since the last fill
  confirming: null,      // the question of the open confirmation, or null
};
window.faceplate = S;

const MIN_SPAN = 0.05;   // trend y axes span at least this fraction of the loop's range

// which command key each control needs (the server's PERMISSIONS decide; this only shows it)
const CONTROLS = {
  mode: ["btn-auto", "btn-man"],
  manual_value: ["manual-value", "btn-manual"],
  sp: ["sp-input", "btn-sp"],
  u_min: ["umin", "umax", "btn-limits"],
  tunings: ["btn-tunings", "btn-tunings-reset"],
  tune: ["tune-start", "tune-abort", "tune-reject"],
};

const MAIN_TUNINGS = {
  PID: ["kp", "ti", "td", "n", "b", "c"],
  ADRC: ["b0", "omega_c", "omega_o", "order"],
};

const $ = (id) => document.getElementById(id);

function fmt(x) {
  if (x === null || x === undefined) return "—";
  if (typeof x !== "number") return String(x);
  const a = Math.abs(x);
  if (a >= 1000) return x.toFixed(0);
  if (a >= 100) return x.toFixed(1);
  if (a >= 1) return x.toFixed(3);
  return x.toFixed(4);
}

function fmtParam(x) {
  if (x === null || x === undefined) return "";
  if (typeof x === "number") return String(Number(x.toPrecision(8)));
  if (Array.isArray(x)) return x.join(", ");
  return String(x);
}

// ---------------------------------------------------------------- account

// the heading and the window's title for a runtime's name: "ctrlblocks demo", not
// "ctrlblocks — ctrlblocks demo" (the product's name once)
function titles(name) {
  const heading = /^ctrlblocks\b/i.test(name) ? name : "ctrlblocks — " + name;
  return [heading, heading + " · faceplate"];
}
S.titles = titles;

async function loadInfo() {
  const r = await fetch("api/info", { credentials: "same-origin" });
  S.info = await r.json();
  [$("rt-name").textContent, document.title] = titles(S.info.name);
  setUser(S.info.user, S.info.role);
  $("login-needed").hidden = S.info.may_view;
  document.querySelector("main").hidden = !S.info.may_view;
  if (S.info.may_view && !S.ws) connect();
  if (S.selected) { showRanges(); applyPermissions(); }
}

function eng(name) {
  return (S.info && S.info.engineering && S.info.engineering[name || S.selected]) || null;
}
function unit(sig, name) {
  const e = eng(name);
  return (e && e.units[sig]) || "";
}
function withUnit(x, sig, name) {
  const u = unit(sig, name);
  return u ? `${fmt(x)} ${u}` : fmt(x);
}

function setUser(user, role) {
  S.user = user;
  $("login-form").hidden = !!user;
  $("logged-in").hidden = !user;
  $("who").textContent = user || "";
  $("role").textContent = role || "";
  document.body.classList.toggle("logged-in", !!user);
  document.body.classList.toggle("operator", !!user && role !== "viewer");
  applyPermissions();
}

const ROLE_NOTES = {
  none: "Not logged in: you can only watch. Log in to change this loop.",
  viewer: "Viewer: you can only watch.",
  operator: "Operator: mode, setpoint and manual value. Limits and tuning need an engineer.",
  engineer: "",
};

function applyPermissions() {
  const may = new Set((S.info && S.info.may_change) || []);
  for (const [key, ids] of Object.entries(CONTROLS)) {
    for (const id of ids) {
      $(id).disabled = !may.has(key);
      $(id).title = may.has(key) ? "" : "your role may not change this";
    }
  }
  for (const inp of $("tunings").querySelectorAll("input")) inp.disabled = !may.has("tunings");
  for (const b of $("tune-proposals").querySelectorAll("button")) b.disabled = !may.has("tune");
  const role = (S.info && S.info.role) || "none";
  $("role-note").textContent = ROLE_NOTES[role] || "";
  $("role-note").hidden = !ROLE_NOTES[role];
  for (const id of ["history-box", "audit-box"]) $(id).hidden = !S.user;
}

$("login-form").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const r = await fetch("api/login", {
    method: "POST",
    credentials: "same-origin",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ user: $("login-user").value, password: $("login-password").value }),
  });
  const j = await r.json();
  $("login-password").value = "";
  if (r.ok) {
    await loadInfo();
    message(true, r.status, `logged in as ${j.user} (${j.role})`);
    loadAudit();
  } else {
    message(false, r.status, `login refused: ${j.error.message}`);
  }
});

$("btn-logout").addEventListener("click", async () => {
  await fetch("api/logout", { method: "POST", credentials: "same-origin" });
  await loadInfo();
  message(true, 200, "logged out");
});

// ---------------------------------------------------------------- live data

function connect() {
  const url = new URL("ws", location.href);
  url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
  const ws = new WebSocket(url);
  S.ws = ws;
  ws.onopen = () => { $("conn").textContent = "live"; $("conn").className = "conn up"; };
  ws.onclose = () => {
    S.ws = null;
    $("conn").className = "conn down";
    // not public and logged out (or the session was ended): wait for a login
    if (S.info && !S.info.public_view && !S.user) { $("conn").textContent = "not logged in"; return; }
    $("conn").textContent = "disconnected — retrying";
    setTimeout(() => { if (!S.ws) loadInfo(); }, 1000);
  };
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "hello") onHello(msg);
    else if (msg.type === "update") onUpdate(msg);
  };
}

// tell the server what is on screen: the visible rows and the open faceplate
let watchTimer = null;
function sendWatch() {
  if (watchTimer) return;
  watchTimer = setTimeout(() => {
    watchTimer = null;
    if (S.ws && S.ws.readyState === WebSocket.OPEN) {
      S.ws.send(JSON.stringify({ type: "watch", rows: [...S.visible], plate: S.selected }));
    }
  }, 50);
}

function onHello(msg) {
  S.order = msg.loops;
  S.words = msg.words || {};
  S.states = {};  // a new socket sends everything once
  buildTable();
  if (!S.selected && S.order.length) {
    select(decodeURIComponent(location.hash.slice(1)) || S.order[0]);
  }
  sendWatch();
}

function onUpdate(msg) {
  S.updates += 1;
  for (const [name, diff] of Object.entries(msg.loops)) {
    S.states[name] = Object.assign(S.states[name] || { name }, diff);
  }
  const keep = (S.info && S.info.trend_seconds) || 300;
  for (const [name, cols] of Object.entries(msg.samples)) {
    const d = S.data[name] || (S.data[name] = { t: [], sp: [], pv: [], mv: [], man: [] });
    for (const k of ["t", "sp", "pv", "mv"]) d[k].push(...cols[k]);
    d.man.push(...cols.manual);
    const tmin = d.t[d.t.length - 1] - keep;
    let cut = 0;
    while (cut < d.t.length && d.t[cut] < tmin) cut++;
    if (cut > 0) for (const k of Object.keys(d)) d[k].splice(0, cut);
  }
  renderTable(msg.loops);
  if (S.selected && msg.loops[S.selected]) renderPlate();
  else if (S.selected && msg.samples[S.selected]) updateChart();
}

// ---------------------------------------------------------------- loop list

// the loop's worst condition: "alarm", "warning", "info" or "" (nothing to say)
function worst(st) {
  const sev = (st.conditions || []).map((c) => c.severity);
  return ["alarm", "warning", "info"].find((x) => sev.includes(x)) || "";
}

// the state words of a loop, as coloured badges (the texts in their titles)
function stateBadges(el, st) {
  el.replaceChildren();
  for (const c of st.conditions || []) {
    const b = document.createElement("span");
    b.className = "st " + c.severity;
    b.dataset.code = c.code;
    b.textContent = (S.words[c.code] || [c.severity, c.code])[1];
    b.title = c.text;
    el.appendChild(b);
  }
  if (!el.childElementCount) {
    const b = document.createElement("span");
    b.className = "st ok";
    b.textContent = "ok";
    el.appendChild(b);
  }
}

function modeBadge(el, st) {
  el.textContent = st.mode === "manual" ? "MAN" : "AUTO";
  const w = worst(st);
  el.className = "mode " + st.mode + (w && w !== "info" ? " " + w : "");
}

const rowObserver = new IntersectionObserver((entries) => {
  for (const e of entries) {
    if (e.isIntersecting) S.visible.add(e.target.dataset.loop);
    else S.visible.delete(e.target.dataset.loop);
  }
  sendWatch();
});

function buildTable() {
  const tbody = $("loops").tBodies[0];
  rowObserver.disconnect();
  tbody.replaceChildren();
  S.visible.clear();
  for (const name of S.order) {
    const tr = document.createElement("tr");
    tr.dataset.loop = name;
    for (const c of ["name", "mode", "state", "pv", "sp", "mv", "block"]) {
      const td = document.createElement("td");
      td.className = c;
      tr.appendChild(td);
    }
    tr.querySelector(".name").textContent = name;
    tr.addEventListener("click", () => select(name));
    tbody.appendChild(tr);
    rowObserver.observe(tr);
  }
}

// the rows of the loops in ``diffs`` (name -> the fields that changed; all rows without it):
// only the cells whose fields changed are touched
function renderTable(diffs) {
  const tbody = $("loops").tBodies[0];
  for (const name of diffs ? Object.keys(diffs) : S.order) {
    const st = S.states[name];
    const tr = tbody.querySelector(`tr[data-loop="${CSS.escape(name)}"]`);
    if (!st || !tr) continue;
    const d = diffs ? diffs[name] : st;
    if ("conditions" in d || "mode" in d) {
      const w = worst(st);
      tr.classList.toggle("alarm", w === "alarm");
      tr.classList.toggle("warning", w === "warning");
      modeBadge(tr.querySelector(".mode"), st);
      stateBadges(tr.querySelector(".state"), st);
    }
    if ("block" in d) tr.querySelector(".block").textContent = st.block;
    for (const sig of ["sp", "pv", "mv"]) {
      if (sig in d) tr.querySelector("." + sig).textContent = withUnit(st[sig], sig, name);
    }
  }
}

// ---------------------------------------------------------------- faceplate

function select(name) {
  if (!S.order.includes(name)) name = S.order[0];
  const before = S.selected;
  S.selected = name;
  history.replaceState(null, "", "#" + encodeURIComponent(name));
  for (const tr of $("loops").tBodies[0].rows) tr.classList.toggle("selected", tr.dataset.loop === name);
  $("plate").hidden = false;
  $("plate-title").textContent = name;
  S.follow = true;
  S.dirty.clear();
  S.tunedFor = null;
  makeChart();
  setHistoryDefaults();
  if (before !== name) {
    delete S.data[name];  // its whole trend comes with the next push
    sendWatch();
  }
  if (S.states[name] && S.states[name].tunings) renderPlate();
  loadAudit();
}

function rangeText(r, u) {
  if (!r) return "";
  u = u || r.unit || "";
  const tail = u ? ` ${u}` : "";
  const inf = r.inf_ok ? " or inf" : "";
  if (r.generic) return (r.lo_open ? "> 0" : r.lo === 0 ? "≥ 0" : "any") + inf;
  const zero = r.zero_ok && r.lo > 0 ? "0 or " : "";
  const pm = r.symmetric ? "±" : "";
  if (r.integer) {
    const n = [];
    for (let k = r.lo; k <= r.hi && n.length < 6; k++) n.push(k);
    return n.length && n[n.length - 1] === r.hi ? n.join(", ") : `${r.lo} … ${r.hi}`;
  }
  const num = (x) => String(Number(x.toPrecision(4)));
  return `${zero}${pm}${num(r.lo)} … ${num(r.hi)}${tail}${inf}`;
}

function showRanges() {
  const e = eng();
  for (const sig of ["sp", "pv", "mv"]) $("u-" + sig).textContent = unit(sig);
  $("r-sp").textContent = e ? rangeText(e.sp_range, e.units.sp) : "";
  $("r-manual").textContent = e ? rangeText(e.mv_range, e.units.mv) : "";
  $("r-limits").textContent = e && e.mv_range ? "within " + rangeText(e.mv_range, e.units.mv) : "";
  for (const row of $("tunings").tBodies[0].rows) {
    row.cells[3].textContent = e ? rangeText(e.tuning_ranges[row.dataset.key], "") : "";
  }
  markOutOfRange();
}

function inRange(r, text) {
  const x = Number(text);
  return !r || text.trim() === "" || (Number.isFinite(x) && x >= r.lo && x <= r.hi);
}

// a value outside the engineering range is marked at once (the server refuses it)
function markOutOfRange() {
  const e = eng();
  for (const inp of document.querySelectorAll("input[data-range]")) {
    const r = e && (inp.dataset.range === "sp" ? e.sp_range : e.mv_range);
    inp.classList.toggle("out", !inRange(r, inp.value));
  }
}

function fillInputs(all) {
  const st = S.states[S.selected];
  if (!st) return;
  const vals = { "manual-value": st.manual_value, "sp-input": st.sp, umin: st.u_min, umax: st.u_max };
  for (const [id, v] of Object.entries(vals)) {
    if (all || !S.dirty.has(id)) $(id).value = fmtParam(v);
  }
  if (all) S.dirty.clear();
}

for (const id of ["manual-value", "sp-input", "umin", "umax"]) {
  $(id).addEventListener("input", () => { S.dirty.add(id); markOutOfRange(); });
}

function renderPlate() {
  const st = S.states[S.selected];
  if (!st || !st.tunings) return;  // the whole state comes with the next push
  if (S.tunedFor !== S.selected) {  // first whole state of this loop: build its controls
    S.tunedFor = S.selected;
    fillInputs(true);
    buildTunings();
    showRanges();
  }
  $("v-sp").textContent = fmt(st.sp);
  $("v-pv").textContent = fmt(st.pv);
  $("v-mv").textContent = fmt(st.mv);
  const m = $("plate-mode");
  modeBadge(m, st);
  // a cascade's primary that tracks y2 or holds (the inner loop open): its mode stays AUTO
  const tracks = Object.entries(st.tracking || {})
    .map(([role, what]) => what === "hold" ? `${role} holds` : `${role} tracks ${what}`);
  if (tracks.length) m.textContent += ` (${tracks.join(", ")})`;
  stateBadges($("plate-state"), st);
  const list = $("plate-alarms");
  list.replaceChildren();
  for (const c of st.conditions || []) {
    if (c.severity === "info") continue;
    const li = document.createElement("li");
    li.className = c.severity;
    const b = document.createElement("b");
    b.textContent = (S.words[c.code] || [c.severity, c.code])[1] + ": ";
    li.append(b, c.text);
    list.appendChild(li);
  }
  $("block-type").textContent = st.block;
  fillInputs(false);
  for (const row of $("tunings").tBodies[0].rows) {
    row.cells[1].textContent = fmtParam(st.tunings[row.dataset.key]);
  }
  renderTuning(st.tuning);
  updateChart();
}

function buildTunings() {
  const st = S.states[S.selected];
  const tbody = $("tunings").tBodies[0];
  tbody.innerHTML = "";
  const main = MAIN_TUNINGS[st.block] || [];
  const keys = [...main.filter((k) => k in st.tunings),
                ...Object.keys(st.tunings).filter((k) => !main.includes(k))];
  for (const k of keys) {
    const v = st.tunings[k];
    const tr = document.createElement("tr");
    tr.dataset.key = k;
    tr.className = main.includes(k) ? "main" : "extra";
    const th = document.createElement("th");
    th.textContent = k;
    const cur = document.createElement("td");
    const td = document.createElement("td");
    const rng = document.createElement("td");
    rng.className = "range";
    const inp = document.createElement("input");
    inp.dataset.key = k;
    if (typeof v === "boolean") {
      inp.type = "checkbox";
      inp.checked = v;
    } else {
      inp.size = 9;
      inp.value = fmtParam(v);
    }
    inp.dataset.initial = inp.type === "checkbox" ? String(inp.checked) : inp.value;
    td.appendChild(inp);
    tr.append(th, cur, td, rng);
    tbody.appendChild(tr);
  }
  showRanges();
  applyPermissions();
}

function changedTunings() {
  const out = {};
  for (const inp of $("tunings").querySelectorAll("input")) {
    const now = inp.type === "checkbox" ? String(inp.checked) : inp.value;
    if (now !== inp.dataset.initial) out[inp.dataset.key] = inp.type === "checkbox" ? inp.checked : inp.value;
  }
  return out;
}

// ---------------------------------------------------------------- actions

function message(ok, status, text) {
  S.lastMessage = { ok, status, text };
  const el = $("msg");
  el.textContent = text;
  el.className = ok ? "ok" : "refused";
}

// POST a loop action (route under api/loops/NAME/), report the answer; the answer's JSON or null
async function post(route, body, what) {
  const name = S.selected;
  let r;
  try {
    r = await fetch(`api/loops/${encodeURIComponent(name)}/${route}`, {
      method: "POST",
      credentials: "same-origin",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body),
    });
  } catch (e) {
    message(false, 0, `${what}: no answer from the server (${e})`);
    return null;
  }
  const j = await r.json();
  if (r.ok) {
    S.states[name] = j.state;
    message(true, r.status, `${name}: ${what} accepted`);
  } else if (r.status === 401) {
    message(false, r.status, `${name}: ${what} refused — ${j.error.message}`);
  } else {
    const e = j.error;
    const code = e.code_hex ? `${e.code_hex} ${e.name}: ` : "";
    message(false, r.status, `${name}: ${what} refused — ${code}${e.field ? e.field + ": " : ""}${e.message}`);
  }
  loadAudit();
  return r.ok ? j : null;
}

async function command(changes, what) {
  return (await post("command", changes, what)) !== null;
}

$("btn-auto").addEventListener("click", () => command({ mode: "auto" }, "AUTO"));
$("btn-man").addEventListener("click", () => command({ mode: "manual" }, "MAN"));
// a step larger than the configured fraction of the range asks first (in the page)
function bigStep(key, text) {
  const e = eng();
  const st = S.states[S.selected];
  const r = e && (key === "sp" ? e.sp_range : e.mv_range);
  const x = Number(text);
  const cur = st && (key === "sp" ? st.sp : st.manual_value);
  if (!r || text.trim() === "" || !Number.isFinite(x) || !Number.isFinite(cur)) return null;
  const step = Math.abs(x - cur);
  const limit = e.confirm_step * (r.hi - r.lo);
  if (step <= limit) return null;
  const u = key === "sp" ? e.units.sp : e.units.mv;
  const what = key === "sp" ? "Setpoint" : "Manual value";
  return `${what} ${fmt(cur)} → ${fmt(x)} ${u}: a step of ${fmt(step)} ${u}, more than ` +
    `${Math.round(e.confirm_step * 100)} % of the range ${rangeText(r, u)}. Apply it?`;
}

function confirmStep(question) {
  return new Promise((resolve) => {
    S.confirming = question;
    $("confirm-text").textContent = question;
    $("confirm").hidden = false;
    const done = (ok) => {
      $("confirm").hidden = true;
      S.confirming = null;
      $("confirm-yes").onclick = $("confirm-no").onclick = null;
      resolve(ok);
    };
    $("confirm-yes").onclick = () => done(true);
    $("confirm-no").onclick = () => done(false);
    $("confirm-yes").focus();
  });
}

async function setValue(key, id, what) {
  const text = $(id).value;
  const question = bigStep(key, text);
  if (question && !(await confirmStep(question))) {
    message(false, 0, `${S.selected}: ${what} not sent (cancelled)`);
    return;
  }
  if (await command({ [key]: text }, what)) S.dirty.delete(id);
}

$("btn-manual").addEventListener("click", () => setValue("manual_value", "manual-value", "manual value"));
$("btn-sp").addEventListener("click", () => setValue("sp", "sp-input", "setpoint"));
$("btn-limits").addEventListener("click", async () => {
  if (await command({ u_min: $("umin").value, u_max: $("umax").value }, "limits")) {
    S.dirty.delete("umin");
    S.dirty.delete("umax");
  }
});
$("btn-tunings").addEventListener("click", async () => {
  const t = changedTunings();
  if (!Object.keys(t).length) { message(false, 0, "no tuning parameter changed"); return; }
  if (await command({ tunings: t }, "tuning " + Object.keys(t).join(", "))) buildTunings();
});
$("btn-tunings-reset").addEventListener("click", buildTunings);
$("btn-tunings-all").addEventListener("click", (ev) => {
  const all = document.querySelector("fieldset.tunings").classList.toggle("all");
  ev.target.textContent = all ? "Main parameters" : "All parameters";
});

// ---------------------------------------------------------------- live trend

// a y axis that always shows the SP (the MV) and spans at least MIN_SPAN of the loop's
// range, so measurement noise at steady state is not blown up to full height
function yRange(lo, hi, which) {
  const e = eng();
  const st = S.states[S.selected] || {};
  const ref = which === "mv" ? st.mv : st.sp;
  const r = e && (which === "mv" ? e.mv_range : e.sp_range);
  if (!Number.isFinite(lo) || !Number.isFinite(hi)) { lo = hi = ref; }
  if (Number.isFinite(ref)) { lo = Math.min(lo, ref); hi = Math.max(hi, ref); }
  if (!Number.isFinite(lo) || !Number.isFinite(hi)) return [0, 1];
  const minSpan = r ? MIN_SPAN * (r.hi - r.lo) : Math.max(MIN_SPAN * Math.abs(ref || 0), 1e-3);
  if (hi - lo < minSpan) {
    const mid = (lo + hi) / 2;
    lo = mid - minSpan / 2;
    hi = mid + minSpan / 2;
  }
  const pad = 0.05 * (hi - lo);
  return [lo - pad, hi + pad];
}
S.yRange = yRange;

// time axis labels that do not overlap: the time of day (with seconds when the ticks are
// less than a minute apart), the date only under the first tick and where the day changes
const pad2 = (x) => String(x).padStart(2, "0");
function timeLabels(u, splits, axisIdx, foundSpace, foundIncr) {
  let day = null;
  return splits.map((t) => {
    const d = new Date(t * 1000);
    let s = `${pad2(d.getHours())}:${pad2(d.getMinutes())}`;
    if (foundIncr < 60) s += `:${pad2(d.getSeconds())}`;
    const today = d.toDateString();
    if (today !== day) {
      s += `\n${d.getFullYear()}-${pad2(d.getMonth() + 1)}-${pad2(d.getDate())}`;
      day = today;
    }
    return s;
  });
}
S.timeLabels = timeLabels;

function chartOpts(el, title) {
  const label = (txt, sig) => (unit(sig) ? `${txt} [${unit(sig)}]` : txt);
  return {
    title,
    width: Math.max(280, el.clientWidth),
    height: 300,
    cursor: { drag: { x: true, y: false } },
    scales: {
      x: { time: true },
      y: { range: (u, lo, hi) => yRange(lo, hi, "sp") },
      mv: { range: (u, lo, hi) => yRange(lo, hi, "mv") },
    },
    series: [
      {},
      { label: "SP", stroke: "#2b8a3e", width: 1.5 },
      { label: "PV", stroke: "#1c7ed6", width: 1.5 },
      { label: "MV", stroke: "#e8590c", width: 1.5, scale: "mv" },
    ],
    axes: [
      { space: 90, values: timeLabels },
      { label: label("SP, PV", "pv") },
      { label: label("MV", "mv"), side: 1, scale: "mv", grid: { show: false } },
    ],
  };
}

function makeChart() {
  const el = $("trend");
  el.innerHTML = "";
  const opts = chartOpts(el, "");
  opts.hooks = {
    setSelect: [(u) => {
      if (u.select.width > 2) {
        S.follow = false;
        S.view = [u.posToVal(u.select.left, "x"), u.posToVal(u.select.left + u.select.width, "x")];
        u.setScale("x", { min: S.view[0], max: S.view[1] });
        u.setSelect({ width: 0, height: 0 }, false);
      }
    }],
  };
  opts.cursor.drag.setScale = false;
  S.chart = new uPlot(opts, trendData(), el);
  el.addEventListener("dblclick", () => { S.follow = true; updateChart(); });
  el.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const u = S.chart;
    const [lo, hi] = currentView();
    const rect = u.over.getBoundingClientRect();
    const at = u.posToVal(ev.clientX - rect.left, "x");
    const f = ev.deltaY > 0 ? 1.25 : 0.8;
    S.follow = false;
    S.view = [at - (at - lo) * f, at + (hi - at) * f];
    updateChart();
  }, { passive: false });
}

function currentView() {
  if (!S.follow && S.view) return S.view;
  const d = S.data[S.selected];
  const now = d && d.t.length ? d.t[d.t.length - 1] : Date.now() / 1000;
  return [now - S.windowSec, now];
}

function trendData() {
  const d = S.data[S.selected] || { t: [], sp: [], pv: [], mv: [] };
  return [d.t, d.sp, d.pv, d.mv];
}

function updateChart() {
  if (!S.chart) return;
  const [lo, hi] = currentView();
  S.chart.batch(() => {
    S.chart.setData(trendData(), false);
    S.chart.setScale("x", { min: lo, max: hi });
  });
}

$("trend-window").addEventListener("change", (ev) => {
  S.windowSec = Number(ev.target.value);
  if (!S.follow && S.view) {
    const mid = (S.view[0] + S.view[1]) / 2;
    S.view = [mid - S.windowSec / 2, mid + S.windowSec / 2];
  }
  updateChart();
});
function pan(frac) {
  const [lo, hi] = currentView();
  const w = hi - lo;
  S.follow = false;
  S.view = [lo + frac * w, hi + frac * w];
  updateChart();
}
$("pan-left").addEventListener("click", () => pan(-0.5));
$("pan-right").addEventListener("click", () => pan(0.5));
$("btn-live").addEventListener("click", () => { S.follow = true; updateChart(); });
window.addEventListener("resize", () => {
  if (S.chart) S.chart.setSize({ width: $("trend").clientWidth, height: 300 });
});

// ---------------------------------------------------------------- history

function toLocalInput(t) {
  const d = new Date(t * 1000 - new Date(t * 1000).getTimezoneOffset() * 60000);
  return d.toISOString().slice(0, 19);
}
function fromLocalInput(s) {
  return new Date(s).getTime() / 1000;
}

function setHistoryDefaults() {
  const now = Date.now() / 1000;
  $("hist-from").value = toLocalInput(now - 600);
  $("hist-to").value = toLocalInput(now + 60);
  updateCsvLink();
}

function historyQuery() {
  const start = fromLocalInput($("hist-from").value);
  const end = fromLocalInput($("hist-to").value);
  return `start=${start}&end=${end}`;
}

function updateCsvLink() {
  $("csv-link").href = `api/loops/${encodeURIComponent(S.selected)}/history.csv?${historyQuery()}`;
}
$("hist-from").addEventListener("change", updateCsvLink);
$("hist-to").addEventListener("change", updateCsvLink);

$("btn-history").addEventListener("click", async () => {
  updateCsvLink();
  const r = await fetch(`api/loops/${encodeURIComponent(S.selected)}/history?${historyQuery()}`);
  const j = await r.json();
  if (!r.ok) { $("hist-info").textContent = j.error.message; return; }
  const c = j.columns;
  $("hist-info").textContent = `${j.rows} samples` + (j.stride > 1 ? ` (every ${j.stride}th shown)` : "");
  const el = $("hist-chart");
  el.innerHTML = "";
  S.histChart = new uPlot(chartOpts(el, `${S.selected}: history`), [c.t_wall, c.sp, c.pv, c.mv], el);
});


// ---------------------------------------------------------------- live tuning

const TUNE_FIELDS = { amplitude: "tune-amplitude", max_time: "tune-max-time",
  mv_min: "tune-mv-min", mv_max: "tune-mv-max", pv_min: "tune-pv-min", pv_max: "tune-pv-max" };
S.tuneShown = null;    // what the proposals table shows (rebuilt only when it changes)

function renderTuning(tu) {
  const status = $("tune-status");
  if (!tu) {
    status.textContent = "no test yet";
    status.className = "";
  } else {
    const why = tu.reason ? ` — ${tu.reason}` : "";
    const by = tu.decided_by ? ` by ${tu.decided_by}` + (tu.accepted ? `: ${tu.accepted}` : "") : "";
    const prog = tu.state === "running"
      ? ` ${fmt(tu.elapsed)} s of at most ${fmt(tu.max_time)} s, MV ${fmt(tu.mv)}` : "";
    status.textContent = `${tu.method} test ${tu.state}${prog}${why}${by}`;
    status.className = tu.state;
  }
  const key = tu ? JSON.stringify([S.selected, tu.state, tu.margins_ready, tu.proposals || null])
    : S.selected;
  if (key === S.tuneShown) return;
  S.tuneShown = key;
  const m = tu && tu.model;
  $("tune-model").textContent = !m ? ""
    : m.kind === "FOPDT"
      ? `model: FOPDT gain ${fmt(m.gain)}, time constant ${fmt(m.time_constant)} s, dead time ${fmt(m.dead_time)} s`
      : `ultimate point: ku ${fmt(m.ku)}, pu ${fmt(m.pu)} s (no model for margins: a step test gives one)`;
  const tbody = $("tune-proposals").tBodies[0];
  tbody.innerHTML = "";
  const may = new Set((S.info && S.info.may_change) || []);
  for (const [name, p] of Object.entries((tu && tu.proposals) || {})) {
    const tr = document.createElement("tr");
    tr.dataset.proposal = name;
    const mg = (tu.margins || {})[name];
    const settings = Object.entries(p).filter(([k]) => k !== "type")
      .map(([k, v]) => `${k} ${fmtParam(v)}`).join(", ");
    const cells = [name, `${p.type}: ${settings}`,
                   mg ? (mg.summary || mg.error) : (tu.margins_ready ? "-" : "computing ...")];
    for (const c of cells) {
      const td = document.createElement("td");
      td.textContent = c;
      tr.appendChild(td);
    }
    if (mg && (mg.stable === false || mg.ms > 2)) tr.className = "fragile";
    const td = document.createElement("td");
    if (tu.state === "done") {
      const b = document.createElement("button");
      b.type = "button";
      b.textContent = "Accept";
      b.disabled = !may.has("tune");
      b.addEventListener("click", () => tuneAction("accept", { proposal: name }, `accept ${name}`));
      td.appendChild(b);
    }
    tr.appendChild(td);
    tbody.appendChild(tr);
  }
  $("tune-warnings").textContent = ((tu && tu.warnings) || []).join(" · ");
}

async function tuneAction(action, body, what) {
  const j = await post(action === "start" ? "tune" : `tune/${action}`, body, what);
  if (j) renderTuning(j.tuning);
  return j !== null;
}

$("tune-start").addEventListener("click", () => {
  const body = { method: $("tune-method").value };
  for (const [k, id] of Object.entries(TUNE_FIELDS)) {
    if ($(id).value.trim()) body[k] = $(id).value;
  }
  tuneAction("start", body, `${body.method} test`);
});
$("tune-abort").addEventListener("click", () => tuneAction("abort", { reason: "from the faceplate" }, "abort"));
$("tune-reject").addEventListener("click", () => tuneAction("reject", {}, "reject"));

// ---------------------------------------------------------------- audit

async function loadAudit() {
  if (!S.selected || !S.user) return;
  const r = await fetch(`api/audit?limit=20&loop=${encodeURIComponent(S.selected)}`);
  if (!r.ok) return;
  const rows = await r.json();
  const tbody = $("audit").tBodies[0];
  tbody.innerHTML = "";
  for (const a of rows) {
    const tr = document.createElement("tr");
    const cells = [new Date(a.t_wall * 1000).toLocaleString(), a.who, a.action,
                   JSON.stringify(a.new), a.ok ? "accepted" : "refused: " + a.message];
    for (const c of cells) {
      const td = document.createElement("td");
      td.textContent = c;
      tr.appendChild(td);
    }
    if (!a.ok) tr.className = "refused";
    tbody.appendChild(tr);
  }
}

// ---------------------------------------------------------------- start

loadInfo();
