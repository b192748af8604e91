// Cairn's live view: draws what cairn-base pushes over its WebSocket (docs/web-view.md);
// sends a visit request for the chosen robot where the map is clicked, stops and starts the
// exploration, e-stops every robot, and asks for a robot's e-stop reset.
"use strict";

const token = new URLSearchParams(location.search).get("token") || "";
const canvas = document.getElementById("map");
const ctx = canvas.getContext("2d");
// Robot 1 red, 2 blue, 3 green...: the colours of the exported map.png.
const colours = ["#dc1e1e", "#1e5adc", "#14a028", "#c87800", "#9628b4", "#00a0aa"];
const colour = (id) => colours[(Math.max(id, 1) - 1) % colours.length];

// What the tests read: the latest messages, counts, and the view's transform.
const view = { state: null, map: null, image: null, counts: { state: 0, map: 0, tiles: 0, reply: 0 }, lastReply: null,
               resetButtons: new Map() };
window.cairnView = view;

// The map fills the canvas, keeping its aspect; world y grows up, canvas y down.
function fit() {
  const m = view.map;
  if (!m) return null;
  const scale = Math.min(canvas.width / m.width, canvas.height / m.height);  // px per cell
  return { scale, ox: (canvas.width - m.width * scale) / 2, oy: (canvas.height - m.height * scale) / 2 };
}
view.worldToCanvas = (x, y) => {
  const m = view.map, f = fit();
  if (!f) return null;
  return [f.ox + ((x - m.origin_x) / m.resolution) * f.scale, f.oy + (m.height - (y - m.origin_y) / m.resolution) * f.scale];
};
view.canvasToWorld = (px, py) => {
  const m = view.map, f = fit();
  if (!f) return null;
  return [m.origin_x + ((px - f.ox) / f.scale) * m.resolution, m.origin_y + (m.height - (py - f.oy) / f.scale) * m.resolution];
};
const metres = (d) => (d / view.map.resolution) * fit().scale;

function ellipse(x, y, e, style) {
  const c = view.worldToCanvas(x, y);
  if (!e || e.major <= 0) return;
  ctx.beginPath();
  ctx.strokeStyle = style;
  ctx.ellipse(c[0], c[1], Math.max(metres(e.major), 1), Math.max(metres(e.minor), 1), -e.angle, 0, 2 * Math.PI);
  ctx.stroke();
}

function rectangle(r, style, dash) {
  const a = view.worldToCanvas(r[0], r[1]), b = view.worldToCanvas(r[2], r[3]);
  ctx.strokeStyle = style;
  ctx.setLineDash(dash || []);
  ctx.strokeRect(Math.min(a[0], b[0]), Math.min(a[1], b[1]), Math.abs(b[0] - a[0]), Math.abs(b[1] - a[1]));
  ctx.setLineDash([]);
}

// The central map's frontier (clear cells beside unknown ones), the robots' latest bids
// (circles of area proportional to the gain), their unreachable clusters and given-up spots.
function drawExploration(s) {
  const m = view.map, f = fit();
  if (m.frontier) {
    ctx.fillStyle = "rgba(255, 140, 0, 0.8)";
    const w = Math.max(f.scale, 1);
    for (const k of m.frontier) {
      const i = k % m.width, j = Math.floor(k / m.width);
      ctx.fillRect(f.ox + i * f.scale, f.oy + (m.height - 1 - j) * f.scale, w, w);
    }
  }
  for (const r of s.robots) {
    const col = colour(r.id);
    if (r.bid) {
      ctx.strokeStyle = col;
      for (const it of r.bid.items) {
        const c = view.worldToCanvas(it.x, it.y);
        ctx.beginPath(); ctx.arc(c[0], c[1], Math.max(2, Math.sqrt(it.gain) / 2), 0, 2 * Math.PI); ctx.stroke();
      }
      for (const u of r.bid.unreachable) rectangle(u.rect, "#c00000");
    }
    if (r.task && r.task.igr) rectangle(r.task.igr, col, [6, 3]);
  }
  if (s.exploration) {
    ctx.strokeStyle = "#000";
    for (const p of s.exploration.given_up) {
      const c = view.worldToCanvas(p[0], p[1]);
      ctx.beginPath();
      ctx.moveTo(c[0] - 5, c[1] - 5); ctx.lineTo(c[0] + 5, c[1] + 5);
      ctx.moveTo(c[0] + 5, c[1] - 5); ctx.lineTo(c[0] - 5, c[1] + 5);
      ctx.stroke();
    }
  }
}

