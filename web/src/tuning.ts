// Tuning: every firmware setting (GET /api/firmware/settings) with its unit, range and what it
// does (a tap or click on its name shows it: touch screens have no hover), edited and applied one
// at a time (PUT), saved to / loaded from EEPROM. An edit not applied yet is marked, and "Save to
// EEPROM" refuses while there is one: it would save the value applied, not the one on screen.

import { api, type FirmwareSetting } from "./api";
import { byId, say } from "./dom";
import { count, num } from "./format";
import { parseNumber } from "./parse";

export interface PanelContext {
  notify(text: string, kind?: "error" | "info"): void;
  errorText(err: unknown): string;
}

function el<K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}): HTMLElementTagNameMap[K] {
  return Object.assign(document.createElement(tag), props);
}

/** A setting's name with line-break opportunities after its underscores only, so a narrow
 * screen wraps "manual_timeout_s" as "manual_ timeout_s", never inside a word. */
function breakable(name: string): Node[] {
  const parts = name.split(/(?<=_)/);
  return parts.flatMap((part, k) => (k < parts.length - 1 ? [document.createTextNode(part), el("wbr")] : [document.createTextNode(part)]));
}

/** A name that shows its explanation on a tap or a click (touch screens have no hover), and the
 * paragraph it shows: a setting's in the tuning table, a fault's in the simulator's form. */
export function explainedName(label: string, doc: string, docId: string, text: string): [HTMLButtonElement, HTMLElement] {
  const name = el("button", { type: "button", className: "tune-name", title: doc });
  name.append(...breakable(label));
  name.setAttribute("aria-expanded", "false");
  name.setAttribute("aria-controls", docId);
  const paragraph = el("p", { id: docId, className: "tune-doc", hidden: true });
  paragraph.textContent = text;
  name.addEventListener("click", () => {
    paragraph.hidden = !paragraph.hidden;
    name.setAttribute("aria-expanded", String(!paragraph.hidden));
  });
  return [name, paragraph];
}

export class Tuning {
  private settings: FirmwareSetting[] = [];
  private readonly table: HTMLElement;
  private readonly msg: HTMLOutputElement;
  /** Called after every (re)load of the table. */
  onLoad: () => void = () => {};

  constructor(
    root: HTMLElement,
    private readonly ctx: PanelContext,
  ) {
    this.table = byId("tune-table", root);
    this.msg = byId<HTMLOutputElement>("tune-msg", root);
    byId("tune-save", root).addEventListener("click", () => void this.eeprom("save"));
    byId("tune-load", root).addEventListener("click", () => void this.eeprom("load"));
    byId("tune-reload", root).addEventListener("click", () => void this.load());
  }

  /** A firmware setting's value as last read or applied, if the table is loaded. */
  value(name: string): number | undefined {
    return this.settings.find((s) => s.name === name)?.value;
  }

  /** Every setting's id and name (the command form takes names for ids). */
  names(): { id: number; name: string }[] {
    return this.settings.map(({ id, name }) => ({ id, name }));
  }

  async load(): Promise<void> {
    try {
      this.settings = await api<FirmwareSetting[]>("GET", "/api/firmware/settings");
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    this.table.replaceChildren(...this.settings.map((s) => this.row(s)));
    this.table.dataset["count"] = String(this.settings.length);
    this.onLoad();
  }

  /** The names of the settings whose field differs from the value applied. */
  unapplied(): string[] {
    return [...this.table.querySelectorAll<HTMLElement>('.tune-row[data-unapplied="true"]')].map((r) => r.dataset["setting"] ?? "");
  }

  private row(s: FirmwareSetting): HTMLElement {
    const form = el("form", { className: "tune-row", noValidate: true });
    form.dataset["setting"] = s.name;
    const docId = `tune-doc-${s.id}`;
    const [name, doc] = explainedName(
      s.name,
      s.doc,
      docId,
      `${s.doc.charAt(0).toUpperCase()}${s.doc.slice(1)} (${s.name}, id ${s.id}; default ${num(s.default)} ${s.unit}).`,
    );
    const input = el("input", {
      id: `tune-${s.id}`,
      name: "value",
      inputMode: "decimal",
      autocomplete: "off",
      value: num(s.value),
      title: s.doc,
    });
    input.setAttribute("aria-label", `${s.name} (${s.unit})`);
    input.setAttribute("aria-describedby", docId);
    const unit = el("span", { className: "tune-unit" });
    unit.textContent = s.unit;
    const range = el("span", { className: "tune-range muted" });
    range.textContent = `${num(s.min)} … ${num(s.max)}`;
    const mark = el("span", { className: "tune-unapplied" });
    mark.textContent = "not applied";
    const apply = el("button", { type: "submit", className: "small" });
    apply.textContent = "Apply";
    form.append(name, input, unit, range, mark, apply, doc);
    input.addEventListener("input", () => this.mark(form, s, input));
    form.addEventListener("submit", (e) => {
      e.preventDefault();
      void this.apply(s, input, form);
    });
    return form;
  }

  /** Marks the row while its field differs from the value applied. */
  private mark(form: HTMLElement, s: FirmwareSetting, input: HTMLInputElement): void {
    const p = parseNumber(input.value, s.name);
    form.dataset["unapplied"] = String(!(p.ok && num(p.value) === num(s.value)));
  }

  private async apply(s: FirmwareSetting, input: HTMLInputElement, form: HTMLElement): Promise<void> {
    const p = parseNumber(input.value, s.name);
    if (!p.ok) {
      say(this.msg, p.message, true);
      input.setAttribute("aria-invalid", "true");
      return;
    }
    if (p.value < s.min || p.value > s.max) {
      say(this.msg, `${s.name} must be between ${num(s.min)} and ${num(s.max)} ${s.unit}: ${num(p.value)} is out of range.`, true);
      input.setAttribute("aria-invalid", "true");
      return;
    }
    input.removeAttribute("aria-invalid");
    try {
      const reply = await api<{ value: number }>("PUT", "/api/firmware/settings", { id: s.id, value: p.value });
      s.value = reply.value;
      input.value = num(reply.value);
      this.mark(form, s, input);
      say(this.msg, `${s.name} = ${num(reply.value)} ${s.unit} (applied; “Save to EEPROM” keeps it after a reset).`);
    } catch (err) {
      input.setAttribute("aria-invalid", "true");
      say(this.msg, this.ctx.errorText(err), true);
    }
  }

  private async eeprom(what: "save" | "load"): Promise<void> {
    const pending = this.unapplied();
    if (what === "save" && pending.length > 0) {
      const them = pending.length === 1 ? "it" : "them";
      say(
        this.msg,
        `Not saved: ${count(pending.length, "edit")} not applied yet (${pending.join(", ")}). ` +
          `Save to EEPROM keeps the values applied: apply ${them} first, or Re-read to drop ${them}.`,
        true,
      );
      this.table.querySelector<HTMLInputElement>('.tune-row[data-unapplied="true"] input')?.focus();
      return;
    }
    try {
      await api("POST", `/api/firmware/${what}`);
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    if (what === "load") await this.load();
    say(this.msg, what === "save" ? "Settings saved to EEPROM." : "Settings loaded from EEPROM.");
  }
}
