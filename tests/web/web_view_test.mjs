// The web view in a real browser (Debian's chromium, headless, driven by puppeteer-core):
// cairn-base with two fake robots in a walled room (cairn-test-room-robots); the page and
// the socket refuse without the token; the canvas shows the room's walls at their pixels;
// the robot markers move; a click sends a visit request the base assigns. A screenshot
// is kept in the build directory. Every wait is for a condition, with a bound.
//   node web_view_test.mjs --base BIN --robots BIN --config TOML --dds LOOPBACK_XML --out DIR
import { spawn } from "node:child_process";
import fs from "node:fs";
import http from "node:http";
import path from "node:path";
import puppeteer from "puppeteer-core";

const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) => (a.startsWith("--") ? [...acc, [a.slice(2), all[i + 1]]] : acc), []));
const CHROMIUM = "/usr/bin/chromium";
const TOKEN = "test-token-0123456789";  // tests/web/base-web.toml
const domain = 200 + (process.pid % 30);  // outside the 100..199 the process tests draw from
const out = path.resolve(args.out);
const children = [];
let failures = 0;

function check(ok, what) {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}`);
  if (!ok) failures++;
  return ok;
}

function fatal(what) {
  console.log(`FAIL ${what}`);
  cleanup().then(() => process.exit(1));
}

async function cleanup() {
  for (const c of children) if (c.exitCode === null) c.kill("SIGTERM");
  await Promise.all(children.map((c) => (c.exitCode === null ? new Promise((r) => c.once("exit", r)) : null)));
}

// Resolves when `pred(text)` holds for the child's stdout so far; rejects after `ms`.
function waitForOutput(child, pred, ms, what) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`no ${what} within ${ms} ms`)), ms);
    const look = () => {
      const m = pred(child.stdoutText);
      if (m) { clearTimeout(timer); child.stdout.off("data", look); resolve(m); }
    };
    child.stdout.on("data", look);
    look();
  });
}

function start(bin, argv, name) {
  const env = { ...process.env, CYCLONEDDS_URI: `file://${args.dds}` };
  const c = spawn(bin, argv, { env, stdio: ["ignore", "pipe", "pipe"] });
  c.stdoutText = "";
  c.logText = "";  // stdout and stderr: the log lines go to either
  const log = fs.createWriteStream(path.join(out, `${name}.log`));
  c.stdout.on("data", (d) => { c.stdoutText += d; c.logText += d; log.write(d); });
  c.stderr.on("data", (d) => { c.logText += d; log.write(d); });
  children.push(c);
  return c;
}

// A WebSocket upgrade by hand: the status the server answers it with.
function upgradeStatus(port, target) {
  return new Promise((resolve, reject) => {
    const req = http.request({ host: "127.0.0.1", port, path: target, headers: {
      Connection: "Upgrade", Upgrade: "websocket", "Sec-WebSocket-Version": "13", "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==" } });
    req.on("upgrade", (res, socket) => { socket.destroy(); resolve(res.statusCode); });
    req.on("response", (res) => { res.resume(); resolve(res.statusCode); });
    req.on("error", reject);
    req.end();
  });
}

process.on("unhandledRejection", (e) => fatal(`unexpected: ${e && e.stack ? e.stack : e}`));
// Whatever ends this process (a thrown error included), its children end with it.
process.on("exit", () => { for (const c of children) if (c.exitCode === null) c.kill("SIGKILL"); });
setTimeout(() => fatal("the whole test took over 50 s"), 50000).unref();

fs.mkdirSync(out, { recursive: true });
if (!fs.existsSync(CHROMIUM)) fatal(`${CHROMIUM} is missing: scripts/setup-deps.sh installs Debian's chromium`);
const runDir = fs.mkdtempSync(path.join(out, "run-"));
const config = path.join(runDir, "base.toml");
fs.writeFileSync(config, fs.readFileSync(args.config, "utf8").replaceAll("@DOMAIN@", String(domain)).replaceAll("@DIR@", runDir));