function draw() {
  ctx.fillStyle = "#bebebe";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!view.map || !view.image) return;
  const f = fit();
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(view.image, f.ox, f.oy, view.map.width * f.scale, view.map.height * f.scale);
  const s = view.state;
  if (!s) return;
  ctx.lineWidth = 1;
  if (document.getElementById("show-explore").checked) drawExploration(s);
  for (const l of s.landmarks) {
    const c = view.worldToCanvas(l.x, l.y);
    ctx.strokeStyle = "#e600c8";
    ctx.beginPath();
    ctx.moveTo(c[0] - 4, c[1]); ctx.lineTo(c[0] + 4, c[1]);
    ctx.moveTo(c[0], c[1] - 4); ctx.lineTo(c[0], c[1] + 4);
    ctx.stroke();
    ellipse(l.x, l.y, l.ellipse, "#e600c8");
  }
  for (const r of s.robots) {
    const col = colour(r.id);
    if (r.trail && r.trail.length > 1) {
      ctx.strokeStyle = col;
      ctx.beginPath();
      r.trail.forEach((p, i) => { const c = view.worldToCanvas(p[0], p[1]); i ? ctx.lineTo(c[0], c[1]) : ctx.moveTo(c[0], c[1]); });
      ctx.stroke();
    }
    if (!r.pose) continue;
    const c = view.worldToCanvas(r.pose.x, r.pose.y);
    if (r.task && r.task.active) {
      const t = view.worldToCanvas(r.task.x, r.task.y);
      ctx.setLineDash([4, 4]);
      ctx.strokeStyle = col;
      ctx.beginPath(); ctx.moveTo(c[0], c[1]); ctx.lineTo(t[0], t[1]); ctx.stroke();
      ctx.setLineDash([]);
    }
    ellipse(r.pose.x, r.pose.y, r.ellipse, col);
    ctx.fillStyle = col;
    ctx.beginPath(); ctx.arc(c[0], c[1], 6, 0, 2 * Math.PI); ctx.fill();
    ctx.strokeStyle = "#000";
    ctx.beginPath(); ctx.moveTo(c[0], c[1]);
    ctx.lineTo(c[0] + 12 * Math.cos(r.pose.theta), c[1] - 12 * Math.sin(r.pose.theta)); ctx.stroke();
  }
}

function text(v) { return v === undefined || v === null ? "" : String(v); }
function row(cells) {
  const tr = document.createElement("tr");
  for (const c of cells) { const td = document.createElement("td"); td.append(c); tr.append(td); }
  return tr;
}

function send(cmd) {
  const reply = document.getElementById("reply");
  if (!view.socket || view.socket.readyState !== WebSocket.OPEN) { reply.textContent = "no link yet"; return false; }
  view.socket.send(JSON.stringify(cmd));
  return true;
}

// A latched robot's reset button is the same element from one redraw to the next: one made
// anew on every state update would be swapped out under the operator's pointer between
// press and release, and the click would be lost.
function resetButton(id) {
  let b = view.resetButtons.get(id);
  if (!b) {
    b = document.createElement("button");
    b.className = "reset"; b.textContent = "reset"; b.dataset.robot = String(id);
    b.onclick = () => send({ cmd: "reset", robot: id });
    view.resetButtons.set(id, b);
  }
  return b;
}

