// Tuning: every firmware setting (GET /api/firmware/settings) with its unit, range and doc,
// edited and applied one at a time (PUT), saved to / loaded from EEPROM; and a step response
// (drive straight at a fixed speed for a moment, plot the measured wheel speeds against it).

import uPlot from "uplot";
import { api, type FirmwareSetting, type Telemetry } from "./api";
import { byId, cssVar, say } from "./dom";
import { parseNumber } from "./parse";
import { axisStyle } from "./plots";

export interface PanelContext {
  notify(text: string, kind?: "error" | "info"): void;
  errorText(err: unknown): string;
}

/** A value as the firmware holds it (float32), shown without its rounding noise. */
function show(v: number): string {
  return String(Number(v.toPrecision(6)));
}

function el<K extends keyof HTMLElementTagNameMap>(tag: K, props: Partial<HTMLElementTagNameMap[K]> = {}): HTMLElementTagNameMap[K] {
  return Object.assign(document.createElement(tag), props);
}

export class Tuning {
  private settings: FirmwareSetting[] = [];
  private readonly table: HTMLElement;
  private readonly msg: HTMLOutputElement;

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

  async load(): Promise<void> {
    try {
      this.settings = await api<FirmwareSetting[]>("GET", "/api/firmware/settings");
    } catch (err) {
      say(this.msg, this.ctx.errorText(err), true);
      return;
    }
    this.table.replaceChildren(...this.settings.map((s) => this.row(s)));
    this.table.dataset["count"] = String(this.settings.length);
  }

  private row(s: FirmwareSetting): HTMLElement {
    const form = el("form", { className: "tune-row", noValidate: true });
    form.dataset["setting"] = s.name;
    const label = el("label", { className: "tune-name", title: s.doc, htmlFor: `tune-${s.id}` });
    label.textContent = s.name;
    const input = el("input", {
      id: `tune-${s.id}`,
      name: "value",
      inputMode: "decimal",
      autocomplete: "off",
      value: show(s.value),
      title: s.doc,
    });
    input.setAttribute("aria-label", `${s.name} (${s.unit})`);
    const unit = el("span", { className: "tune-unit" });
    unit.textContent = s.unit;
    const range = el("span", { className: "tune-range muted" });
    range.textContent = `${show(s.min)} … ${show(s.max)}`;
    const apply = el("button", { type: "submit", className: "small" });
    apply.textContent = "Apply";
    form.append(label, input, unit, range, apply);
    form.addEventListener("submit", (e) => {
      e.preventDefault();
      void this.apply(s, input);
    });
    return form;
  }

  private async apply(s: FirmwareSetting, input: HTMLInputElement): Promise<void> {
    const p = parseNumber(input.value, s.name);
    if (!p.ok) {
      say(this.msg, p.message, true);
      input.setAttribute("aria-invalid", "true");
      return;
    }
    if (p.value < s.min || p.value > s.max) {
      say(this.msg, `${s.name} must be between ${show(s.min)} and ${show(s.max)} ${s.unit}: ${show(p.value)} is out of range.`, true);
      input.setAttribute("aria-invalid", "true");
      return;
    }
    input.removeAttribute("aria-invalid");
    try {
      const reply = await api<{ value: number }>("PUT", "/api/firmware/settings", { id: s.id, value: p.value });
      s.value = reply.value;
      input.value = show(reply.value);
      say(this.msg, `${s.name} = ${show(reply.value)} ${s.unit} (applied; “Save to EEPROM” keeps it after a reset).`);
    } catch (err) {
      input.setAttribute("aria-invalid", "true");
      say(this.msg, this.ctx.errorText(err), true);
    }
  }

