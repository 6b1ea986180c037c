// The page: one WebSocket to `esair std hmi`; panels built from what the server says
// (resource kinds, the robot's board files). No build step, no network but this server.
import { Pose } from "./pose.js";
import { Joints, Motions } from "./joints.js";
import { Feet } from "./feet.js";
import { Components } from "./components.js";
import { Log } from "./log.js";
import { Generic } from "./generic.js";
import { Replay } from "./replay.js";
import { counted } from "./words.js";

const $ = (id) => document.getElementById(id);
const DRAW_SHARE = 0.25;         // drawing takes at most this share of the page's time
const MAX_DRAW_GAP_MS = 200;     // ... but the plots move at least 5 times a second
// redraws a second at most (`?fps=N` in the URL, 1-60): the feet come at 50 Hz, an eye
// needs less, and each frame drawn costs the computer showing the page (docs/hmi.md)
// The feet plot is drawn at the first frame after a sample at most FEET_FPS times a
// second (`?feet_fps=N`, default `?fps`, else 30: each frame costs the browser about the
// same whatever it draws, so 60 halves a sample's wait for a frame at 1.5-2x the
// browser's CPU, docs/hmi.md), the rest (the figure, the sliders, other panels) at most FPS.
const PARAMS = new URLSearchParams(location.search);
const ASKED_FPS = Number(PARAMS.get("fps"));
const FPS = Math.min(60, Math.max(1, ASKED_FPS || 30));
const FEET_FPS = Math.min(60, Math.max(1, Number(PARAMS.get("feet_fps")) || ASKED_FPS || 30));
const MIN_DRAW_GAP_MS = 1000 / FPS - 4;      // less a quarter of a 60 Hz frame: rAF jitters
const MIN_FEET_GAP_MS = 1000 / FEET_FPS - 4;
const FEET_LIVE_MS = 50;         // the feet drew this recently: the rest waits for their next frame
const KEEP = 20000;              // bench figures kept (up to twice as many: cut in halves,
                                 // not one shift of 20000 a sample)
const keep = (a, x) => { a.push(x); if (a.length >= 2 * KEEP) a.splice(0, KEEP); };

class App {
  constructor() {
    this.ws = null;
    this.nextId = 1;
    this.pending = new Map();
    this.role = "viewer";
    this.retry = 250;
    this.link = {};
    this.runtimeUp = true;
    this.wsUp = false;
    this.robots = {};
    // latencies: sample time stamp -> the frame that drew it; arrivals: -> the page got it
    // (the difference is the browser's wait for a frame), both in ms, for the bench
    // draws, drawMs: frames drawn and the time they took (the page's own cost)
    // hop, hmi, wire: the parts of `arrivals` (sample -> this HMI process got it -> it
    // sent it -> the page got it); waits: the page got it -> the frame drew it; hidden: the page is in the background (not drawn)
    this.stats = { samples: 0, latencies: [], arrivals: [], draws: 0, drawMs: 0,
      hop: [], hmi: [], wire: [], waits: [], hidden: false, frames: 0 };
    this.log = new Log($("log"), $("log-level"));
    this.components = new Components($("components"), $("add"), this);
    this._dirty = false; this.framePending = false; this.hidden = document.visibilityState === "hidden";
    this.drawnAt = -1e9; this.drawCost = 0; this.drawGap = MIN_DRAW_GAP_MS;     // frame(): the draw budget
    this.feetDirty = false; this.feetAt = -1e9; this.feetCost = 0; this.feetGap = MIN_FEET_GAP_MS;   // ... the feet's
    this.flushedAt = null;       // the server's "f" of the frame being read
    this.fps = FPS; this.feetFps = FEET_FPS;
    $("stop").addEventListener("click", () => this.stop());
    $("release").addEventListener("click", () => this.release());
    $("login").addEventListener("submit", (e) => { e.preventDefault(); this.login(); });
    $("record").addEventListener("click", () => this.record());
    this.replay = new Replay(this);
    // the banners stick right under the header, whatever its height (it wraps in a
    // window under 1100 px): --head in style.css
    new ResizeObserver(() => document.documentElement.style.setProperty(
      "--head", `${$("top").offsetHeight}px`)).observe($("top"));
    window.__hmi = this;         // for tests and the bench
    document.addEventListener("visibilitychange", () => this.visibility());
    this.connect();
  }