function panel() {
  const s = view.state;
  const body = document.querySelector("#robots tbody");
  body.replaceChildren();
  const rt = document.querySelector("#rt tbody");
  rt.replaceChildren();
  const select = document.getElementById("robot");
  for (const r of s.robots) {
    const name = document.createElement("span");
    const sw = document.createElement("span");
    sw.className = "swatch"; sw.style.background = colour(r.id);
    name.append(sw, `${r.id} ${text(r.name)}`);
    const stop = document.createElement("span");
    stop.textContent = text(r.stop);
    if (r.estop) stop.className = "estop";
    if (r.reset_required) stop.append(" ", resetButton(r.id));  // latched: the operator may reset it from here
    const battery = r.battery_v ? `${r.battery_v.toFixed(1)} V ${Math.round(r.battery_soc * 100)}%` : "";
    const task = r.task ? `${r.task.kind} #${r.task.id}` : "";
    body.append(row([name, text(r.mode), `${r.presence} ${r.link_age_s.toFixed(1)} s`, battery, stop, task]));
    if (r.rt) {
      rt.append(row([`${r.id}`, `${r.rt.period_mean_us.toFixed(0)} / ${r.rt.period_p99_us.toFixed(0)}`,
                     r.rt.jitter_max_us.toFixed(0), String(r.rt.misses), String(r.rt.overflows)]));
    }
    if (!select.querySelector(`option[value="${r.id}"]`)) {
      const o = document.createElement("option");
      o.value = String(r.id); o.textContent = `robot ${r.id} ${text(r.name)}`;
      select.append(o);
    }
  }
  const latched = new Set(s.robots.filter((r) => r.reset_required).map((r) => r.id));
  for (const id of view.resetButtons.keys()) if (!latched.has(id)) view.resetButtons.delete(id);
  const cmds = document.querySelector("#commands tbody");
  cmds.replaceChildren();
  for (const c of s.commands) {
    const target = c.cmd === "visit" ? `(${c.x.toFixed(2)}, ${c.y.toFixed(2)})` : c.cmd === "explore" ? (c.run ? "start" : "stop")
      : c.cmd === "estop_all" ? "every robot" : "";
    cmds.append(row([String(c.id), c.cmd, text(c.robot), target, c.result]));
  }
  const button = document.getElementById("explore");
  const ex = document.getElementById("exploration");
  if (s.exploration) {
    button.hidden = false;
    button.textContent = s.exploration.paused ? "start exploration" : "stop exploration";
    button.dataset.run = s.exploration.paused ? "true" : "false";
    ex.textContent = (s.exploration.paused ? "stopped by the operator" : s.exploration.explored ? "explored" : "exploring") +
      `; ${s.exploration.rounds} round(s), ${s.exploration.given_up.length} frontier spot(s) given up` +
      (view.map && view.map.frontier_total !== undefined ? `; ${view.map.frontier_total} frontier cell(s) on the map` : "");
  } else {
    button.hidden = true;
    ex.textContent = "off: this base runs no exploration executive";
  }
  document.getElementById("landmarks").textContent =
    `${s.landmarks_total} landmark(s)` + (s.landmarks_total > s.landmarks.length ? `, ${s.landmarks.length} shown` : "");
}

// The map arrives in tiles (docs/web-view.md): each message carries the geometry, the frontier
// and the tiles that changed since this socket's last one ("full": all of them, a new image).
// The tiles are painted into an off-screen canvas of one pixel per cell, which draw() scales.
view.mapChain = Promise.resolve();
function applyTiles(msg) {
  const m = view.map;
  if (msg.full || !view.image || !m || m.width !== msg.width || m.height !== msg.height) {
    const c = document.createElement("canvas");
    c.width = msg.width; c.height = msg.height;
    view.image = c;
  }
  const tctx = view.image.getContext("2d");
  const loads = msg.tiles.map((t) => new Promise((done) => {
    const img = new Image();
    img.onload = () => { tctx.drawImage(img, t.tx * msg.tile, msg.height - t.ty * msg.tile - img.height); done(); };
    img.onerror = () => done();
    img.src = "data:image/png;base64," + t.png;
  }));
  return Promise.all(loads).then(() => {
    delete msg.tiles;  // painted: keep the geometry and the frontier
    view.map = msg; view.counts.map++; view.counts.tiles = (view.counts.tiles || 0) + loads.length;
    draw();
  });
}

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${scheme}://${location.host}/ws?token=${encodeURIComponent(token)}`);
  const link = document.getElementById("link");
  ws.onopen = () => { link.textContent = "live"; link.className = "up"; };
  ws.onclose = () => { link.textContent = "disconnected: retrying"; link.className = "down"; setTimeout(connect, 1000); };
  ws.onmessage = (ev) => {
    const msg = JSON.parse(ev.data);
    if (msg.type === "map") {
      view.mapChain = view.mapChain.then(() => applyTiles(msg));  // in order: tiles decode asynchronously
    } else if (msg.type === "state") {
      view.state = msg; view.counts.state++;
      panel(); draw();
    } else if (msg.type === "reply") {
      view.lastReply = msg; view.counts.reply++;
      document.getElementById("reply").textContent = msg.ok ? `request #${msg.id} queued` : `refused: ${msg.error}`;
    }
  };
  view.socket = ws;
}

canvas.addEventListener("click", (ev) => {
  const robot = Number(document.getElementById("robot").value);
  const reply = document.getElementById("reply");
  if (!robot) { reply.textContent = "choose a robot first"; return; }
  const rect = canvas.getBoundingClientRect();
  const w = view.canvasToWorld((ev.clientX - rect.left) * (canvas.width / rect.width), (ev.clientY - rect.top) * (canvas.height / rect.height));
  if (!w) { reply.textContent = "no map yet"; return; }
  send({ cmd: "visit", robot, x: w[0], y: w[1] });
});
document.getElementById("explore").addEventListener("click", (ev) => send({ cmd: "explore", run: ev.target.dataset.run === "true" }));
document.getElementById("show-explore").addEventListener("change", draw);
document.getElementById("estop-all").addEventListener("click", () => send({ cmd: "estop_all" }));

connect();
