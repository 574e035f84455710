// The process alarm list of the faceplate (its own component; server: GET /api/alarms and
// POST /api/loops/NAME/alarms/ack|shelve|unshelve, ctrlblocks.runtime.health).
// Every loop's alarm state at a glance (unacknowledged count, worst priority) and its
// annunciated alarms with an Ack button for the roles that may acknowledge.  Text only
// (textContent), never HTML from the server.
"use strict";

(function () {
  const PERIOD_MS = 2000;
  const ACK_ROLES = new Set(["operator", "engineer"]);
  const PRIORITY = { 1: "high", 2: "medium", 3: "low" };
  let role = null;

  function el(tag, text, cls) {
    const e = document.createElement(tag);
    if (text !== undefined) e.textContent = String(text);
    if (cls) e.className = cls;
    return e;
  }

  async function ack(loop, alarm) {
    const r = await fetch(`api/loops/${encodeURIComponent(loop)}/alarms/ack`, {
      method: "POST", credentials: "same-origin",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(alarm ? { alarm } : {}),
    });
    const out = await r.json().catch(() => ({}));
    const note = document.getElementById("alarm-note");
    note.textContent = r.ok ? "" : ((out.error && out.error.message) || `refused (${r.status})`);
    refresh();
  }

  function render(data) {
    const body = document.querySelector("#alarm-list tbody");
    const glance = document.getElementById("alarm-glance");
    body.replaceChildren();
    glance.replaceChildren();
    const loops = Object.keys(data.loops || {}).sort();
    for (const loop of loops) {
      const st = data.loops[loop];
      const badge = el("span", `${loop}: ${st.unacknowledged} unack.`,
        "alarm-badge prio-" + (PRIORITY[st.worst] || "none"));
      glance.append(badge);
      for (const a of st.alarms) {
        const tr = el("tr", undefined, "prio-" + (PRIORITY[a.priority] || "none"));
        tr.append(el("td", loop), el("td", a.name), el("td", a.state),
          el("td", PRIORITY[a.priority] || a.priority),
          el("td", a.value === null ? "" : Number(a.value).toPrecision(5)),
          el("td", a.limit === null ? "" : Number(a.limit).toPrecision(5)));
        const td = el("td");
        if (ACK_ROLES.has(role) && (a.state === "UNACK" || a.state === "RTN_UNACK")) {
          const b = el("button", "Ack");
          b.type = "button";
          b.addEventListener("click", () => ack(loop, a.name));
          td.append(b);
        }
        tr.append(td);
        body.append(tr);
      }
    }
    document.getElementById("alarm-section").hidden = loops.length === 0;
  }

  async function refresh() {
    try {
      const info = await fetch("api/info", { credentials: "same-origin" }).then((r) => r.json());
      role = info.role;
      const r = await fetch("api/alarms", { credentials: "same-origin" });
      if (r.ok) render(await r.json());
    } catch (e) {
      // the live connection indicator of app.js reports a lost server
    }
  }

  document.addEventListener("DOMContentLoaded", () => {
    refresh();
    setInterval(refresh, PERIOD_MS);
  });
})();
