// The live `esair std ls` table; an operator adds, removes and restarts behaviors.
const COLS = ["name", "kind", "state", "pid", "host", "restarts", "reason"];

export class Components {
  constructor(table, form, app) {
    this.body = table.tBodies[0]; this.app = app;
    form.addEventListener("submit", (e) => { e.preventDefault(); this.add(form); });
  }

  update(rows) {
    const same = JSON.stringify(rows);             // `ls` comes 4 times a second: the
    if (same === this.shown) return;               // table is rebuilt only when it changed
    this.shown = same;
    this.body.textContent = "";
    for (const r of rows) {
      const tr = document.createElement("tr"); tr.dataset.name = r.name;
      // what a narrow table leaves out (style.css) is in the row's title
      tr.title = COLS.slice(1).filter((c) => r[c] != null && r[c] !== "").map((c) => `${c}: ${r[c]}`).join("\n");
      for (const c of COLS) {
        const td = document.createElement("td"); td.textContent = r[c] ?? "";
        if (c === "state") td.className = `state-${r.state}`;
        tr.append(td);
      }
      const td = document.createElement("td"); td.className = "op-only";
      if (r.kind === "behavior" || r.kind === "reaction") {
        for (const [label, op] of [["restart", "restart"], ["remove", "remove"]]) {
          const b = document.createElement("button"); b.className = "small"; b.textContent = label;
          b.addEventListener("click", async () => {
            const res = await this.app.send({ op, name: r.name });
            if (res.ok || !res.logged) this.app.log.add(res.ok ? "info" : "error", `${op} ${r.name}: ${res.ok ? "done" : res.error}`);
          });
          td.append(b);
        }
      }
      tr.append(td);
      this.body.append(tr);
    }
  }

  async add(form) {
    const uses = {};
    for (const part of form.querySelector("#add-uses").value.split(",")) {
      const [k, v] = part.split("=").map((x) => x.trim());
      if (k) uses[k] = v || "read";
    }
    const name = form.querySelector("#add-name").value.trim();
    const res = await this.app.send({ op: "add", name, class: form.querySelector("#add-class").value.trim(), uses });
    if (res.ok || !res.logged) this.app.log.add(res.ok ? "info" : "error", `add ${name}: ${res.ok ? res.result : res.error}`);
  }
}
