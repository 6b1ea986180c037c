// Panels for any robot from its resource kinds and samples: a numeric sensor gets a
// plot, an image sensor ({image: data URL or base64}) a picture; a room sensor ({walls})
// and the pose sensors ({x, y}) of one resource entry share that entry's map; a
// behavior's state (its `get`) is shown as fields, with a dial for a bearing in it (also
// drawn on the map); an audio frame ({pcm: base64 int16, channels, n, rate}) a plot of
// each channel's level and a line of its rate; an actuator that is not a MIN robot's
// servo or motion gets a command box.
import { showFields } from "./fields.js";
import { counted } from "./words.js";
const WINDOW_S = 10;
const FLOOR_DB = -80;        // an audio level plot's bottom (dBFS): silence is drawn there

export class Generic {
  constructor(sensorsEl, actuatorsEl, robots, app, statesEl) {
    this.sEl = sensorsEl; this.aEl = actuatorsEl; this.app = app; this.panels = {}; this.acts = {};
    this.stEl = statesEl; this.maps = {}; this.states = {};
    if (statesEl) statesEl.textContent = "";
    this.own = Object.keys(robots).map((e) => `${e}.`);
    sensorsEl.textContent = ""; actuatorsEl.textContent = "";
  }

  mine(name) { return this.own.some((p) => name.startsWith(p)); }

