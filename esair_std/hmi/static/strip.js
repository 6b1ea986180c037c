// A strip chart that scrolls: the last `window_s` seconds of some series against time,
// newest on the right. A frame moves the pixels already drawn left by the time that
// passed (one drawImage of the plot onto itself) and draws only the new segments (and
// the horizontal grid and constant lines, a threshold, under them), so a frame costs
// the same whether the window holds 10 samples or 10 000 (docs/hmi.md, "Where a page's
// CPU goes"). One opaque canvas: the compositor copies it without blending. The axes'
// labels around the plot are drawn once per size. The data stays with the caller
// (arrays of time stamps and values); a full redraw (first frame, resize, resume, a
// jump back in time) draws the whole window from them.
const PAD = { l: 38, r: 6, t: 6, b: 16 };        // CSS pixels around the plot
const GRID = "#e5e7eb", INK = "#6b7280", PAPER = "#fff";

export class Strip {
  // opts: {height, range: [lo, hi], window_s, series: [{label, color, width}],
  //        lines: [{value, label, color, dash}], mark: "#b91c1c"}
  constructor(parent, opts) {
    this.o = opts;
    this.el = document.createElement("div"); this.el.className = "strip";
    this.fg = document.createElement("canvas");
    this.ctx = this.fg.getContext("2d", { alpha: false });
    this.el.append(this.fg);
    const legend = document.createElement("div"); legend.className = "legend";
    for (const s of [...opts.series, ...(opts.lines || [])]) {
      const k = document.createElement("span"); k.style.setProperty("--c", s.color);
      if (s.dash) k.className = "dash";
      k.textContent = s.label; legend.append(k);
    }
    parent.append(this.el, legend);
    this.head = null;           // the time stamp of the newest sample drawn, null: redraw all
    this.headX = 0;             // its column (device pixels since the epoch)
    this.frames = { full: 0, scrolled: 0 };     // how each frame was drawn (tests)
  }

  // width in CSS pixels: both canvases sized to it (times the device pixel ratio), the
  // axes drawn, the data redrawn at the next frame
  size(width) {
    const r = window.devicePixelRatio || 1, h = this.o.height;
    this.r = r; this.W = Math.round(width * r); this.H = Math.round(h * r);
    const c = this.fg;
    c.width = this.W; c.height = this.H; c.style.width = `${width}px`; c.style.height = `${h}px`;
    this.L = Math.round(PAD.l * r); this.R = this.W - Math.round(PAD.r * r);
    this.T = Math.round(PAD.t * r); this.B = this.H - Math.round(PAD.b * r);
    this.pps = (this.R - this.L) / this.o.window_s;          // device pixels a second
    this.axes();
    this.head = null;
  }

  y(v) {
    const [lo, hi] = this.o.range;
    const f = Math.min(1, Math.max(0, (v - lo) / (hi - lo)));
    return this.B - f * (this.B - this.T);
  }

  // the labels and ticks around the plot, and an empty plot
  axes() {
    const c = this.ctx, r = this.r, [lo, hi] = this.o.range;
    c.fillStyle = PAPER; c.fillRect(0, 0, this.W, this.H);
    c.font = `${10 * r}px system-ui`; c.fillStyle = INK; c.strokeStyle = INK; c.lineWidth = r;
    c.textAlign = "right"; c.textBaseline = "middle";
    for (let i = 0; i <= 4; i++) {
      const v = lo + (hi - lo) * i / 4;
      c.fillText(String(Math.round(v)), this.L - 4 * r, Math.min(this.B - 4 * r, Math.max(this.T + 4 * r, this.y(v))));
    }
    c.textAlign = "center"; c.textBaseline = "top";
    const w = this.o.window_s;
    for (let s = 0; s <= w; s += w / 5) {
      const x = Math.round(this.R - s * this.pps) + 0.5;
      c.beginPath(); c.moveTo(x, this.B); c.lineTo(x, this.B + 3 * r); c.stroke();
      c.fillText(s ? `−${s} s` : "now", Math.min(x, this.R - 10 * r), this.B + 4 * r);
    }
    this.paper(this.L, this.R);
  }

