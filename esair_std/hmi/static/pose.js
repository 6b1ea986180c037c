// The robot's pose from the commanded angles (sent by a page, or a motion's frames as
// the robot plays them, one frame each delay_ticks ticks). A robot whose actuator board
// has a `figure: {kind: biped}` section (docs/board-format.md; PAPA-MAN) is drawn as a
// stick figure, front and side, from its link lengths and the servo of each joint; any
// other robot's joints as dials.
const RAD = Math.PI / 180;
const HEAD = 0.25;                       // the head's radius, in thighs (drawn only)
const SIDES = { l: "left", r: "right" };
// the figure is drawn again at most this often (ms): the robot's servos may be commanded
// 50 times a second, and each picture costs the browser a frame's compositing of its
// panel (docs/hmi.md); a motion's frames still show as they come at a motion's pace
const POSE_MS = 100;

export class Pose {
  constructor(el, note, info) {
    this.el = el; this.info = info; this.angles = {}; this.motion = null; this.changed = true;
    this.drawnAt = -1e9;
    el.textContent = "";
    if (!info) { note.textContent = "(no robot board files)"; return; }
    for (const s of info.servos) this.angles[s.name] = s.stand;
    this.fig = info.figure && info.figure.kind === "biped" ? info.figure : null;
    this.biped = !!this.fig;
    if (this.fig) {                      // lengths in thighs
      const L = this.fig.links_mm;
      this.G = { torso: L.torso / L.thigh, hip: L.hip / L.thigh, thigh: 1,
                 shank: L.shank / L.thigh, foot: L.foot / L.thigh, head: HEAD };
      this.stand = Object.fromEntries(info.servos.map((s) => [s.name, s.stand]));
    }
    this.canvas = document.createElement("canvas");
    this.w = 520; this.h = this.biped ? 300 : 60 + 90 * Math.ceil(info.servos.length / 6);
    el.append(this.canvas);
    this.ctx = this.canvas.getContext("2d", { alpha: false });     // opaque: copied, not blended
    this.size();
    window.addEventListener("resize", () => { if (this.size()) this.draw(); });
    note.textContent = this.biped ? "commanded · front and side" : "commanded · joints as dials";
    this.draw();
  }

  set(angles) {                          // redrawn at the next frame when an angle changed
    for (const [k, v] of Object.entries(angles)) {
      if (this.angles[k] !== v) { this.angles[k] = v; this.changed = true; }
    }
  }

  // plays `motion` from `ms` into it (a page opened while it plays; past its end: its last frame)
  play(motion, tick_s, ms = 0) {
    if (!motion || !this.info) return;
    this.motion = { motion, tick_s, t0: performance.now() - ms, shown: -1 };
  }

  // The index of the frame `motion` shows `ms` after the robot took its PLY line, as the
  // robot's frame player writes them (esair_min/core/player.py): frame 0 at the first tick
  // after the line, then one each delay_ticks ticks; the first tick comes 0 to 1 tick
  // after the line (half a tick taken). Before it: -1; past the end: the last frame.
  frameAt(motion, tick_s, ms) {
    const tick = tick_s * 1000;
    const i = Math.floor((ms - tick / 2) / (motion.delay_ticks * tick));
    return Math.max(-1, Math.min(motion.frames.length - 1, i));
  }

  halt() { this.motion = null; }

  // shows frame `i` of `motion` (this.shown says which: the tests compare it with the robot's)
  show(motion, i) { this.shown = { motion: motion.name, frame: i }; this.set(motion.frames[i]); }

  // called each animation frame; true when the angles changed
  animate(now) {
    if (!this.info) return false;
    if (this.motion) {
      const m = this.motion, last = m.motion.frames.length - 1;
      const i = this.frameAt(m.motion, m.tick_s, now - m.t0);
      if (i >= 0 && i !== m.shown) { m.shown = i; this.show(m.motion, i); }
      if (i === last) this.motion = null;
    }
    if (!this.changed || now - this.drawnAt < POSE_MS) return false;
    this.changed = false; this.drawnAt = now;
    this.draw();
    return true;
  }

  // The canvas has as many pixels as it shows (CSS pixels times the device's ratio): the
  // figure is drawn in a 520-wide space scaled to it, not drawn large and scaled down by
  // the compositor at every frame. True when the size changed.
  size() {
    const css = Math.min(this.w, this.el.clientWidth || this.w), r = window.devicePixelRatio || 1;
    const k = (css / this.w) * r, W = Math.round(this.w * k), H = Math.round(this.h * k);
    if (W === this.canvas.width && H === this.canvas.height) return false;
    this.k = k; this.canvas.width = W; this.canvas.height = H;
    this.canvas.style.width = `${css}px`; this.canvas.style.height = `${Math.round(this.h * css / this.w)}px`;
    return true;
  }