  rows(rows) {
    for (const r of rows) {
      if (r.kind !== "actuator" || this.mine(r.name) || this.acts[r.name]) continue;
      const box = document.createElement("form"); box.className = "generic";
      const input = document.createElement("input"); input.placeholder = "command (JSON or text)"; input.size = 16;
      const b = document.createElement("button"); b.textContent = `send to ${r.name}`;
      box.append(input, b);
      input.addEventListener("input", () => input.setCustomValidity(""));
      box.addEventListener("submit", (e) => {
        e.preventDefault();
        // JSON or text, as `esair std send`: text that starts like JSON ({ [ ") must be
        // JSON, so a typo is not sent to the robot as a string
        let cmd = input.value;
        try { cmd = JSON.parse(cmd); } catch (err) {
          if (/^\s*[[{"]/.test(cmd)) {
            input.setCustomValidity(`not JSON: ${err.message}`); input.reportValidity();
            this.app.log.add("error", `${r.name}: not sent: not JSON (${err.message})`);
            return;
          }
        }
        this.app.command(r.name, cmd);
      });
      this.aEl.append(box); this.acts[r.name] = box;
      this.aEl.parentElement.hidden = false;
    }
  }

  sample(m) {
    const v = m.v;
    if (v && typeof v === "object" && (Array.isArray(v.walls) ||
        (typeof v.x === "number" && typeof v.y === "number"))) {
      const map = this.map(m.r.split(".")[0]);
      map.push(m); map.changed = true;
      return;
    }
    let p = this.panels[m.r];
    if (!p) p = this.panels[m.r] = this.make(m);
    if (p) { p.push(m); p.changed = true; }
  }

  box(title, first = false) {       // maps and pictures first, plots after them
    const box = document.createElement("div"); box.className = "generic";
    const t = document.createElement("div"); t.textContent = title; box.append(t);
    if (first) this.sEl.prepend(box); else this.sEl.append(box);
    this.sEl.parentElement.hidden = false;
    return box;
  }

  map(entry) {
    let map = this.maps[entry];
    if (!map) {
      const box = this.box(`${entry} map`, true); box.dataset.map = entry;
      map = this.maps[entry] = this.panels[`map:${entry}`] = new RoomMap(box);
    }
    return map;
  }

  state(name, v) {
    if (!this.stEl) return;
    let st = this.states[name];
    if (!st) {
      const box = document.createElement("div"); box.className = "generic"; box.dataset.state = name;
      const t = document.createElement("div"); t.textContent = name; box.append(t);
      this.stEl.append(box); this.stEl.parentElement.hidden = false;
      st = this.states[name] = new State(box);
    }
    const b = bearingOf(v);
    st.push(v, b); st.changed = true;
    if (b) for (const map of Object.values(this.maps)) if (map.pose) { map.aim(b); map.changed = true; }
  }

  make(m) {
    const v = m.v;
    const image = v && typeof v === "object" && typeof v.image === "string";
    const box = this.box(m.r, image);
    if (image) return new Picture(box);
    if (audioFrame(v) && typeof uPlot !== "undefined") return new AudioLevels(box, v.channels);
    const fields = numbers(v);
    if (fields && typeof uPlot !== "undefined") return new Plot(box, Object.keys(fields));
    const pre = document.createElement("pre"); box.append(pre);
    return { push: (s) => { pre.textContent = JSON.stringify(s.v); }, draw() {} };
  }

  draw() {                     // only what changed since the last frame
    for (const p of Object.values(this.panels)) if (p && p.changed) { p.changed = false; p.draw(); }
    for (const st of Object.values(this.states)) if (st.changed) { st.changed = false; st.draw(); }
  }
}

function numbers(v) {
  if (typeof v === "number") return { value: v };
  if (!v || typeof v !== "object") return null;
  const out = {};
  for (const [k, x] of Object.entries(v)) {
    if (typeof x === "number") out[k] = x;
    else if (x && typeof x === "object") for (const [k2, y] of Object.entries(x)) if (typeof y === "number") out[`${k}.${k2}`] = y;
  }
  return Object.keys(out).length ? out : null;
}

class Plot {
  constructor(box, keys) {
    this.keys = keys; this.t = []; this.cols = keys.map(() => []);
    this.u = new uPlot({ width: Math.max(260, box.clientWidth || 300), height: 120, cursor: { show: false },
      scales: { x: { time: true } }, series: [{}, ...keys.map((k, i) => ({ label: k, stroke: `hsl(${i * 67},60%,45%)` }))] },
    [this.t, ...this.cols], box);
  }
  push(m) {
    const f = numbers(m.v) || {};
    this.t.push(m.ts); this.keys.forEach((k, i) => this.cols[i].push(f[k] ?? null));
    let cut = 0; while (cut < this.t.length && this.t[cut] < m.ts - WINDOW_S) cut++;
    if (cut) for (const a of [this.t, ...this.cols]) a.splice(0, cut);
  }
  draw() { this.u.setData([this.t, ...this.cols]); }
}

// {pcm: base64 of n x channels int16 (little-endian, interleaved), channels, n, rate}
function audioFrame(v) {
  return !!v && typeof v === "object" && typeof v.pcm === "string" && Number.isInteger(v.channels) &&
    v.channels > 0 && Number.isInteger(v.n) && v.n > 0 && Number.isInteger(v.rate) && v.rate > 0;
}

// Each channel's RMS level of one frame, dBFS (0: a full-scale square wave), FLOOR_DB at
// the least; null when the frame's pcm does not hold n x channels samples.
export function levels(v) {
  let bin;
  try { bin = atob(v.pcm); } catch { return null; }
  const ch = v.channels;
  if (bin.length !== 2 * ch * v.n) return null;
  const sums = new Float64Array(ch);
  for (let i = 0, k = 0; i < v.n * ch; i++, k += 2) {
    let x = bin.charCodeAt(k) | (bin.charCodeAt(k + 1) << 8);
    if (x >= 32768) x -= 65536;
    sums[i % ch] += x * x;
  }
  return Array.from(sums, (sum) => {
    const rms = Math.sqrt(sum / v.n) / 32768;
    return rms > 0 ? Math.max(FLOOR_DB, Math.round(200 * Math.log10(rms)) / 10) : FLOOR_DB;
  });
}

// An audio sensor: each channel's level per frame (dBFS, the last WINDOW_S seconds), and
// a line with the rate, the frame's size and number, and the frames a second that came.
class AudioLevels {
  constructor(box, channels) {
    this.ch = channels; this.t = []; this.cols = Array.from({ length: channels }, () => []);
    this.last = null; this.note = document.createElement("small");
    this.u = new uPlot({ width: Math.max(260, box.clientWidth || 300), height: 120, cursor: { show: false },
      scales: { x: { time: true }, y: { range: [FLOOR_DB, 0] } },
      axes: [{}, { size: 60, values: (u, ticks) => ticks.map((x) => `${x} dB`) }],
      series: [{}, ...this.cols.map((_, i) => ({ label: `mic ${i + 1}`, stroke: `hsl(${i * 67},60%,45%)` }))] },
    [this.t, ...this.cols], box);
    box.append(this.note);
  }
  push(m) {
    const lv = audioFrame(m.v) && m.v.channels === this.ch ? levels(m.v) : null;
    if (!lv) return;                      // a frame of another shape: not drawn
    this.last = { seq: m.v.seq, rate: m.v.rate, n: m.v.n, levels: lv };
    this.t.push(m.ts); lv.forEach((x, i) => this.cols[i].push(x));
    let cut = 0; while (cut < this.t.length && this.t[cut] < m.ts - WINDOW_S) cut++;
    if (cut) for (const a of [this.t, ...this.cols]) a.splice(0, cut);
  }
  draw() {
    this.u.setData([this.t, ...this.cols]);
    const l = this.last; if (!l) return;
    const span = this.t.length > 1 ? this.t[this.t.length - 1] - this.t[0] : 0;
    const fps = span > 0 ? ((this.t.length - 1) / span).toFixed(1) : "–";
    this.note.textContent = `${l.rate} Hz · ${counted(this.ch, "channel")} · ${counted(l.n, "sample")} a frame · ` +
      `frame ${l.seq} · ${fps} frames/s`;
  }
}

class Picture {
  constructor(box) { this.img = document.createElement("img"); box.append(this.img); }
  push(m) { this.src = m.v.image.startsWith("data:") ? m.v.image : `data:image/${m.v.format || "jpeg"};base64,${m.v.image}`; }
  draw() { if (this.src && this.img.src !== this.src) this.img.src = this.src; }
}

// The map of one resource entry: its room ({walls: [[x1, y1, x2, y2], ...], landmarks}
// samples), its pose sensors' robot ({x, y, th|theta}: a heading arrow and a trail) and a
// behavior's bearing (rad, counter-clockwise from the robot's heading) as a ray from it.
class RoomMap {
  constructor(box) {
    this.c = document.createElement("canvas"); this.c.width = 360; this.c.height = 250; box.append(this.c);
    this.note = document.createElement("small"); box.append(this.note);
    this.walls = []; this.landmarks = []; this.trail = []; this.pose = null; this.bearing = null;
    this.view = { walls: 0, landmarks: 0, pose: null, ray: null };      // what is drawn (tests)
  }
  push(m) {
    const v = m.v;
    if (Array.isArray(v.walls)) {
      this.walls = v.walls.filter((w) => Array.isArray(w) && w.length === 4 && w.every(Number.isFinite));
      this.landmarks = Array.isArray(v.landmarks) ? v.landmarks.filter((l) => l && Number.isFinite(l.x) && Number.isFinite(l.y)) : [];
      return;
    }
    const th = typeof v.th === "number" ? v.th : typeof v.theta === "number" ? v.theta : null;
    this.pose = { x: v.x, y: v.y, th, r: m.r };
    this.trail.push([v.x, v.y]); if (this.trail.length > 500) this.trail.shift();
  }
  aim(bearing) { this.bearing = bearing; }
  bounds() {
    const xs = [], ys = [];
    for (const w of this.walls) { xs.push(w[0], w[2]); ys.push(w[1], w[3]); }
    if (!xs.length) for (const p of this.trail) { xs.push(p[0]); ys.push(p[1]); }
    if (!xs.length) return null;
    return [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  }
  draw() {
    const W = this.c.width, H = this.c.height, c = this.c.getContext("2d");
    c.clearRect(0, 0, W, H);
    const b = this.bounds(); if (!b) return;
    const [x0, x1, y0, y1] = b, pad = 10;
    const s = Math.min((W - 2 * pad) / Math.max(1e-9, x1 - x0), (H - 2 * pad) / Math.max(1e-9, y1 - y0), 200);
    const px = (x, y) => [pad + (x - x0) * s, H - pad - (y - y0) * s];
    c.lineWidth = 3; c.strokeStyle = "#1d2430"; c.beginPath();
    for (const w of this.walls) { c.moveTo(...px(w[0], w[1])); c.lineTo(...px(w[2], w[3])); }
    c.stroke();
    for (const l of this.landmarks) {
      const [x, y] = px(l.x, l.y);
      c.lineWidth = 2; c.beginPath();
      if (l.kind === "access_point") {
        c.strokeStyle = "#2563eb"; c.moveTo(x, y - 7); c.lineTo(x - 6, y + 5); c.lineTo(x + 6, y + 5); c.closePath(); c.stroke();
        if (Number.isFinite(l.range_m)) { c.setLineDash([4, 4]); c.beginPath(); c.arc(x, y, l.range_m * s, 0, 2 * Math.PI); c.stroke(); c.setLineDash([]); }
      } else if (l.kind === "sound") {
        c.strokeStyle = c.fillStyle = "#dc2626"; c.arc(x, y, 6, 0, 2 * Math.PI); if (l.on) c.fill(); else c.stroke();
      } else {
        c.fillStyle = Array.isArray(l.color) ? `rgb(${l.color.join(",")})` : "#6b7280";
        c.arc(x, y, Math.max(3, (l.r || 0.1) * s), 0, 2 * Math.PI); c.fill();
      }
    }
    c.lineWidth = 1.5; c.strokeStyle = "#93c5fd"; c.beginPath();
    this.trail.forEach((p, i) => { const [x, y] = px(p[0], p[1]); if (i) c.lineTo(x, y); else c.moveTo(x, y); });
    c.stroke();
    let ray = null;
    if (this.pose) {
      const [x, y] = px(this.pose.x, this.pose.y), th = this.pose.th ?? 0;
      if (this.bearing && this.pose.th !== null) {
        ray = th + this.bearing.bearing;
        const len = Math.hypot(x1 - x0, y1 - y0) * s;
        c.strokeStyle = `rgba(234,88,12,${Math.max(0.25, Math.min(1, this.bearing.confidence ?? 1))})`;
        c.lineWidth = 2; c.beginPath(); c.moveTo(x, y); c.lineTo(x + len * Math.cos(ray), y - len * Math.sin(ray)); c.stroke();
      }
      c.fillStyle = "#1d4ed8"; c.beginPath(); c.arc(x, y, 7, 0, 2 * Math.PI); c.fill();
      if (this.pose.th !== null) {
        c.strokeStyle = "#fff"; c.lineWidth = 2; c.beginPath(); c.moveTo(x, y);
        c.lineTo(x + 10 * Math.cos(th), y - 10 * Math.sin(th)); c.stroke();
      }
    }
    this.view = { walls: this.walls.length, landmarks: this.landmarks.length,
      pose: this.pose && [this.pose.x, this.pose.y, this.pose.th], ray };
    const p = this.pose;
    this.note.textContent = p ? `${p.r}: x ${p.x.toFixed(2)} y ${p.y.toFixed(2)}` +
      (p.th !== null ? ` θ ${(p.th * 180 / Math.PI).toFixed(1)}°` : "") : "";
  }
}

// A behavior's state (its `get`): its fields, one a row (fields.js), and a dial for a
// bearing in it.
class State {
  constructor(box) {
    this.list = document.createElement("dl"); this.list.className = "fields";
    this.dial = null; this.box = box; box.append(this.list);
  }
  push(v, bearing) {
    this.value = v;
    showFields(this.list, v);
    this.bearing = bearing;
    if (bearing && !this.dial) {
      this.dial = document.createElement("canvas"); this.dial.width = this.dial.height = 110;
      this.text = document.createElement("div"); this.text.className = "bearing";
      this.box.insertBefore(this.text, this.list); this.box.insertBefore(this.dial, this.text);
    }
  }
  draw() {
    if (!this.dial || !this.bearing) return;
    const c = this.dial.getContext("2d"), r = 48, cx = 55, cy = 55, b = this.bearing.bearing;
    c.clearRect(0, 0, 110, 110);
    c.strokeStyle = "#9ca3af"; c.lineWidth = 1; c.beginPath(); c.arc(cx, cy, r, 0, 2 * Math.PI); c.stroke();
    c.fillStyle = "#1d4ed8"; c.beginPath(); c.moveTo(cx, cy - 14); c.lineTo(cx - 7, cy + 6); c.lineTo(cx + 7, cy + 6); c.fill();
    // the robot's heading is up; a positive bearing is to its left
    c.strokeStyle = "#ea580c"; c.lineWidth = 3; c.beginPath(); c.moveTo(cx, cy);
    c.lineTo(cx - r * Math.sin(b), cy - r * Math.cos(b)); c.stroke();
    const conf = this.bearing.confidence;
    this.text.textContent = `bearing ${(b * 180 / Math.PI).toFixed(1)}°` +
      (typeof conf === "number" ? ` · confidence ${conf.toFixed(2)}` : "");
  }
}

// {bearing: rad} in a behavior's state, or in its `last`
export function bearingOf(v) {
  for (const o of [v, v && v.last]) {
    if (o && typeof o === "object" && typeof o.bearing === "number" && Number.isFinite(o.bearing)) {
      return { bearing: o.bearing, confidence: typeof o.confidence === "number" ? o.confidence : null };
    }
  }
  return null;
}
