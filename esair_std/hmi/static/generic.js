// Panels for any robot from its resource kinds and samples: a numeric sensor gets a
// plot, an image sensor ({image: data URL}) a picture, a pose sensor ({x, y}) a map;
// an actuator that is not a MIN robot's servo or motion gets a command box.
const WINDOW_S = 10;

export class Generic {
  constructor(sensorsEl, actuatorsEl, robots, app) {
    this.sEl = sensorsEl; this.aEl = actuatorsEl; this.app = app; this.panels = {}; this.acts = {};
    this.own = Object.keys(robots).map((e) => `${e}.`);
    sensorsEl.textContent = ""; actuatorsEl.textContent = "";
  }

  mine(name) { return this.own.some((p) => name.startsWith(p)); }

  rows(rows) {
    for (const r of rows) {
      if (r.kind !== "actuator" || this.mine(r.name) || this.acts[r.name]) continue;
      const box = document.createElement("form"); box.className = "generic";
      const input = document.createElement("input"); input.placeholder = "command (JSON)"; input.size = 16;
      const b = document.createElement("button"); b.textContent = `send to ${r.name}`;
      box.append(input, b);
      box.addEventListener("submit", (e) => {
        e.preventDefault();
        let cmd = input.value; try { cmd = JSON.parse(cmd); } catch { /* text */ }
        this.app.command(r.name, cmd);
      });
      this.aEl.append(box); this.acts[r.name] = box;
      this.aEl.parentElement.hidden = false;
    }
  }

  sample(m) {
    let p = this.panels[m.r];
    if (!p) p = this.panels[m.r] = this.make(m);
    if (p) p.push(m);
  }

  make(m) {
    const v = m.v;
    const box = document.createElement("div"); box.className = "generic";
    const title = document.createElement("div"); title.textContent = m.r; box.append(title);
    this.sEl.append(box); this.sEl.parentElement.hidden = false;
    if (v && typeof v === "object" && typeof v.image === "string") return new Picture(box);
    if (v && typeof v === "object" && typeof v.x === "number" && typeof v.y === "number") return new PoseMap(box);
    const fields = numbers(v);
    if (fields && typeof uPlot !== "undefined") return new Plot(box, Object.keys(fields));
    const pre = document.createElement("pre"); box.append(pre);
    return { push: (s) => { pre.textContent = JSON.stringify(s.v); }, draw() {} };
  }

  draw() { for (const p of Object.values(this.panels)) if (p) p.draw(); }
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

class Picture {
  constructor(box) { this.img = document.createElement("img"); box.append(this.img); }
  push(m) { this.src = m.v.image.startsWith("data:") ? m.v.image : `data:image/${m.v.format || "jpeg"};base64,${m.v.image}`; }
  draw() { if (this.src && this.img.src !== this.src) this.img.src = this.src; }
}

class PoseMap {
  constructor(box) {
    this.c = document.createElement("canvas"); this.c.width = 300; this.c.height = 200; box.append(this.c);
    this.trail = [];
  }
  push(m) { this.trail.push([m.v.x, m.v.y, m.v.theta]); if (this.trail.length > 500) this.trail.shift(); }
  draw() {
    const c = this.c.getContext("2d"); c.clearRect(0, 0, 300, 200);
    if (!this.trail.length) return;
    const xs = this.trail.map((p) => p[0]), ys = this.trail.map((p) => p[1]);
    const minx = Math.min(...xs), maxx = Math.max(...xs), miny = Math.min(...ys), maxy = Math.max(...ys);
    const s = Math.min(280 / Math.max(1e-9, maxx - minx), 180 / Math.max(1e-9, maxy - miny), 100);
    const px = (p) => [10 + (p[0] - minx) * s, 190 - (p[1] - miny) * s];
    c.strokeStyle = "#2563eb"; c.beginPath();
    this.trail.forEach((p, i) => { const [x, y] = px(p); if (i) c.lineTo(x, y); else c.moveTo(x, y); });
    c.stroke();
    const [x, y] = px(this.trail[this.trail.length - 1]);
    c.fillStyle = "#b91c1c"; c.beginPath(); c.arc(x, y, 4, 0, 2 * Math.PI); c.fill();
  }
}