  private async eeprom(what: "save" | "load"): Promise<void> {
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

// -- step response -----------------------------------------------------------------------------

const STEP_V = 0.3; // m/s
const STEP_S = 1.5; // driving
const AFTER_S = 0.6; // recorded after the stop
const REPEAT_MS = 150; // the gateway stops manual driving without a command every 0.5 s

export class StepResponse {
  private recording: { t0: number; t: number[]; left: number[]; right: number[]; target: number[] } | null = null;
  private timer: number | null = null;
  private plot: uPlot | null = null;
  private readonly button: HTMLButtonElement;
  private readonly msg: HTMLOutputElement;

  constructor(
    private readonly root: HTMLElement,
    private readonly ctx: PanelContext,
  ) {
    this.button = byId<HTMLButtonElement>("step-run", root);
    this.msg = byId<HTMLOutputElement>("step-msg", root);
    this.button.addEventListener("click", () => void this.run());
  }

  get running(): boolean {
    return this.timer !== null;
  }

  onTelemetry(frame: Telemetry): void {
    const r = this.recording;
    if (!r) return;
    r.t.push((performance.now() - r.t0) / 1000);
    r.left.push(frame.v_left);
    r.right.push(frame.v_right);
    r.target.push((frame.v_left_target + frame.v_right_target) / 2);
  }

  /** Stops a step response under way (the emergency stop). */
  cancel(): void {
    if (this.timer !== null) window.clearInterval(this.timer);
    this.timer = null;
    if (this.recording) this.finish("Step response interrupted.");
  }

  private async run(): Promise<void> {
    if (this.running) return;
    this.root.dataset["step"] = "running";
    this.button.disabled = true;
    say(this.msg, `Driving straight at ${STEP_V} m/s for ${STEP_S} s…`);
    this.recording = { t0: performance.now(), t: [], left: [], right: [], target: [] };
    const started = performance.now();
    const send = async (v: number): Promise<boolean> => {
      try {
        await api("POST", "/api/drive", { v, omega: 0 }, 2000);
        return true;
      } catch (err) {
        this.cancel();
        say(this.msg, this.ctx.errorText(err), true);
        return false;
      }
    };
    if (!(await send(STEP_V))) return;
    this.timer = window.setInterval(() => {
      if ((performance.now() - started) / 1000 < STEP_S) {
        void send(STEP_V);
        return;
      }
      if (this.timer !== null) window.clearInterval(this.timer);
      this.timer = null;
      void send(0).then(() => window.setTimeout(() => this.finish(), AFTER_S * 1000));
    }, REPEAT_MS);
  }

  private finish(note = ""): void {
    const r = this.recording;
    this.recording = null;
    this.button.disabled = false;
    this.root.dataset["step"] = "done";
    if (!r) return;
    this.draw(r);
    // over the last half second of driving: the mean speed and its error
    const window0 = STEP_S - 0.5;
    const steady = r.t.map((t, k) => [t, ((r.left[k] ?? 0) + (r.right[k] ?? 0)) / 2] as const).filter(([t]) => t >= window0 && t <= STEP_S);
    const mean = steady.reduce((a, [, v]) => a + v, 0) / Math.max(1, steady.length);
    const peak = Math.max(0, ...r.left, ...r.right);
    const rise = r.t.find((_, k) => ((r.left[k] ?? 0) + (r.right[k] ?? 0)) / 2 >= 0.9 * STEP_V);
    this.root.dataset["samples"] = String(r.t.length);
    this.root.dataset["peak"] = peak.toFixed(4);
    if (note) {
      this.msg.textContent = note;
      return;
    }
    this.msg.textContent =
      `${r.t.length} samples: ` +
      `90 % of ${STEP_V} m/s ${rise === undefined ? "never reached" : `after ${rise.toFixed(2)} s`}, ` +
      `peak ${peak.toFixed(3)} m/s (${(((peak - STEP_V) / STEP_V) * 100).toFixed(0)} % overshoot), ` +
      `steady ${mean.toFixed(3)} m/s (error ${(((mean - STEP_V) / STEP_V) * 100).toFixed(1)} %).`;
  }

  private draw(r: { t: number[]; left: number[]; right: number[]; target: number[] }): void {
    const host = this.root.querySelector<HTMLElement>("#step-plot");
    if (!host) return;
    const data: uPlot.AlignedData = [r.t, r.left, r.right, r.target];
    if (this.plot) {
      this.plot.setData(data);
      return;
    }
    const css = getComputedStyle(document.documentElement);
    const axis = axisStyle(css);
    this.plot = new uPlot(
      {
        title: "step response: wheel speed (m/s)",
        width: Math.max(240, host.clientWidth),
        height: 200,
        scales: { x: { time: false } },
        axes: [{ ...axis, label: "s" }, { ...axis }],
        series: [
          { label: "t (s)" },
          { label: "left", stroke: cssVar("--plot-a", "#1d4ed8", css), width: 2, points: { show: false } },
          { label: "right", stroke: cssVar("--plot-b", "#e76f51", css), width: 2, points: { show: false } },
          { label: "target", stroke: cssVar("--fg-muted", "#667", css), width: 1, dash: [6, 4], points: { show: false } },
        ],
      },
      data,
      host,
    );
    new ResizeObserver(() => this.plot?.setSize({ width: Math.max(240, host.clientWidth), height: 200 })).observe(host);
  }
}
