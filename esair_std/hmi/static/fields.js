// A value (a behavior's state) as readable fields: one row per key, an object's keys one
// level down as "key.sub", numbers rounded, lists as their items or their count and last
// item, long text cut with its whole in the row's title. Rows are set in place.
const TEXT_MAX = 60;         // characters of one value shown (the rest in its title)
const LIST_MAX = 6;          // a list of this many plain items or fewer is shown whole

function plain(v) { return v === null || typeof v !== "object"; }

function num(x) {           // at most 3 decimals (a time stamp keeps its seconds)
  if (Number.isInteger(x) || !Number.isFinite(x)) return String(x);
  return String(Math.round(x * 1000) / 1000);
}

export function valueText(v) {
  if (v === null || v === undefined) return "–";
  if (typeof v === "number") return num(v);
  if (typeof v === "string") return v;
  if (typeof v !== "object") return String(v);
  if (Array.isArray(v)) {
    if (!v.length) return "none";
    if (v.length <= LIST_MAX && v.every(plain)) return v.map(valueText).join(", ");
    return `${v.length} · last ${valueText(v[v.length - 1])}`;
  }
  return Object.entries(v).map(([k, x]) => `${k} ${plain(x) ? valueText(x) : "…"}`).join(", ");
}

// [[key, text]] of a value: an object's keys (its objects' keys one level down)
export function fieldsOf(v) {
  if (plain(v) || Array.isArray(v)) return [["value", valueText(v)]];
  const out = [];
  for (const [k, x] of Object.entries(v)) {
    if (!plain(x) && !Array.isArray(x)) {
      const sub = Object.entries(x);
      if (!sub.length) out.push([k, "–"]);
      for (const [k2, y] of sub) out.push([`${k}.${k2}`, valueText(y)]);
    } else out.push([k, valueText(x)]);
  }
  return out;
}

export function showFields(dl, v) {
  const rows = fieldsOf(v);
  while (dl.children.length > 2 * rows.length) dl.lastChild.remove();
  while (dl.children.length < 2 * rows.length) dl.append(document.createElement(dl.children.length % 2 ? "dd" : "dt"));
  rows.forEach(([k, text], i) => {
    const dt = dl.children[2 * i], dd = dl.children[2 * i + 1];
    const cut = text.length > TEXT_MAX ? `${text.slice(0, TEXT_MAX - 1)}…` : text;
    if (dt.textContent !== k) dt.textContent = k;
    if (dd.textContent !== cut) dd.textContent = cut;
    const title = cut === text ? "" : text;
    if (dd.title !== title) dd.title = title;
  });
}