start(args.robots, ["--domain", String(domain), "--duration", "60"], "robots");
const base = start(args.base, ["-c", config, "--duration", "60"], "base");
const port = Number((await waitForOutput(base, (t) => /web view listening on 127\.0\.0\.1 port (\d+)/.exec(t), 10000, "web view address"))[1]);
const url = (p) => `http://127.0.0.1:${port}${p}`;

// Access: nothing without the token, not even a command.
check((await fetch(url("/"))).status === 401, "the page without the token: 401");
check((await fetch(url("/?token=wrong-token-0123456789"))).status === 401, "the page with a wrong token: 401");
check((await fetch(url("/api/state"))).status === 401, "the state without the token: 401");
const sneaky = await fetch(url("/api/command"), { method: "POST", body: JSON.stringify({ cmd: "visit", robot: 1, x: 0, y: 0 }) });
check(sneaky.status === 401, "a command without the token: 401");
check((await upgradeStatus(port, "/ws")) === 401, "the WebSocket upgrade without the token: 401");
check((await upgradeStatus(port, `/ws?token=${TOKEN}`)) === 101, "the WebSocket upgrade with the token: 101");
check((await fetch(url("/api/state"), { headers: { "X-Cairn-Token": TOKEN } })).status === 200, "the state with the token as a header: 200");

