// Simulator faults (GET/PUT /api/sim/faults, cart2d/simulation/faults.py): in simulation only, one field per
// fault with its range and what it does (a tap or click on its name shows it, as in Tuning), so
// odometry drift can be caused on purpose and seen (the map's true pose against odometry) and
// calibration tried. On a real cart the GET answers 404 and the form stays hidden.

import { api, ApiError } from "./api";
import { byId, say } from "./dom";
import { num } from "./format";
import { parseNumber } from "./parse";
import { explainedName, type PanelContext } from "./tuning";

/** One fault as the gateway describes it (cart2d/server/admin.py, _faults_view). */
export interface SimFault {
  name: string;
  min: number;
  max: number;
  default: number;
  unit: string;
  whole: boolean;
  doc: string;
}

export interface SimFaultsView {
  faults: Record<string, number>;
  available: SimFault[];
}

function el<K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}): HTMLElementTagNameMap[K] {
  return Object.assign(document.createElement(tag), props);
}

function rangeText(f: SimFault): string {
  if (f.whole && f.max - f.min === 1) return `${num(f.min)} or ${num(f.max)}`;
  return `${num(f.min)} … ${num(f.max)}`;
}

/** The value typed for `f`, or a sentence saying what is wrong with it. */
export function checkFault(f: SimFault, text: string): { value: number } | { error: string } {
  const p = parseNumber(text, f.name);
  if (!p.ok) return { error: p.message };
  const unit = f.unit ? ` ${f.unit}` : "";
  if (p.value < f.min || p.value > f.max) {
    return { error: `${f.name} must be between ${num(f.min)} and ${num(f.max)}${unit}: ${num(p.value)} is out of range.` };
  }
  if (f.whole && !Number.isInteger(p.value)) return { error: `${f.name} takes ${rangeText(f)}, not ${num(p.value)}.` };
  return { value: p.value };
}

export class SimFaults {
  private view: SimFaultsView | null = null;
  private readonly section: HTMLElement;
  private readonly table: HTMLElement;
  private readonly msg: HTMLOutputElement;

  constructor(private readonly ctx: PanelContext) {
    this.section = byId("sim-faults");
    this.table = byId("faults-table");
    this.msg = byId<HTMLOutputElement>("faults-msg");
    byId<HTMLFormElement>("faults-form").addEventListener("submit", (e) => {
      e.preventDefault();
      void this.apply();
    });
    byId("faults-off").addEventListener("click", () => void this.put({}, "All faults off."));
    byId("faults-reload").addEventListener("click", () => void this.load());
  }

  /** Shows the form with the simulator's faults now; hides it on a real cart (404). */
  async load(): Promise<void> {
    try {
      await this.fetch();
    } finally {
      this.section.dataset["loaded"] = "true"; // shown or hidden for good: the layout has settled
    }
  }

  private async fetch(): Promise<void> {
    let view: SimFaultsView;
    try {
      view = await api<SimFaultsView>("GET", "/api/sim/faults");
    } catch (err) {
      if (err instanceof ApiError && err.status === 404) {
        this.section.hidden = true;
        return;
      }
      // a simulator that does not answer now: say so where the form is
      this.section.hidden = false;
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    this.show(view);
    say(this.msg, this.summary());
  }

  private show(view: SimFaultsView): void {
    this.view = view;
    this.table.replaceChildren(...view.available.map((f) => this.row(f, view.faults[f.name] ?? f.default)));
    this.section.hidden = false;
    this.section.dataset["active"] = String(this.active().length);
  }

  /** The faults that are on (a value other than their default), as "name = value". */
  private active(): string[] {
    const view = this.view;
    if (!view) return [];
    return view.available
      .filter((f) => (view.faults[f.name] ?? f.default) !== f.default)
      .map((f) => `${f.name} = ${num(view.faults[f.name] ?? f.default)}${f.unit ? ` ${f.unit}` : ""}`);
  }

  private summary(): string {
    const on = this.active();
    return on.length === 0 ? "No fault is on." : `On: ${on.join(", ")}.`;
  }

  private row(f: SimFault, value: number): HTMLElement {
    const row = el("div", { className: "tune-row fault-row" });
    row.dataset["fault"] = f.name;
    const docId = `fault-doc-${f.name}`;
    const unit = f.unit ? ` ${f.unit}` : "";
    const [name, doc] = explainedName(
      f.name,
      f.doc,
      docId,
      `${f.doc.charAt(0).toUpperCase()}${f.doc.slice(1)} (${f.name}; ${rangeText(f)}${unit}; off at ${num(f.default)}).`,
    );
    const input = el("input", { name: f.name, inputMode: f.whole ? "numeric" : "decimal", autocomplete: "off", value: num(value), title: f.doc });
    input.setAttribute("aria-label", `${f.name}${f.unit ? ` (${f.unit})` : ""}`);
    input.setAttribute("aria-describedby", docId);
    input.addEventListener("input", () => this.mark(row, f, input));
    const unitEl = el("span", { className: "tune-unit" });
    unitEl.textContent = f.unit;
    const range = el("span", { className: "tune-range muted" });
    range.textContent = rangeText(f);
    const mark = el("span", { className: "tune-unapplied" });
    mark.textContent = "not applied";
    row.append(name, input, unitEl, range, mark, doc);
    return row;
  }

  /** Marks the row while its field differs from the value the simulator has. */
  private mark(row: HTMLElement, f: SimFault, input: HTMLInputElement): void {
    const now = this.view?.faults[f.name] ?? f.default;
    const p = parseNumber(input.value, f.name);
    row.dataset["unapplied"] = String(!(p.ok && num(p.value) === num(now)));
  }

  /** Every field checked, then the whole set sent (those at their default left out: off). */
  private async apply(): Promise<void> {
    const view = this.view;
    if (!view) return this.load();
    const chosen: Record<string, number> = {};
    const problems: string[] = [];
    for (const f of view.available) {
      const input = this.table.querySelector<HTMLInputElement>(`input[name="${CSS.escape(f.name)}"]`);
      if (!input) continue;
      const checked = checkFault(f, input.value);
      if ("error" in checked) {
        problems.push(checked.error);
        input.setAttribute("aria-invalid", "true");
        continue;
      }
      input.removeAttribute("aria-invalid");
      if (checked.value !== f.default) chosen[f.name] = checked.value;
    }
    if (problems.length > 0) {
      say(this.msg, `Not applied: ${problems.join(" ")}`, true);
      this.table.querySelector<HTMLInputElement>('input[aria-invalid="true"]')?.focus();
      return;
    }
    await this.put(chosen, null);
  }

  private async put(chosen: Record<string, number>, done: string | null): Promise<void> {
    try {
      this.show(await api<SimFaultsView>("PUT", "/api/sim/faults", chosen));
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    say(this.msg, done ?? `Applied. ${this.summary()} They last until changed or the gateway stops.`);
  }
}