  // columns x0..x1 of the plot emptied: paper, the horizontal grid, the constant lines
  paper(x0, x1) {
    const c = this.ctx, r = this.r, [lo, hi] = this.o.range;
    c.fillStyle = PAPER; c.fillRect(x0, 0, x1 - x0, this.B + 1);
    c.strokeStyle = GRID; c.lineWidth = r; c.beginPath();
    for (let i = 0; i <= 4; i++) {
      const y = Math.round(this.y(lo + (hi - lo) * i / 4)) + 0.5;
      c.moveTo(x0, y); c.lineTo(x1, y);
    }
    c.stroke();
    for (const l of this.o.lines || []) {
      if (l.value == null) continue;
      const y = Math.round(this.y(l.value)) + 0.5;
      const dash = (l.dash || []).map((d) => d * r), period = dash.reduce((a, b) => a + b, 0) || 1;
      // the dashes move with the time, as the data (the phase taken modulo the pattern
      // here: the canvas keeps it in single precision, too coarse for columns since 1970)
      c.strokeStyle = l.color; c.setLineDash(dash);
      c.lineDashOffset = (((x0 + this.headX - this.R) % period) + period) % period;
      c.beginPath(); c.moveTo(x0, y); c.lineTo(x1, y); c.stroke(); c.setLineDash([]);
    }
  }

  // Draw up to the newest sample of t (seconds) / cols (one array of values per series,
  // null or undefined: a gap), and the markers ({ts, text}) in the window. A marker
  // that comes after the samples around it were drawn is drawn when it comes.
  draw(t, cols, markers) {
    const n = t.length, c = this.ctx;
    if (!n) { if (this.head !== null) { this.paper(this.L, this.R); this.head = null; } return; }
    const headX = Math.round(t[n - 1] * this.pps);
    let from = -1;                              // the index of the sample drawn last
    if (this.head !== null && t[n - 1] >= this.head) {
      for (let i = n - 1; i >= 0 && t[i] >= this.head; i--) if (t[i] === this.head) { from = i; break; }
    }
    const shift = headX - this.headX;
    c.save();
    c.beginPath(); c.rect(this.L, 0, this.R - this.L, this.B + 1); c.clip();
    this.headX = headX;
    if (from < 0 || shift >= this.R - this.L) {                       // the whole window
      this.paper(this.L, this.R);
      from = 0;
      this.frames.full++;
      this.drawn = new Set();
    } else {
      if (shift > 0) {                           // the drawn pixels move left with time
        c.drawImage(this.fg, this.L + shift, 0, this.R - this.L - shift, this.B + 1,
          this.L, 0, this.R - this.L - shift, this.B + 1);
        this.paper(this.R - shift, this.R);
      }
      this.frames.scrolled++;
    }
    const x = (ts) => this.R - (headX - Math.round(ts * this.pps));
    const first = t[n - 1] - this.o.window_s;
    c.lineJoin = "round";
    this.o.series.forEach((s, k) => {
      const v = cols[k];
      c.strokeStyle = s.color; c.lineWidth = (s.width || 1) * this.r;
      c.beginPath();
      let pen = false;
      for (let i = from; i < n; i++) {
        if (t[i] < first - 1 || v[i] == null) { pen = false; continue; }
        const px = x(t[i]), py = this.y(v[i]);
        if (pen) c.lineTo(px, py); else c.moveTo(px, py);
        pen = true;
      }
      c.stroke();
    });
    // markers: a line, and "!R" on its left (the pixels right of the head are cleared
    // at the next frame); each drawn once on a canvas that keeps it
    c.strokeStyle = c.fillStyle = this.o.mark || "#b91c1c"; c.lineWidth = 2 * this.r;
    c.font = `${11 * this.r}px system-ui`; c.textAlign = "right"; c.textBaseline = "top";
    for (const m of markers) {
      if (this.drawn.has(m) || m.ts > t[n - 1] || m.ts < first) continue;
      const px = x(m.ts);
      c.beginPath(); c.moveTo(px, this.T); c.lineTo(px, this.B); c.stroke();
      c.fillText("!R", px - 3 * this.r, this.T + 2 * this.r);
      this.drawn.add(m);
    }
    for (const m of this.drawn) if (m.ts < first) this.drawn.delete(m);
    c.restore();
    this.head = t[n - 1];
  }

  // the next draw redraws the whole window (resume after a pause, shown again)
  redraw() { this.head = null; }
}
