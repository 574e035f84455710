// ctrlblocks faceplate: loop list, live trend (uPlot), operator actions, history, audit.
// Plain JS, no build step. Live data arrives over the WebSocket /ws; actions are
// POST api/loops/NAME/command (the server and the block validate them).
"use strict";

const S = {
  info: null,            // GET api/info
  user: null,            // operator name or null (viewer)
  states: {},            // loop name -> state (from the push)
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
};
window.faceplate = S;

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

async function loadInfo() {
  const r = await fetch("api/info", { credentials: "same-origin" });
  S.info = await r.json();
  $("rt-name").textContent = "— " + S.info.name;
  setUser(S.info.user);
}

function setUser(user) {
  S.user = user;
  $("login-form").hidden = !!user;
  $("logged-in").hidden = !user;
  $("who").textContent = user || "";
  document.body.classList.toggle("operator", !!user);
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
    setUser(j.user);
    message(true, r.status, `logged in as ${j.user}`);
  } else {
    message(false, r.status, `login refused: ${j.error.message}`);
  }
});

$("btn-logout").addEventListener("click", async () => {
  await fetch("api/logout", { method: "POST", credentials: "same-origin" });
  setUser(null);
  message(true, 200, "logged out");
});

// ---------------------------------------------------------------- live data

function connect() {
  const url = new URL("ws", location.href);
  url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
  const ws = new WebSocket(url);
  ws.onopen = () => { $("conn").textContent = "live"; $("conn").className = "conn up"; };
  ws.onclose = () => {
    $("conn").textContent = "disconnected — retrying";
    $("conn").className = "conn down";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "update") onUpdate(msg);
  };
}

function onUpdate(msg) {
  S.updates += 1;
  S.order = msg.loops.map((s) => s.name);
  for (const st of msg.loops) S.states[st.name] = st;
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
  renderTable();
  if (!S.selected && S.order.length) select(decodeURIComponent(location.hash.slice(1)) || S.order[0]);
  if (S.selected) renderPlate();
}

// ---------------------------------------------------------------- loop list

function renderTable() {
  const tbody = $("loops").tBodies[0];
  for (const name of S.order) {
    const st = S.states[name];
    let tr = tbody.querySelector(`tr[data-loop="${CSS.escape(name)}"]`);
    if (!tr) {
      tr = document.createElement("tr");
      tr.dataset.loop = name;
      for (const c of ["name", "block", "mode", "sp", "pv", "mv", "alarms"]) {
        const td = document.createElement("td");
        td.className = c;
        tr.appendChild(td);
      }
      tr.addEventListener("click", () => select(name));
      tbody.appendChild(tr);
    }
    tr.classList.toggle("selected", name === S.selected);
    tr.classList.toggle("alarm", st.alarms.length > 0);
    tr.querySelector(".name").textContent = name;
    tr.querySelector(".block").textContent = st.block;
    const m = tr.querySelector(".mode");
    m.textContent = st.mode === "manual" ? "MAN" : "AUTO";
    m.className = "mode " + st.mode;
    tr.querySelector(".sp").textContent = fmt(st.sp);
    tr.querySelector(".pv").textContent = fmt(st.pv);
    tr.querySelector(".mv").textContent = fmt(st.mv);
    tr.querySelector(".alarms").textContent = st.alarms.join("; ") || "ok";
  }
}

// ---------------------------------------------------------------- faceplate

function select(name) {
  if (!S.states[name]) name = S.order[0];
  S.selected = name;
  history.replaceState(null, "", "#" + encodeURIComponent(name));
  $("plate").hidden = false;
  $("plate-title").textContent = name;
  S.follow = true;
  S.dirty.clear();
  fillInputs(true);
  buildTunings();
  makeChart();
  renderTable();
  renderPlate();
  setHistoryDefaults();
  loadAudit();
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
  $(id).addEventListener("input", () => S.dirty.add(id));
}

function renderPlate() {
  const st = S.states[S.selected];
  if (!st) return;
  $("v-sp").textContent = fmt(st.sp);
  $("v-pv").textContent = fmt(st.pv);
  $("v-mv").textContent = fmt(st.mv);
  const m = $("plate-mode");
  m.textContent = st.mode === "manual" ? "MAN" : "AUTO";
  m.className = "mode " + st.mode;
  $("plate-alarms").textContent = st.alarms.join("; ");
  $("block-type").textContent = st.block;
  fillInputs(false);
  for (const row of $("tunings").tBodies[0].rows) {
    row.cells[1].textContent = fmtParam(st.tunings[row.dataset.key]);
  }
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
    tr.append(th, cur, td);
    tbody.appendChild(tr);
  }
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

async function command(changes, what) {
  const name = S.selected;
  let r;
  try {
    r = await fetch(`api/loops/${encodeURIComponent(name)}/command`, {
      method: "POST",
      credentials: "same-origin",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(changes),
    });
  } catch (e) {
    message(false, 0, `${what}: no answer from the server (${e})`);
    return false;
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
  return r.ok;
}

$("btn-auto").addEventListener("click", () => command({ mode: "auto" }, "AUTO"));
$("btn-man").addEventListener("click", () => command({ mode: "manual" }, "MAN"));
$("btn-manual").addEventListener("click", async () => {
  if (await command({ manual_value: $("manual-value").value }, "manual value")) S.dirty.delete("manual-value");
});
$("btn-sp").addEventListener("click", async () => {
  if (await command({ sp: $("sp-input").value }, "setpoint")) S.dirty.delete("sp-input");
});
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

function chartOpts(el, title) {
  return {
    title,
    width: Math.max(300, el.clientWidth),
    height: 300,
    cursor: { drag: { x: true, y: false } },
    scales: { x: { time: true }, mv: { auto: true } },
    series: [
      {},
      { label: "SP", stroke: "#2b8a3e", width: 1.5 },
      { label: "PV", stroke: "#1c7ed6", width: 1.5 },
      { label: "MV", stroke: "#e8590c", width: 1.5, scale: "mv" },
    ],
    axes: [{}, { label: "SP, PV" }, { label: "MV", side: 1, scale: "mv", grid: { show: false } }],
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

// ---------------------------------------------------------------- audit

async function loadAudit() {
  if (!S.selected) return;
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

loadInfo().then(connect);
