// Replay of a recording (MCAP written by the record button or `esair std record`): the
// HMI server reads it; the feet plot shows the 10 s up to the time slider's position,
// with the recording's !R notices as markers. "back to live" returns to the robot.
import { counted } from "./words.js";
const $ = (id) => document.getElementById(id);

export class Replay {
  constructor(app) {
    this.app = app; this.active = false; this.samples = [];
    $("load").addEventListener("click", () => this.load());
    $("timeline").addEventListener("input", () => this.show(Number($("timeline").value)));
    $("live-view").addEventListener("click", () => this.live());
  }

  async refresh() {
    const r = await this.app.send({ op: "recordings" });
    if (!r.ok) return;
    const sel = $("recordings"); const keep = sel.value;
    sel.textContent = "";
    const first = document.createElement("option"); first.value = ""; first.textContent = "recordings…";
    sel.append(first);
    for (const f of r.result.slice().reverse()) {
      const o = document.createElement("option"); o.value = f.file;
      o.textContent = `${f.file} (${Math.ceil(f.bytes / 1024)} KB)`; sel.append(o);
    }
    sel.value = keep;
  }

  async load() {
    const file = $("recordings").value;
    if (!file) { await this.refresh(); return; }
    const r = await this.app.send({ op: "load", file });
    if (!r.ok) { this.app.log.add("error", `replay ${file}: ${r.error}`); return; }
    const feet = `${this.app.entry}.feet`, notices = `${this.app.entry}.notices`;
    this.feetSamples = r.result.samples.filter((s) => s[0] === feet);
    this.notices = r.result.samples.filter((s) => s[0] === notices && String(s[3].notice || "").startsWith("R "));
    if (!this.feetSamples.length) { this.app.log.add("warning", `replay ${file}: no ${feet} samples`); return; }
    this.active = true; document.body.classList.add("replaying");
    this.t0 = this.feetSamples[0][2]; this.t1 = this.feetSamples[this.feetSamples.length - 1][2];
    const tl = $("timeline");
    Object.assign(tl, { min: 0, max: Math.ceil((this.t1 - this.t0) * 20) / 20, disabled: false });
    tl.value = tl.max;
    $("live-view").hidden = false;
    this.app.log.add("info", `replaying ${file}: ${counted(this.feetSamples.length, "feet sample")}, ${(this.t1 - this.t0).toFixed(1)} s`);
    this.show(Number(tl.value));
  }

  show(offset) {
    const feet = this.app.feet; if (!feet || !feet.top) return;
    const end = this.t0 + offset;
    feet.clear();
    for (const [, seq, t, v] of this.feetSamples) if (t <= end && t >= end - 10) feet.push({ q: seq, ts: t, v });
    for (const [, , t, v] of this.notices) if (t <= end && t >= end - 10) feet.marker(t, v.notice);
    feet.fresh = [];
    $("timeline-at").textContent = `${offset.toFixed(1)} s`;
    this.app.feetDirty = true; this.app.kick();
  }

  live() {
    this.active = false; document.body.classList.remove("replaying");
    $("timeline").disabled = true; $("live-view").hidden = true; $("timeline-at").textContent = "";
    this.app.feet.clear(); this.app.feetDirty = true; this.app.kick();
  }
}
