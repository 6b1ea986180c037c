// Notices, errors and refusals, newest first, with a level filter.
const LEVELS = { debug: 0, info: 1, warning: 2, error: 3 };
const KEEP = 500;

export class Log {
  constructor(el, select) {
    this.el = el; this.select = select;
    select.addEventListener("change", () => this.filter());
  }

  add(level, text) {
    const li = document.createElement("li");
    li.className = level; li.dataset.level = level;
    li.textContent = `${new Date().toLocaleTimeString()} ${level.toUpperCase()} ${text}`;
    if ((LEVELS[level] ?? 1) < LEVELS[this.select.value]) li.classList.add("hidden");
    this.el.prepend(li);
    while (this.el.children.length > KEEP) this.el.lastChild.remove();
  }

  filter() {
    const min = LEVELS[this.select.value];
    for (const li of this.el.children) li.classList.toggle("hidden", (LEVELS[li.dataset.level] ?? 1) < min);
  }
}
