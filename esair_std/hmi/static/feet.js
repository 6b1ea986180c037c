// The foot pressure sensors: a rolling 10 s plot of every sensor, and of the two feet's
// sums with |L - R| against the balance threshold; the reaction's !R notices as markers.
// Two strip charts (strip.js): a frame draws only the samples that came since the last.
import { Strip } from "./strip.js";

const WINDOW_S = 10;
const COLORS = ["#2563eb", "#3b82f6", "#60a5fa", "#93c5fd", "#b45309", "#d97706", "#f59e0b", "#fbbf24"];
const LAT_KEEP = 20000;         // bench figures kept (up to twice as many, cut in halves)
const SLACK_S = 1;              // samples kept past the window: cut once a second, not one a sample
const NOTE_MS = 250;
const HEIGHT = 150;

export class Feet {
  constructor(el, pauseBtn, note, info) {
    this.el = el; this.note = note; this.info = info; this.paused = false;
    this.markers = []; this.fresh = []; this.noteAt = -1e9; this.noteMarks = 0; this.noteText = "";
    this.changed = false; this.visible = true;        // drawn only when both (app.js, frame)
    el.textContent = "";
    if (!info) return;
    this.names = info.sensors.map((s) => s.name);
    const bal = info.balance || { compare: Object.keys(info.groups).slice(0, 2), threshold: null };
    this.compare = bal.compare; this.threshold = bal.threshold;
    this.t = []; this.v = this.names.map(() => []);
    this.l = []; this.r = []; this.d = [];
    const top = Math.max(...info.sensors.map((s) => s.max ?? 1023));
    const most = Math.max(...this.compare.map((g) => (info.groups[g] || []).length), 1);
    this.top = new Strip(el, { height: HEIGHT, range: [0, top], window_s: WINDOW_S,
      series: this.names.map((n, i) => ({ label: n, color: COLORS[i % 8], width: 1 })) });
    this.bottom = new Strip(el, { height: HEIGHT, range: [0, top * most], window_s: WINDOW_S,
      series: [
        { label: `L ${this.compare[0]}`, color: "#2563eb", width: 2 },
        { label: `R ${this.compare[1]}`, color: "#b45309", width: 2 },
        { label: "|L−R|", color: "#b91c1c", width: 2 }],
      lines: this.threshold == null ? [] : [
        { label: `threshold ${this.threshold}`, value: this.threshold, color: "#6b7280", dash: [6, 4] }] });
    this.resize();
    pauseBtn.addEventListener("click", () => {
      this.paused = !this.paused; pauseBtn.textContent = this.paused ? "resume" : "pause";
      pauseBtn.classList.toggle("on", this.paused);
      if (!this.paused) { this.top.redraw(); this.bottom.redraw(); this.changed = true; }
    });
    // off screen (scrolled away, a narrow window): no drawing until it shows again
    if (typeof IntersectionObserver !== "undefined") {
      new IntersectionObserver((es) => {
        this.visible = es[es.length - 1].isIntersecting;
        if (this.visible) { this.top.redraw(); this.bottom.redraw(); this.changed = true; }
      }).observe(el);
    }
    window.addEventListener("resize", () => { this.resize(); this.changed = true; });
  }

  resize() {
    const width = Math.max(280, this.el.clientWidth || 400);
    if (width === this.width) return;
    this.width = width; this.top.size(width); this.bottom.size(width);
  }

  push(m, got) {                   // got: when the page got it (ms since the epoch)
    if (!this.top || !m.v || !m.v.values) return;
    if (this.t.length && m.ts < this.t[this.t.length - 1]) return;    // out of order
    this.t.push(m.ts);
    const values = m.v.values;
    for (let i = 0; i < this.names.length; i++) this.v[i].push(values[this.names[i]]);
    const L = m.v.groups[this.compare[0]], R = m.v.groups[this.compare[1]];
    this.l.push(L); this.r.push(R); this.d.push(Math.abs(L - R));
    if (got !== undefined) this.fresh.push(m.ts, got);       // pairs, flat: no array a sample
    this.changed = true;
    const old = m.ts - WINDOW_S;
    if (this.t[0] < old - SLACK_S) {       // the strips skip what is older than the window
      let cut = 0;
      while (cut < this.t.length && this.t[cut] < old) cut++;
      for (const a of [this.t, ...this.v, this.l, this.r, this.d]) a.splice(0, cut);
    }
    if (this.markers.length && this.markers[0].ts < old) this.markers = this.markers.filter((k) => k.ts >= old);
    this.last = { L, R, d: Math.abs(L - R), seq: m.q };
  }

  clear() {
    if (!this.top) return;
    for (const a of [this.t, ...this.v, this.l, this.r, this.d]) a.length = 0;
    this.markers = []; this.fresh = []; this.last = null; this.changed = true; this.noteAt = -1e9;
    this.top.redraw(); this.bottom.redraw();
  }

  marker(ts, text) {
    this.markers.push({ ts, text }); this.lastMarker = { ts, text }; this.changed = true;
  }

  // Draw what changed (the samples since the last frame); stats.latencies: each
  // sample drawn, its time stamp -> this frame (drawnAt, ms since the epoch), stats.waits:
  // the page got it -> this frame. Off screen: nothing drawn, nothing counted.
  draw(drawnAt, stats) {
    if (!this.top || !this.changed) return;
    if (!this.visible) { this.fresh.length = 0; return; }
    this.changed = false;
    const fresh = this.fresh;
    for (let i = 0; i < fresh.length; i += 2) {
      stats.latencies.push(drawnAt - fresh[i] * 1000); stats.waits.push(drawnAt - fresh[i + 1]);
    }
    if (stats.latencies.length >= 2 * LAT_KEEP) { stats.latencies.splice(0, LAT_KEEP); stats.waits.splice(0, LAT_KEEP); }
    fresh.length = 0;
    if (this.paused) return;
    this.top.draw(this.t, this.v, this.markers);
    this.bottom.draw(this.t, [this.l, this.r, this.d], this.markers);
    // the numbers under the title: text changes lay the page out again, 4 times a second
    // is enough to read them
    if (this.last && (drawnAt - this.noteAt >= NOTE_MS || this.markers.length !== this.noteMarks)) {
      this.noteAt = drawnAt; this.noteMarks = this.markers.length;
      const over = this.threshold != null && this.last.d > this.threshold;
      const text = `L ${this.last.L} · R ${this.last.R} · |L−R| ${this.last.d}` +
        (this.threshold != null ? (over ? ` > ${this.threshold}` : ` ≤ ${this.threshold}`) : "") +
        ` · #${this.last.seq}` + (this.markers.length ? ` · ${this.markers.length} !R` : "");
      if (text !== this.noteText) { this.noteText = text; this.note.textContent = text; }
      if (this.note.classList.contains("over") !== over) this.note.classList.toggle("over", over);
    }
  }
}
