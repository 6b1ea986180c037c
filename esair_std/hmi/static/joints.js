// One slider per servo actuator, within the servo's limits from the board files; the
// command is sent while dragging ("live", at most every 100 ms) or on release. A refused
// command puts the slider back at the robot's angle, the reason beside it.
const LIVE_MS = 100;
const SHOW_MS = 250;           // the sliders follow the commands 4 times a second at most

export class Joints {
  constructor(el, liveBox, info, entry, app) {
    this.el = el; this.live = liveBox; this.app = app; this.entry = entry; this.inputs = {};
    this.due = {}; this.shownAt = -1e9;
    this.held = {};            // servo -> the angle the robot was last told (commands, motions)
    el.textContent = "";
    if (!info) { el.textContent = "no servos"; return; }
    for (const s of info.servos) {
      const row = document.createElement("label"); row.className = "joint";
      const name = document.createElement("span"); name.textContent = s.name;
      const input = document.createElement("input");
      Object.assign(input, { type: "range", min: s.min, max: s.max, step: 1, value: s.stand });
      input.dataset.servo = s.name; input.title = `${s.name}: ${s.min}..${s.max}°`;
      const out = document.createElement("output"); out.textContent = `${s.stand}°`;
      const why = document.createElement("small"); why.className = "why"; why.hidden = true;
      this.held[s.name] = s.stand;
      let last = 0, timer = null;
      const sendNow = () => { last = performance.now(); timer = null;
        this.app.command(`${entry}.servo.${s.name}`, { angle: Number(input.value) })
          .then((r) => this.answered(s.name, r)); };
      input.addEventListener("input", () => {
        out.textContent = `${input.value}°`; input.dataset.dragging = "1";
        this.inputs[s.name][2] = Number(input.value);
        if (!this.live.checked) return;
        const wait = LIVE_MS - (performance.now() - last);
        if (wait <= 0) sendNow(); else if (!timer) timer = setTimeout(sendNow, wait);
      });
      input.addEventListener("change", () => {
        delete input.dataset.dragging;
        if (timer) { clearTimeout(timer); timer = null; }
        sendNow();
      });
      row.append(name, input, out, why);
      el.append(row);
      this.inputs[s.name] = [input, out, s.stand, why];   // the slider, its number, the angle shown, the refusal
    }
  }

  // A commanded angle is shown at the next frame at most SHOW_MS after the last write,
  // and only when it changed: each write lays out and paints the panel again, and the
  // robot's 12 servos may be commanded 50 times a second (app.js, frame).
  set(servo, angle) {
    if (this.inputs[servo]) { this.due[servo] = angle; this.held[servo] = angle; }
  }

  // A command's answer: went through, the reason goes; refused, the slider goes back to
  // the robot's angle (unless it is still being dragged) and the reason shows beside it.
  answered(servo, r) {
    const [input, out, , why] = this.inputs[servo];
    const res = `${this.entry}.servo.${servo}: `;        // the row names it already
    const reason = r.ok ? "" : String(r.error).startsWith(res) ? r.error.slice(res.length) : r.error;
    why.hidden = r.ok; why.textContent = r.ok ? "" : `refused: ${reason}`;
    why.title = why.textContent;
    if (r.ok || input.dataset.dragging) return;
    const angle = this.held[servo];
    input.value = angle; out.textContent = `${angle}°`; this.inputs[servo][2] = angle;
    delete this.due[servo];
  }

  // true while something is still to be shown (the frame asks for another)
  show(now) {
    if (!Object.keys(this.due).length) return false;
    if (now - this.shownAt < SHOW_MS) return true;
    this.shownAt = now;
    for (const [servo, angle] of Object.entries(this.due)) {
      const io = this.inputs[servo];
      if (io[0].dataset.dragging || io[2] === angle) continue;
      io[2] = angle; io[0].value = angle; io[1].textContent = `${angle}°`;
    }
    this.due = {};
    return false;
  }

  sync(angles) { for (const [k, v] of Object.entries(angles)) this.set(k, v); }
}

// Buttons for the robot's motions (its EEPROM image) and stand.
export class Motions {
  constructor(el, info, entry, app) {
    el.textContent = "";
    if (!info) return;
    const add = (label, command) => {
      const b = document.createElement("button"); b.textContent = label; b.dataset.motion = label;
      b.addEventListener("click", () => app.command(`${entry}.motion`, command));
      el.append(b);
    };
    for (const m of info.motions) add(m.name, { play: m.name });
  }
}
