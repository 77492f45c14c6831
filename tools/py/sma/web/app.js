// The dashboard page: polls /api/state, draws the last 30 s on canvases, sends commands.
"use strict";
const WINDOW_S = 30;
let token = null, since = 0, line = 0, rows = [], temps = [], lastT = null;
const $ = (id) => document.getElementById(id);

function showError(msg) {
  const e = $("error");
  if (msg) { e.textContent = msg; e.hidden = false; } else { e.hidden = true; }
}

function logLine(kind, text) {
  const pre = $("log"), span = document.createElement("span");
  span.className = kind;
  span.textContent = text + "\n";
  pre.appendChild(span);
  while (pre.childNodes.length > 400) pre.removeChild(pre.firstChild);
  pre.scrollTop = pre.scrollHeight;
}

async function post(path, body) {
  const headers = { "Content-Type": "application/json" };
  if (token) headers["X-Sma-Token"] = token;
  const r = await fetch(path, { method: "POST", headers, body: JSON.stringify(body || {}) });
  let j = {};
  try { j = await r.json(); } catch (e) { /* empty */ }
  return { status: r.status, body: j };
}

async function claim() {
  const r = await post("/api/claim");
  if (r.status === 200) { token = r.body.token; } else { showError(r.body.error); }
}

async function send(cmd) {
  if (!cmd) return;
  if (!token) { showError("this page only watches: another page controls the rig"); return; }
  const r = await post("/api/command", { line: cmd });
  if (r.status !== 200) { showError(r.body.error); return; }
  if (r.body.ok) showError(null);
  else showError("the board refused '" + cmd + "': " + r.body.reply);
}

function draw(canvas, series, yLabelFmt, fixedRange) {
  const ctx = canvas.getContext("2d"), W = canvas.width, H = canvas.height, L = 50, B = 18;
  ctx.clearRect(0, 0, W, H);
  let t1 = -Infinity, lo = Infinity, hi = -Infinity;
  for (const s of series) for (const p of s.pts) { t1 = Math.max(t1, p[0]); }
  if (!isFinite(t1)) return;
  const t0 = t1 - WINDOW_S;
  for (const s of series) for (const p of s.pts) if (p[0] >= t0) { lo = Math.min(lo, p[1]); hi = Math.max(hi, p[1]); }
  if (fixedRange) { lo = Math.min(lo, fixedRange[0]); hi = Math.max(hi, fixedRange[1]); }
  if (!isFinite(lo)) return;
  if (hi - lo < 1e-6) { hi += 0.5; lo -= 0.5; }
  const pad = 0.08 * (hi - lo); lo -= pad; hi += pad;
  const x = (t) => L + (W - L - 5) * (t - t0) / WINDOW_S, y = (v) => 5 + (H - B - 10) * (hi - v) / (hi - lo);
  ctx.strokeStyle = "#ddd"; ctx.fillStyle = "#555"; ctx.font = "11px sans-serif"; ctx.lineWidth = 1;
  for (let i = 0; i <= 4; i++) {
    const v = lo + (hi - lo) * i / 4;
    ctx.beginPath(); ctx.moveTo(L, y(v)); ctx.lineTo(W, y(v)); ctx.stroke();
    ctx.fillText(yLabelFmt(v), 2, y(v) + 4);
  }
  for (let t = Math.ceil(t0 / 5) * 5; t <= t1; t += 5) ctx.fillText(t.toFixed(0) + " s", x(t) - 10, H - 3);
  for (const s of series) {
    ctx.strokeStyle = s.color; ctx.lineWidth = s.width || 1.5; ctx.setLineDash(s.dash || []);
    ctx.beginPath();
    let first = true;
    for (const p of s.pts) {
      if (p[0] < t0) continue;
      if (first) { ctx.moveTo(x(p[0]), y(p[1])); first = false; } else ctx.lineTo(x(p[0]), y(p[1]));
    }
    ctx.stroke();
  }
  ctx.setLineDash([]);
}