  // Something to draw: one animation frame is asked for (none while nothing changed, none
  // while the page is hidden; frame() asks again while it has more to do).
  get dirty() { return this._dirty; }
  set dirty(v) { this._dirty = v; if (v) this.kick(); }

  kick() {
    if (this.framePending || this.hidden) return;
    this.framePending = true;
    requestAnimationFrame((t) => this.frame(t));
  }

  // A page in the background (another tab, a minimized window) draws nothing and asks the
  // server to hold the samples back (op "view"); shown again it draws what comes from then.
  visibility() {
    this.hidden = this.stats.hidden = document.visibilityState === "hidden";
    this.send({ op: "view", hidden: this.hidden });
    if (!this.hidden) { this.feetDirty = true; this.dirty = true; if (this.pose) this.pose.changed = true; }
  }

  connect() {
    const proto = location.protocol === "https:" ? "wss" : "ws";
    const ws = new WebSocket(`${proto}://${location.host}/ws`);
    this.ws = ws;
    ws.onopen = () => {
      this.wsUp = true; this.retry = 250;
      if (this.hidden) this.send({ op: "view", hidden: true });
      const token = sessionStorage.getItem("esair-hmi-token");
      if (token) this.send({ op: "login", token }).then((r) => { if (r.ok) this.setRole("operator"); });
      this.banner();
    };
    ws.onmessage = (ev) => this.receive(JSON.parse(ev.data));
    ws.onclose = () => {
      this.wsUp = false; this.banner();
      for (const [, p] of this.pending) p({ ok: false, error: "connection lost" });
      this.pending.clear();
      setTimeout(() => this.connect(), this.retry);
      this.retry = Math.min(this.retry * 2, 2000);
    };
  }

  send(msg) {
    return new Promise((resolve) => {
      if (!this.ws || this.ws.readyState !== WebSocket.OPEN) {
        resolve({ ok: false, error: "not connected" }); return;
      }
      msg.id = this.nextId++;
      this.pending.set(msg.id, resolve);
      this.ws.send(JSON.stringify(msg));
    });
  }

  // A command; its line in the log comes from the server (every page's, refused or not),
  // the page adds one only when the server could not (not connected).
  async command(resource, command) {
    const r = await this.send({ op: "cmd", resource, command });
    if (!r.ok && !r.logged) this.log.add("error", `${resource} ${JSON.stringify(command)}: ${r.error}`);
    return r;
  }

  async record() {
    const r = await this.send({ op: "record", on: !this.recordingOn });
    if (!r.ok) this.log.add("error", `record: ${r.error}`);
    else { this.recording(r.result); this.replay.refresh(); }
  }

  recording(m) {
    this.recordingOn = m.on;
    $("record").classList.toggle("on", m.on);
    $("record").textContent = m.on ? "■ stop rec" : "● rec";
    $("record").title = m.on ? `recording to ${m.file}` : "record every sample the page receives to MCAP";
  }

  async stop() {
    const r = await this.send({ op: "stop" });
    if (!r.ok && !r.logged) this.log.add("error", `STOP not sent: ${r.error}`);
  }

  async release() {
    const r = await this.send({ op: "release" });
    if (!r.ok) this.log.add("error", `release: ${r.error}`);
  }

  // The runtime's latched STOP (docs/hmi.md): a banner that stays until an operator
  // releases it, on every page, one opened later too (hello's "latch").
  latched(m) {
    const on = !!(m && m.stopped);
    document.body.classList.toggle("stopped", on);
    $("latch-text").textContent = on ? `STOPPED by ${m.by} at ${m.at}${m.reason ? ` (${m.reason})` : ""}`
      + ": every command is refused until an operator releases it" : "";
    $("latch").hidden = !on;
  }

