// The generic-command form: any protocol command (GET /api/protocol), described from the
// protocol's table, with its arguments checked in the page (a setting's name is taken wherever a
// setting id is expected) and its reply decoded: a refusal's reason, STATUS's mode and flags, a
// setting's name beside its id, numbers without float32 noise. A command whose arguments go on
// (WAIT_XY_ARRAY n, x0, y0, …; XY_APPEND) takes points up to what one frame carries ("Add a point").

import { api, type CommandReply, type ProtocolCommand } from "./api";
import { byId, say } from "./dom";
import { count } from "./format";
import { parseNumber } from "./parse";
import { commandDoc, describeResults, listOf, type SettingName } from "./protocol";
import type { PanelContext } from "./tuning";

type Parsed = { ok: true; value: number } | { ok: false; message: string };

const FIXED_INPUTS = 4; // the form's own argument fields (index.html)
const MAX_POINTS = 15; // points one WAIT_XY_ARRAY or XY_APPEND frame carries (docs/protocol.md)

/** The name of argument `k` of a command whose arguments go on: its head, then x0, y0, x1, … */
function goingOnName(names: string[], k: number): string {
  if (k === 0) return names[0] ?? "";
  const point = Math.floor((k - 1) / 2);
  return `${k % 2 === 1 ? "x" : "y"}${point}`;
}

/** Argument `k` of `c` as typed: a number, or for a setting id also the setting's name. */
function argument(c: ProtocolCommand, k: number, text: string, settings: SettingName[]): Parsed {
  const name = listOf(c.args)[k];
  const what = `Argument ${k + 1}${name && name !== "…" ? ` (${name})` : ""}`;
  if (name === "id") {
    const byName = settings.find((s) => s.name === text.trim());
    if (byName) return { ok: true, value: byName.id };
    const p = parseNumber(text, what);
    if (p.ok || text.trim() === "") return p;
    const known = settings.length ? `: ${settings.map((s) => s.name).join(", ")}` : "";
    return { ok: false, message: `${what} is neither a setting's id nor its name: “${text.trim()}”. The names${known}.` };
  }
  return parseNumber(text, what);
}

export class CommandForm {
  private commands: ProtocolCommand[] = [];
  private readonly form = byId<HTMLFormElement>("cmd-form");
  private readonly select = byId<HTMLSelectElement>("cmd-name");
  private readonly msg = byId<HTMLOutputElement>("cmd-msg");
  private readonly argsBox = this.form.querySelector<HTMLElement>(".args") as HTMLElement;
  private readonly more = byId<HTMLButtonElement>("cmd-more");
  private inputs = [0, 1, 2, 3].map((k) => this.form.elements.namedItem(`a${k}`) as HTMLInputElement);
  private points = 1; // the points offered to a command whose arguments go on
  /** Called with a command the firmware accepted (the map draws a path sent past the planner). */
  onAccepted: (name: string, args: number[]) => void = () => {};

  constructor(
    private readonly ctx: PanelContext,
    private readonly settings: () => SettingName[],
  ) {
    this.select.addEventListener("change", () => {
      this.points = 1;
      this.describe();
      this.clearReply();
    });
    this.more.addEventListener("click", () => {
      this.points = Math.min(MAX_POINTS, this.points + 1);
      this.describe();
      this.inputs[2 * this.points - 1]?.focus();
    });
    this.form.addEventListener("submit", (e) => {
      e.preventDefault();
      this.submit();
    });
  }