const browser = await puppeteer.launch({ executablePath: CHROMIUM, headless: true, args: ["--no-sandbox", "--disable-gpu"] });
try {
  const page = await browser.newPage();
  await page.setViewport({ width: 1240, height: 720 });
  check((await page.goto(url("/"))).status() === 401, "chromium: the page without the token is refused (401)");
  check((await page.goto(url(`/?token=${TOKEN}`))).status() === 200, "chromium: the page with the token loads (200)");

  // The room's walls (x = ±4, y = ±3 m) black on the canvas, where the map's geometry puts
  // them; inside clear (white), outside unknown (grey). Waits until the scans have drawn them.
  const wallsDrawn = () => {
    const v = window.cairnView;
    if (!v.map || !v.image || !v.state) return false;
    const ctx = document.getElementById("map").getContext("2d");
    const rgb = (x, y) => { const c = v.worldToCanvas(x, y); return ctx.getImageData(Math.round(c[0]), Math.round(c[1]), 1, 1).data; };
    // Darkest pixel within one cell across the wall (the scan's end lands in the wall's cell or its neighbour).
    const dark = (x, y, alongX) => {
      let min = 255;
      for (let d = -v.map.resolution; d <= v.map.resolution + 1e-9; d += v.map.resolution / 4) {
        const p = alongX ? rgb(x + d, y) : rgb(x, y + d);
        min = Math.min(min, Math.max(p[0], p[1], p[2]));
      }
      return min;
    };
    const walls = [];
    for (const y of [-2.5, -1.5, 0.5, 2.5]) walls.push(dark(4.0, y, true), dark(-4.0, y, true));
    for (const x of [-3.5, -2.5, 2.5, 3.5]) walls.push(dark(x, 3.0, false), dark(x, -3.0, false));
    const inside = rgb(3.2, 2.2), outside = rgb(5.5, 4.5);
    return walls.every((w) => w < 40) && inside[0] > 240 && inside[1] > 240 && outside[0] > 150 && outside[0] < 220
      ? { walls: walls.length, inside: Array.from(inside), outside: Array.from(outside) } : false;
  };
  const walls = await page.waitForFunction(wallsDrawn, { timeout: 15000, polling: 100 }).then((h) => h.jsonValue(), () => null);
  check(walls !== null, `the canvas shows the room: 16 wall points black, inside white, outside grey ${JSON.stringify(walls)}`);

  // A robot marker moves: robot 1's disc (its colour, red) at one place, later at another.
  const marker = () => {
    const v = window.cairnView;
    const r = v.state && v.state.robots.find((x) => x.id === 1 && x.pose);
    if (!r || !v.map) return null;
    const c = v.worldToCanvas(r.pose.x, r.pose.y);
    // Off the heading line, inside the disc.
    const px = Math.round(c[0] - 3 * Math.cos(r.pose.theta)), py = Math.round(c[1] + 3 * Math.sin(r.pose.theta));
    const d = document.getElementById("map").getContext("2d").getImageData(px, py, 1, 1).data;
    return { x: c[0], y: c[1], rgb: Array.from(d.slice(0, 3)) };
  };
  const red = (m) => m && m.rgb[0] > 180 && m.rgb[1] < 80 && m.rgb[2] < 80;
  const first = await page.evaluate(marker);
  check(red(first), `robot 1's marker drawn in red at (${first && first.x.toFixed(0)}, ${first && first.y.toFixed(0)}) px ${JSON.stringify(first && first.rgb)}`);
  const moved = await page.waitForFunction((f) => {
    const v = window.cairnView;
    const r = v.state.robots.find((x) => x.id === 1 && x.pose);
    const c = v.worldToCanvas(r.pose.x, r.pose.y);
    return Math.hypot(c[0] - f.x, c[1] - f.y) > 10;
  }, { timeout: 10000, polling: 100 }, first).then(() => true, () => false);
  const second = await page.evaluate(marker);
  check(moved && red(second), `robot 1's marker moved over 10 px, drawn in red at (${second.x.toFixed(0)}, ${second.y.toFixed(0)}) px`);

  // A bad command over the page's socket: a clear error, not a crash.
  await page.evaluate(() => window.cairnView.socket.send(JSON.stringify({ cmd: "self-destruct" })));
  const bad = await page.waitForFunction(() => window.cairnView.lastReply, { timeout: 5000 }).then((h) => h.jsonValue(), () => null);
  check(bad && bad.ok === false && /unknown command/.test(bad.error), `an unknown command is refused: ${JSON.stringify(bad)}`);

  // Click: robot 1 chosen, the map clicked at a clear point; the base assigns the visit.
  await page.waitForSelector('#robot option[value="1"]', { timeout: 5000 });
  await page.select("#robot", "1");
  const target = [0.0, 2.2];
  const at = await page.evaluate((t) => {
    const c = window.cairnView.worldToCanvas(t[0], t[1]);
    const r = document.getElementById("map").getBoundingClientRect();
    return [r.left + c[0] * (r.width / 800), r.top + c[1] * (r.height / 640)];
  }, target);
  await page.mouse.click(at[0], at[1]);
  const done = await page.waitForFunction(() => {
    const s = window.cairnView.state;
    const c = s.commands.find((x) => x.robot === 1);
    const r = s.robots.find((x) => x.id === 1);
    return c && r.task && r.task.kind === "goto" ? { command: c, task: r.task } : false;
  }, { timeout: 10000, polling: 100 }).then((h) => h.jsonValue(), () => null);
  const near = (a, b) => Math.abs(a - b) <= 0.1;  // two cells: the click lands on a pixel, not a point
  check(done && done.command.result === "accepted" && near(done.command.x, target[0]) && near(done.command.y, target[1]),
    `the click's visit request accepted by the base: ${JSON.stringify(done && done.command)}`);
  check(done && done.task.active && near(done.task.x, target[0]) && near(done.task.y, target[1]),
    `robot 1 assigned a goto task to the click: ${JSON.stringify(done && done.task)}`);
  check(/visit: robot 1 to \(-?0\.\d\d, 2\.\d\d\), asked by web view/.test(base.logText), "the base logged the web view's visit request");

  await page.screenshot({ path: path.join(out, "web_view.png") });
  check(fs.statSync(path.join(out, "web_view.png")).size > 1000, `screenshot kept: ${path.join(out, "web_view.png")}`);
} finally {
  await browser.close();
}
check((base.logText.match(/asked by web view/g) || []).length === 1, "only the one visit with the token reached the executive");
await cleanup();
check(base.exitCode === 0, `cairn-base exited cleanly on SIGTERM (exit ${base.exitCode})`);
console.log(failures === 0 ? "web view: all checks passed" : `web view: ${failures} check(s) failed`);
process.exit(failures === 0 ? 0 : 1);