  async login() {
    const r = await this.send({ op: "login", user: $("login-user").value, password: $("login-pass").value });
    $("login-pass").value = "";
    if (r.ok) {
      sessionStorage.setItem("esair-hmi-token", r.result.token);
      this.setRole("operator");
      this.log.add("info", `logged in as ${r.result.user}`);
    } else this.log.add("error", `login: ${r.error}`);
  }

  setRole(role, loginOffered) {
    this.role = role;
    document.body.classList.toggle("viewer", role !== "operator");
    $("role").textContent = role;
    $("stop").disabled = role !== "operator";
    if (loginOffered !== undefined) this.loginOffered = loginOffered;
    $("login").hidden = !(this.loginOffered && role !== "operator");
  }

  receive(m) {
    switch (m.t) {
      case "b":                                        // a batch (server.py, emit)
        this.flushedAt = m.f;
        for (const x of m.m) this.receive(x);
        this.flushedAt = null;
        return;
      case "hello": return this.hello(m);
      case "ack": {
        const p = this.pending.get(m.id);
        if (p) { this.pending.delete(m.id); p(m); }
        else if (!m.ok) this.log.add("error", m.error);
        return;
      }
      case "s": return this.sample(m);
      case "ls": this.rows = m.rows; this.components.update(m.rows); this.generic.rows(m.rows);
        this.linkbar(); return;
      case "link": this.link = m.link; this.linkbar(); this.banner(); return;
      case "runtime": this.runtimeUp = m.up; this.banner(); return;
      case "log": this.log.add(m.level, m.text); return;
      case "commanded": return this.commanded(m.r, m.v, m.played);
      case "watched": return;
      case "state": this.generic.state(m.r, m.v); this.dirty = true; return;
      case "recording": return this.recording(m);
      case "latch": return this.latched(m.v);
      default: this.log.add("warning", `unknown message ${m.t}`);
    }
  }

  hello(m) {
    $("robot-name").textContent = m.robot;
    document.title = `ESAIR ${m.robot}`;
    this.robots = m.robots;
    this.link = m.link; this.runtimeUp = m.runtime_up;
    this.setRole(m.role, m.login);
    const [entry, info] = Object.entries(m.robots)[0] || [null, null];
    this.entry = entry; this.info = info;
    this.pose = new Pose($("pose"), $("pose-note"), info);
    this.joints = new Joints($("joints"), $("live"), info, entry, this);
    this.motions = new Motions($("motions"), info, entry, this);
    this.feet = new Feet($("feet"), $("pause"), $("feet-note"), info);
    $("feet-panel").hidden = !info;
    $("pose-panel").hidden = $("joints-panel").hidden = !info;
    this.generic = new Generic($("sensors"), $("actuators"), m.robots, this, $("states"));
    this.rows = m.rows; this.components.update(m.rows); this.generic.rows(m.rows);
    for (const s of m.last || []) {          // each sensor's last sample (a MIN robot's: live only)
      if (!(entry && s.r.startsWith(`${entry}.`))) this.generic.sample(s);
    }
    for (const s of m.states || []) this.generic.state(s.r, s.v);
    for (const p of m.problems) this.log.add("warning", p);
    this.recording(m.recording);
    this.latched(m.latch);
    this.replay.refresh();
    for (const [res, v, played] of m.commanded || []) this.commanded(res, v, played);
    this.linkbar(); this.banner();
  }