  draw() {
    if (!this.canvas) return;
    const c = this.ctx;
    c.setTransform(1, 0, 0, 1, 0, 0);
    c.fillStyle = "#fff"; c.fillRect(0, 0, this.canvas.width, this.canvas.height);
    c.setTransform(this.k, 0, 0, this.k, 0, 0);
    if (this.biped) { this.front(c, 130, 40, 55); this.side(c, 390, 40, 55); }
    else this.dials(c);
  }

  // degrees the joint of leg `side` (l, r) is turned from straight, per the figure
  a(side, joint) {
    const servo = this.fig.legs[SIDES[side]][joint];
    const zero = this.fig.zero[servo] ?? this.stand[servo] ?? 90;
    return ((this.angles[servo] ?? zero) - zero) * (this.fig.reversed.includes(servo) ? -1 : 1);
  }

  limb(c, x, y, ang, len, s) { const x2 = x + Math.sin(ang) * len * s, y2 = y + Math.cos(ang) * len * s;
    c.lineTo(x2, y2); return [x2, y2]; }

  front(c, cx, top, s) {
    const G = this.G;
    c.lineWidth = 5; c.lineCap = "round"; c.strokeStyle = "#1d2430";
    c.font = "12px system-ui"; c.fillStyle = "#6b7280"; c.fillText("front", cx - 14, top - 22);
    const hipY = top + G.torso * s;
    c.beginPath(); c.arc(cx, top - 4, G.head * s, 0, 2 * Math.PI); c.stroke();
    c.beginPath(); c.moveTo(cx, top + G.head * s - 4); c.lineTo(cx, hipY);
    c.moveTo(cx - G.hip * s, hipY); c.lineTo(cx + G.hip * s, hipY); c.stroke();
    for (const [side, dir] of [["l", 1], ["r", -1]]) {   // the robot's left is on our right
      const roll = this.a(side, "hip_roll") * RAD * dir;
      const bend = Math.cos(this.a(side, "knee") * RAD);   // a bent knee looks shorter
      c.strokeStyle = side === "l" ? "#2563eb" : "#b45309";
      c.beginPath(); c.moveTo(cx + dir * G.hip * s, hipY);
      let [x, y] = this.limb(c, cx + dir * G.hip * s, hipY, roll, G.thigh * Math.abs(bend) ** 0.5, s);
      [x, y] = this.limb(c, x, y, roll, G.shank * Math.abs(bend) ** 0.5, s);
      const ankle = roll + this.a(side, "ankle_roll") * RAD * dir;
      c.moveTo(x - Math.cos(ankle) * G.foot * s * 0.6, y + Math.sin(ankle) * G.foot * s * 0.6);
      c.lineTo(x + Math.cos(ankle) * G.foot * s * 0.6, y - Math.sin(ankle) * G.foot * s * 0.6);
      c.stroke();
    }
  }

  side(c, cx, top, s) {
    const G = this.G;
    c.lineWidth = 5; c.lineCap = "round";
    c.font = "12px system-ui"; c.fillStyle = "#6b7280"; c.fillText("side", cx - 12, top - 22);
    const hipY = top + G.torso * s;
    c.strokeStyle = "#1d2430";
    c.beginPath(); c.arc(cx, top - 4, G.head * s, 0, 2 * Math.PI); c.stroke();
    c.beginPath(); c.moveTo(cx, top + G.head * s - 4); c.lineTo(cx, hipY); c.stroke();
    for (const side of ["r", "l"]) {                     // the left leg drawn in front
      const hip = this.a(side, "hip_pitch") * RAD;
      const knee = hip - this.a(side, "knee") * RAD;
      const ankle = knee + this.a(side, "ankle_pitch") * RAD;
      c.strokeStyle = side === "l" ? "#2563eb" : "#b45309";
      c.beginPath(); c.moveTo(cx, hipY);
      let [x, y] = this.limb(c, cx, hipY, hip, G.thigh, s);
      [x, y] = this.limb(c, x, y, knee, G.shank, s);
      c.lineTo(x + Math.cos(ankle) * G.foot * s, y - Math.sin(ankle) * G.foot * s);
      c.stroke();
    }
  }

  dials(c) {
    const servos = this.info.servos;
    servos.forEach((sv, i) => {
      const x = 45 + (i % 6) * 80, y = 50 + Math.floor(i / 6) * 90, r = 30;
      const frac = (a) => Math.PI * (0.75 + 1.5 * (a - sv.min) / Math.max(1, sv.max - sv.min));
      c.lineWidth = 6; c.strokeStyle = "#d8dce3";
      c.beginPath(); c.arc(x, y, r, frac(sv.min), frac(sv.max)); c.stroke();
      const ang = this.angles[sv.name];
      c.strokeStyle = "#2563eb"; c.beginPath(); c.arc(x, y, r, frac(sv.min), frac(ang)); c.stroke();
      c.fillStyle = "#1d2430"; c.font = "12px system-ui"; c.textAlign = "center";
      c.fillText(`${ang}°`, x, y + 4); c.fillStyle = "#6b7280"; c.font = "10px system-ui";
      c.fillText(sv.name, x, y + r + 14); c.textAlign = "start";
    });
  }
}