function render(st) {
  const pos = [], ref = [], volt = [];
  for (const r of rows) { pos.push([r[0], r[2]]); ref.push([r[0], r[3]]); volt.push([r[0], r[1]]); }
  draw($("pos"), [{ pts: ref, color: "#222", dash: [6, 4], width: 1 }, { pts: pos, color: "#1565c0" }], (v) => v.toFixed(3));
  draw($("volt"), [{ pts: volt, color: "#c62828" }], (v) => v.toFixed(2));
  const tl = st.status && parseFloat(st.status.tlim);
  const series = [{ pts: temps, color: "#ef6c00" }];
  if (isFinite(tl) && temps.length) series.push({ pts: temps.map((p) => [p[0], tl]), color: "#b71c1c", dash: [3, 3], width: 1 });
  draw($("temp"), series, (v) => v.toFixed(0));
  const last = rows[rows.length - 1];
  $("now").textContent = last ? `t=${last[0].toFixed(2)} s  d=${last[2].toFixed(4)} mm  ref=${last[3].toFixed(4)} mm  ` +
    `V=${last[1].toFixed(3)}  duty=${last[4].toFixed(4)}  T=${st.status.T || "?"} C  ${st.recording ? "REC " + st.recording.file + " (" + st.recording.rows + " rows)" : ""}` : "no telemetry yet";
}

async function poll() {
  try {
    const headers = token ? { "X-Sma-Token": token } : {};
    const r = await fetch(`/api/state?since=${since}&line=${line}`, { headers });
    const st = await r.json();
    if (since > st.seq) { rows = []; temps = []; }  // the server restarted
    since = st.seq; line = st.nline;
    for (const row of st.rows) {
      const last = rows.length ? rows[rows.length - 1][0] : -Infinity;
      if (row[0] <= last) {
        if (row[0] < 1.0) rows = [];             // board reset: its time starts again at 0
        else continue;                           // a repeated or garbled tick
      }
      rows.push(row);
    }
    if (rows.length > 6000) rows = rows.slice(rows.length - 6000);
    const T = st.status && parseFloat(st.status.T), ts = st.status && st.status.t_row;
    if (isFinite(T) && typeof ts === "number" && st.status.seq !== lastT) {
      if (temps.length && ts < temps[temps.length - 1][0]) temps = [];  // board reset
      temps.push([ts, T]); lastT = st.status.seq; if (temps.length > 400) temps.shift();
    }
    for (const [, kind, text] of st.lines) logLine(kind, text);
    $("conn").textContent = st.connected ? "connected " + st.port : "not connected " + st.port;
    $("conn").className = "badge " + (st.connected ? "ok" : "bad");
    const fault = st.status && st.status.fault;
    $("latch").textContent = "latch: " + (fault || "?");
    $("latch").className = "badge " + (fault === undefined ? "" : (fault === "none" ? "ok" : "bad"));
    $("role").textContent = st.controller ? "this page controls the rig" : "watching only";
    if (!st.controller && token) { token = null; }
    if (!st.controller && !token) await claim();
    if (!st.connected && st.error) showError(st.error);
    $("rec").textContent = st.recording ? "Stop recording" : "Start recording";
    render(st);
  } catch (e) {
    showError("the dashboard server does not answer (was it stopped?)");
  }
  setTimeout(poll, 200);
}

$("cmdform").addEventListener("submit", (ev) => { ev.preventDefault(); const c = $("cmd").value.trim(); $("cmd").value = ""; send(c); });
for (const b of document.querySelectorAll("button[data-cmd]")) b.addEventListener("click", () => send(b.dataset.cmd));
$("stop").addEventListener("click", async () => {
  const r = await post("/api/stop");
  if (r.body.reply && r.body.reply.startsWith("OK")) showError(null); else showError("stop: " + (r.body.reply || r.body.error));
});
$("rec").addEventListener("click", async () => {
  const start = $("rec").textContent.startsWith("Start");
  const r = await post("/api/record", { action: start ? "start" : "stop", file: $("recfile").value.trim() });
  if (r.status !== 200) showError(r.body.error);
});
$("release").addEventListener("click", async () => { const r = await post("/api/release"); if (r.status !== 200) showError(r.body.error); });
$("connect").addEventListener("click", async () => {
  const r = await post("/api/connect");
  if (r.status !== 200) showError(r.body.error); else showError(null);
});
claim().then(poll);