  sample(m) {
    this.stats.samples++;
    if (this.replay.active) return;               // the plot shows a recording
    if (this.entry && m.r === `${this.entry}.feet`) {
      const st = this.stats, got = performance.timeOrigin + performance.now();
      keep(st.arrivals, got - m.ts * 1000);
      if (m.rx != null && this.flushedAt != null) {
        keep(st.hop, (m.rx - m.ts) * 1000); keep(st.hmi, (this.flushedAt - m.rx) * 1000);
        keep(st.wire, got - this.flushedAt * 1000);
      }
      this.feet.push(m, got); this.feetDirty = true; this.kick();
    }
    else if (this.entry && m.r === `${this.entry}.notices`) {
      const text = (m.v && m.v.notice) || "";
      const level = text.startsWith("E") ? "error" : text.startsWith("R ") ? "warning" : "info";
      this.log.add(level, `${this.entry}: !${text}`);
      if (text.startsWith("R ")) { this.feet.marker(m.ts, text); this.feetDirty = true; this.kick(); }
    } else { this.generic.sample(m); this.dirty = true; }
  }

  // A command that went through (`played`: where a motion is, commanded.py played_at: the
  // ms it has played, stopped or not; sent with a STOP and to a page opened later, so
  // every page shows the frame the motion had reached, from the same numbers).
  commanded(res, v, played) {
    if (!this.entry) return;
    if (res.startsWith(`${this.entry}.servo.`)) {
      const servo = res.slice(this.entry.length + 7);
      const angle = typeof v === "object" ? v.angle : v;
      this.pose.set({ [servo]: angle }); this.joints.set(servo, angle);
    } else if (res === `${this.entry}.motion`) {
      const mo = this.motionOf(played ? played.v : v);
      this.played = played || (mo ? { v, ms: 0, stopped: false } : null);
      if (played && played.stopped) {
        this.pose.halt();
        const i = mo ? this.pose.frameAt(mo, this.info.tick_s, played.ms) : -1;
        if (i >= 0) { this.pose.show(mo, i); this.joints.sync(this.pose.angles); }
      } else if (v === "stop") this.pose.halt();
      else if (mo) this.pose.play(mo, this.info.tick_s, played ? played.ms : 0);
    }
    this.dirty = true;
  }

  // the motion of the robot's EEPROM image a motion command plays ("stand", {play: name or number})
  motionOf(v) {
    const name = v === "stand" ? "stand" : v && v.play !== undefined ? v.play : null;
    if (name === null) return null;
    return this.info.motions.find((x) => x.name === name || x.number === Number(name)) || null;
  }

  linkbar() {
    const pills = [];
    const pill = (cls, text, title) => pills.push([`pill ${cls}`, text, title || ""]);
    pill(this.wsUp ? "ready" : "down", this.wsUp ? "hmi ready" : "hmi lost");
    pill(this.runtimeUp ? "ready" : "down", this.runtimeUp ? "runtime ready" : "runtime lost");
    for (const [entry, l] of Object.entries(this.link)) {
      const state = l.state === "lost" ? "lost · reconnecting" : l.state;
      const bits = [`${entry} link ${state}`];
      if (l.reply_age_s != null) bits.push(`reply ${l.reply_age_s < 10 ? l.reply_age_s.toFixed(2) : ">10"} s ago`);
      if (l.commands_per_s != null) bits.push(`${l.commands_per_s} cmd/s`);
      if (l.errors != null) bits.push(counted(l.errors, "error"));
      pill(l.state, bits.join(" · "), `${l.host || ""} pid ${l.pid || "?"} ${l.reason || ""}`);
    }
    // each computer the resources run on (the host column of `esair std ls`): all of its
    // resources ready, or how many are not (their names in the pill's title)
    const hosts = new Map();
    for (const r of this.rows || []) {
      if (r.kind === "behavior") continue;
      if (!hosts.has(r.host)) hosts.set(r.host, {n: 0, down: [], pids: new Set()});
      const h = hosts.get(r.host);
      h.n++; h.pids.add(r.pid);
      if (r.state !== "ready") h.down.push(`${r.name} ${r.state}`);
    }
    for (const [host, h] of hosts) {
      const text = h.down.length ? `${host} · ${h.down.length} of ${counted(h.n, "resource")} not ready`
        : `${host} · ${counted(h.n, "resource")} ready`;
      pill(h.down.length ? "lost" : "ready", text,
           [`resource host ${host}, pid ${[...h.pids].join(", ")}`, ...h.down].join("\n"));
    }
    // the pills are kept and only what changed is set (the link comes 4 times a second)
    const bar = $("linkbar");
    while (bar.children.length > pills.length) bar.lastChild.remove();
    while (bar.children.length < pills.length) bar.append(document.createElement("span"));
    pills.forEach(([cls, text, title], i) => {
      const s = bar.children[i];
      if (s.className !== cls) s.className = cls;
      if (s.textContent !== text) s.textContent = text;
      if (s.title !== title) s.title = title;
    });
  }

