// The foot pressure sensors: a rolling 10 s plot of every sensor, and of the two feet's
// sums with |L - R| against the balance threshold; the reaction's !R notices as markers.
const WINDOW_S = 10;
const COLORS = ["#2563eb", "#3b82f6", "#60a5fa", "#93c5fd", "#b45309", "#d97706", "#f59e0b", "#fbbf24"];
const LAT_KEEP = 20000;
const NOTE_MS = 250;

export class Feet {
  constructor(el, pauseBtn, note, info) {
    this.el = el; this.note = note; this.info = info; this.paused = false;
    this.markers = []; this.fresh = []; this.noteAt = -1e9; this.noteMarks = 0;
    this.changed = false; this.visible = true;        // drawn only when both (app.js, frame)
    el.textContent = "";
    if (!info || typeof uPlot === "undefined") return;
    this.names = info.sensors.map((s) => s.name);
    const bal = info.balance || { compare: Object.keys(info.groups).slice(0, 2), threshold: null };
    this.compare = bal.compare; this.threshold = bal.threshold;
    this.t = []; this.v = this.names.map(() => []);
    this.l = []; this.r = []; this.d = []; this.th = [];
    const w = Math.max(280, el.clientWidth || 400);
    const marks = { hooks: { draw: [(u) => this.drawMarkers(u)] } };
    const base = (h, series, range) => ({
      width: w, height: h, legend: { show: true, live: false }, cursor: { show: false },
      scales: { x: { time: true }, y: { range } }, plugins: [marks],
      series: [{}, ...series.map((x) => ({ points: { show: false }, ...x }))] });
    this.top = new uPlot(base(150, this.names.map((n, i) => ({ label: n, stroke: COLORS[i % 8], width: 1 })),
      [0, 1023]), [this.t, ...this.v], el);
    this.bottom = new uPlot(base(150, [
      { label: `L ${this.compare[0]}`, stroke: "#2563eb", width: 2 },
      { label: `R ${this.compare[1]}`, stroke: "#b45309", width: 2 },
      { label: "|L−R|", stroke: "#b91c1c", width: 2 },
      { label: `threshold ${this.threshold}`, stroke: "#6b7280", dash: [6, 4], width: 1 }],
      (u, min, max) => [0, Math.max(max, 4 * 1023)]), [this.t, this.l, this.r, this.d, this.th], el);
    pauseBtn.addEventListener("click", () => {
      this.paused = !this.paused; pauseBtn.textContent = this.paused ? "resume" : "pause";
      pauseBtn.classList.toggle("on", this.paused);
    });
    // off screen (scrolled away, a narrow window): no drawing until it shows again
    if (typeof IntersectionObserver !== "undefined") {
      new IntersectionObserver((es) => {
        this.visible = es[es.length - 1].isIntersecting;
        if (this.visible) this.changed = true;
      }).observe(el);
    }
    window.addEventListener("resize", () => {
      const width = Math.max(280, el.clientWidth);
      this.top.setSize({ width, height: 150 }); this.bottom.setSize({ width, height: 150 });
    });
  }

  push(m, got) {                   // got: when the page got it (ms since the epoch)
    if (!this.top || !m.v || !m.v.values) return;
    this.t.push(m.ts);
    this.names.forEach((n, i) => this.v[i].push(m.v.values[n]));
    const L = m.v.groups[this.compare[0]], R = m.v.groups[this.compare[1]];
    this.l.push(L); this.r.push(R); this.d.push(Math.abs(L - R)); this.th.push(this.threshold);
    if (got !== undefined) this.fresh.push([m.ts, got]);
    this.changed = true;
    const old = m.ts - WINDOW_S;
    let cut = 0;
    while (cut < this.t.length && this.t[cut] < old) cut++;
    if (cut) for (const a of [this.t, ...this.v, this.l, this.r, this.d, this.th]) a.splice(0, cut);
    this.markers = this.markers.filter((k) => k.ts >= old);
    this.last = { L, R, d: Math.abs(L - R), seq: m.q };
  }

  clear() {
    if (!this.top) return;
    for (const a of [this.t, ...this.v, this.l, this.r, this.d, this.th]) a.length = 0;
    this.markers = []; this.fresh = []; this.last = null; this.changed = true; this.noteAt = -1e9;
  }

  marker(ts, text) {
    this.markers.push({ ts, text }); this.lastMarker = { ts, text }; this.changed = true;
  }

  drawMarkers(u) {
    const c = u.ctx; c.save(); c.strokeStyle = "#b91c1c"; c.fillStyle = "#b91c1c"; c.lineWidth = 2;
    c.font = `${11 * devicePixelRatio}px system-ui`;
    for (const k of this.markers) {
      const x = u.valToPos(k.ts, "x", true);
      if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) continue;
      c.beginPath(); c.moveTo(x, u.bbox.top); c.lineTo(x, u.bbox.top + u.bbox.height); c.stroke();
      c.fillText("!R", x + 3, u.bbox.top + 12 * devicePixelRatio);
    }
    c.restore();
  }

  // Draw what changed (the samples since the last frame at once); stats.latencies: each
  // sample drawn, its time stamp -> this frame (drawnAt, ms since the epoch), stats.waits:
  // the page got it -> this frame. Off screen: nothing drawn, nothing counted.
  draw(drawnAt, stats) {
    if (!this.top || !this.changed) return;
    if (!this.visible) { this.fresh = []; return; }
    this.changed = false;
    for (const [ts, got] of this.fresh) {
      stats.latencies.push(drawnAt - ts * 1000); stats.waits.push(drawnAt - got);
      if (stats.latencies.length > LAT_KEEP) { stats.latencies.shift(); stats.waits.shift(); }
    }
    this.fresh = [];
    if (this.paused) return;
    this.top.setData([this.t, ...this.v]);
    this.bottom.setData([this.t, this.l, this.r, this.d, this.th]);
    // the numbers under the title: text changes lay the page out again, 4 times a second
    // is enough to read them
    if (this.last && (drawnAt - this.noteAt >= NOTE_MS || this.markers.length !== this.noteMarks)) {
      this.noteAt = drawnAt; this.noteMarks = this.markers.length;
      const over = this.threshold != null && this.last.d > this.threshold;
      this.note.textContent = `L ${this.last.L} · R ${this.last.R} · |L−R| ${this.last.d}` +
        (this.threshold != null ? (over ? ` > ${this.threshold}` : ` ≤ ${this.threshold}`) : "") +
        ` · #${this.last.seq}` + (this.markers.length ? ` · ${this.markers.length} !R` : "");
      this.note.classList.toggle("over", over);
    }
  }
}