  async load(): Promise<void> {
    try {
      this.commands = await api<ProtocolCommand[]>("GET", "/api/protocol");
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    this.select.replaceChildren(
      ...this.commands.map((c) => {
        const o = document.createElement("option");
        o.value = c.name;
        o.textContent = c.name;
        return o;
      }),
    );
    if (this.commands.some((c) => c.name === "POSE")) this.select.value = "POSE";
    this.describe();
  }

  /** The setting names an id field offers (a datalist), once the tuning table has loaded. */
  settingsLoaded(): void {
    const list = byId<HTMLDataListElement>("setting-names");
    list.replaceChildren(
      ...this.settings().map((s) => {
        const o = document.createElement("option");
        o.value = s.name;
        o.label = `id ${s.id}`;
        return o;
      }),
    );
  }

  private selected(): ProtocolCommand | undefined {
    return this.commands.find((c) => c.name === this.select.value);
  }

  /** As many argument fields as `n` (at least the form's own four): added or taken away. */
  private fields(n: number): void {
    const wanted = Math.max(FIXED_INPUTS, n);
    while (this.inputs.length < wanted) {
      const input = document.createElement("input");
      input.name = `a${this.inputs.length}`;
      input.autocomplete = "off";
      this.argsBox.append(input);
      this.inputs.push(input);
    }
    for (const extra of this.inputs.splice(wanted)) extra.remove();
  }

  private describe(): void {
    const c = this.selected();
    if (!c) return;
    const names = listOf(c.args).filter((n) => n !== "…");
    const goesOn = c.arg_count === null;
    this.fields(goesOn ? 1 + 2 * this.points : FIXED_INPUTS);
    this.more.hidden = !goesOn;
    this.more.disabled = this.points >= MAX_POINTS;
    this.inputs.forEach((input, k) => {
      const used = goesOn ? k < 1 + 2 * this.points : k < (c.arg_count ?? 0);
      const name = goesOn ? goingOnName(names, k) : names[k];
      const isId = name === "id";
      input.disabled = !used;
      input.placeholder = used ? (isId ? "id or name" : (name ?? "")) : "";
      input.inputMode = isId ? "text" : "decimal";
      if (isId) input.setAttribute("list", "setting-names");
      else input.removeAttribute("list");
      input.setAttribute("aria-label", used && name ? `argument ${k + 1}: ${name}` : `argument ${k + 1}`);
      if (!used) input.value = "";
    });
    const doc = commandDoc(c.name);
    byId("cmd-doc").textContent = doc?.notes ? `${doc.notes.charAt(0).toUpperCase()}${doc.notes.slice(1)}.` : "";
    byId("cmd-args-hint").textContent =
      `arguments: ${c.args === "–" ? "none" : c.args}${goesOn ? ` (up to ${MAX_POINTS} points: Add a point)` : ""}; ` +
      `results: ${c.results === "–" ? "none" : c.results}`;
    this.msg.textContent = "";
  }

  /** The arguments typed, or a sentence saying why they cannot be sent. */
  private args(c: ProtocolCommand): { args: number[] } | { error: string } {
    const texts = this.inputs.map((i) => (i.disabled ? "" : i.value.trim()));
    const wanted = c.arg_count ?? texts.reduce((n, t, k) => (t !== "" ? k + 1 : n), 0);
    if (c.arg_count === null && wanted > 1 && wanted % 2 === 0) {
      return { error: `${c.name}: point ${wanted / 2 - 1} has its x but no y.` };
    }
    const args: number[] = [];
    for (let k = 0; k < wanted; k++) {
      const p = argument(c, k, texts[k] ?? "", this.settings());
      if (!p.ok) {
        const needs = texts[k] === "" ? `${c.name} needs ${count(wanted, "argument")}: ` : `${c.name}: `;
        return { error: `${needs}${p.message}` };
      }
      args.push(p.value);
    }
    return { args };
  }

  private submit(): void {
    const c = this.selected();
    if (!c) {
      say(this.msg, "Pick a command first.", true);
      return;
    }
    const parsed = this.args(c);
    if ("error" in parsed) {
      this.clearReply(); // a reply on screen belongs to an earlier command, not to this one
      say(this.msg, parsed.error, true);
      return;
    }
    void this.send(c, parsed.args);
  }

  private clearReply(): void {
    for (const id of ["cmd-sent", "cmd-status", "cmd-results", "cmd-message"]) {
      const dd = byId(id);
      dd.textContent = "–";
      dd.className = "";
    }
  }

  private async send(c: ProtocolCommand, args: number[]): Promise<void> {
    this.clearReply();
    say(this.msg, `Sending ${c.name}…`);
    try {
      const reply = await api<CommandReply>("POST", "/api/command", { name: c.name, args });
      byId("cmd-sent").textContent = [c.name, ...args.map(String)].join(" ");
      const status = byId("cmd-status");
      status.textContent = reply.status;
      status.className = reply.status === "CONTROL_OK" ? "ok" : "bad";
      const doc = commandDoc(c.name) ?? { code: c.code, name: c.name, args: c.args, results: c.results, notes: "" };
      const lines = describeResults(doc, reply.status, reply.results, this.settings());
      const results = byId("cmd-results");
      if (lines.length === 0) results.textContent = "none";
      else {
        const list = document.createElement("ul");
        list.className = "results";
        list.replaceChildren(
          ...lines.map((line) => {
            const li = document.createElement("li");
            li.textContent = line;
            return li;
          }),
        );
        results.replaceChildren(list);
      }
      byId("cmd-message").textContent = reply.message || "–";
      say(this.msg, `${c.name} answered.`);
      if (reply.status === "CONTROL_OK") this.onAccepted(c.name, args);
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
    }
  }
}