  banner() {
    const b = $("banner");
    let text = "";
    if (!this.wsUp) text = "Connection to the HMI server lost — reconnecting…";
    else if (!this.runtimeUp) text = "The robot's runtime does not answer — retrying…";
    else for (const [entry, l] of Object.entries(this.link)) {
      if (l.state !== "ready") { text = `LINK LOST: ${entry} — ${l.reason || l.state} — reconnecting…`; break; }
    }
    b.textContent = text; b.hidden = !text;
    this.linkbar();
  }

  // A frame draws what changed since the last one (every sample that came meanwhile at
  // once, the pose and the sliders as the commands left them): the feet plot at the
  // first frame after a sample (at most FEET_FPS a second: the samples come at 50 Hz
  // and a person reads the plot's newest end), the rest at most FPS times a second;
  // each at most DRAW_SHARE of the page's time: when drawing is slow (a busy computer,
  // many pages) frames are skipped rather than the whole page falling behind. Each
  // frame drawn costs the browser far more than the drawing itself (its commit, raster
  // and compositing: docs/hmi.md), so nothing draws outside these frames.
  frame(now) {
    this.framePending = false;
    if (this.hidden) return;
    this.stats.frames++;
    let again = false;
    let drew = false;
    if (this.feetDirty && now - this.feetAt < this.feetGap) again = true;
    else if (this.feetDirty) {
      this.feetDirty = false;
      const t0 = performance.now();
      if (this.feet) this.feet.draw(performance.timeOrigin + t0, this.stats);
      const cost = this.cost(t0); drew = true;
      this.feetCost = 0.8 * this.feetCost + 0.2 * Math.min(cost, 2 * this.feetCost + 1);
      this.feetGap = Math.min(MAX_DRAW_GAP_MS, Math.max(MIN_FEET_GAP_MS, this.feetCost / DRAW_SHARE));
      this.feetAt = now;
    }
    // the rest rides in a frame the feet draw while they come (one frame, not two)
    const feetLive = !drew && now - this.feetAt < FEET_LIVE_MS;
    if (this._dirty && (now - this.drawnAt < this.drawGap || feetLive)) again = true;
    else if (this._dirty) {
      this._dirty = false;
      const t0 = performance.now();
      if (this.generic) this.generic.draw();
      if (this.pose) {
        if (this.pose.animate(now)) this.joints.sync(this.pose.angles);
        // a motion plays, or the sliders wait for their next turn: drawn again later
        const waiting = this.joints.show(now);
        if (this.pose.motion || this.pose.changed || waiting) this._dirty = again = true;
      }
      // a frame whose drawing was cut by the computer (another process got the core)
      // counts at most twice the estimate and 1 ms: drawing that stays slow raises the
      // estimate within a few frames, one preemption does not skip the next frames
      const cost = this.cost(t0); drew = true;
      this.drawCost = 0.8 * this.drawCost + 0.2 * Math.min(cost, 2 * this.drawCost + 1);
      this.drawGap = Math.min(MAX_DRAW_GAP_MS, Math.max(MIN_DRAW_GAP_MS, this.drawCost / DRAW_SHARE));
      this.drawnAt = now;
    }
    if (drew) this.stats.draws++;             // frames that drew something
    if (again) this.kick();
  }

  cost(t0) {                      // the drawing since t0 (ms), counted for the bench
    const cost = performance.now() - t0;
    this.stats.drawMs += cost;
    return cost;
  }
}

window.addEventListener("DOMContentLoaded", () => new App());
