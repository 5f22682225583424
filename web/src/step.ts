// The step response: drive straight at a fixed speed for a moment, then stop, and plot the
// measured wheel speeds against the target on the firmware's time axis. It refuses to drive
// blind (no telemetry arriving), and a run in which the cart hit something (a front switch, a
// stalled wheel, a collision in the simulator) or telemetry stopped is reported as that, not as
// the controller's response.

import uPlot from "uplot";
import { api, type Telemetry } from "./api";
import { byId, cssVar, say } from "./dom";
import { age, count } from "./format";
import type { TelemetryClock } from "./health";
import { PlotLegend, seriesOptions } from "./plot-legend";
import { axisStyle } from "./plots";
import type { PanelContext } from "./tuning";

const STEP_V = 0.3; // m/s
const STEP_S = 1.5; // driving
const AFTER_S = 0.6; // recorded after the stop
const REPEAT_MS = 150; // the gateway stops manual driving without a command every 0.5 s
const TICK_S = 0.008;
const MIN_SAMPLES = 10;
/** Flags that mean the wheels could not follow the target (docs/protocol.md, Modes and flags). */
const BLOCKED = ["BUMPER", "STALLED", "SWITCH_LEFT", "SWITCH_RIGHT"];

interface Run {
  tick0: number | null;
  t: number[];
  left: number[];
  right: number[];
  target: number[];
  flags: Set<string>;
  collisions0: number | null;
  collisions: number;
}

export class StepResponse {
  private run: Run | null = null;
  private timer: number | null = null;
  private plot: uPlot | null = null;
  private readonly button: HTMLButtonElement;
  private readonly msg: HTMLOutputElement;

  constructor(
    private readonly root: HTMLElement,
    private readonly ctx: PanelContext,
    private readonly clock: TelemetryClock,
  ) {
    this.button = byId<HTMLButtonElement>("step-run", root);
    this.msg = byId<HTMLOutputElement>("step-msg", root);
    this.button.addEventListener("click", () => void this.start());
  }

  onTelemetry(frame: Telemetry): void {
    const r = this.run;
    if (!r) return;
    r.tick0 ??= frame.tick;
    r.t.push((((frame.tick - r.tick0 + 65536) % 65536) * TICK_S));
    r.left.push(frame.v_left);
    r.right.push(frame.v_right);
    r.target.push((frame.v_left_target + frame.v_right_target) / 2);
    for (const f of frame.flag_names) if (BLOCKED.includes(f)) r.flags.add(f);
  }

  /** The simulator's count of collisions and contacts (ground truth): a run that adds one hit
   * something. */
  onContacts(n: number): void {
    const r = this.run;
    if (!r) return;
    r.collisions0 ??= n;
    r.collisions = n;
  }

  /** Stops a step response under way (the emergency stop). */
  cancel(): void {
    if (this.timer !== null) window.clearInterval(this.timer);
    this.timer = null;
    if (this.run) this.finish("Step response interrupted.");
  }

  private async start(): Promise<void> {
    if (this.timer !== null || this.run) return;
    if (this.clock.stale()) {
      const a = this.clock.ageS();
      say(
        this.msg,
        `No step response: telemetry is not arriving (${a === null ? "none yet" : `the last frame came ${age(a)} ago`}), ` +
          "so the run would drive blind and measure nothing. Turn telemetry on (telemetry_hz above) and run it again.",
        true,
      );
      this.root.dataset["step"] = "refused";
      return;
    }
    this.root.dataset["step"] = "running";
    this.button.disabled = true;
    say(this.msg, `Driving straight at ${STEP_V} m/s for ${STEP_S} s…`);
    this.run = { tick0: null, t: [], left: [], right: [], target: [], flags: new Set(), collisions0: null, collisions: 0 };
    const started = performance.now();
    const send = async (v: number): Promise<boolean> => {
      try {
        await api("POST", "/api/drive", { v, omega: 0 }, 2000);
        return true;
      } catch (err) {
        if (this.timer !== null) window.clearInterval(this.timer);
        this.timer = null;
        // recorded a moment longer, as after a stop: the frames that say why it was refused
        const why = `The step response stopped: ${this.ctx.errorText(err)}`;
        window.setTimeout(() => this.finish(why, true), AFTER_S * 1000);
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

  /** Why the run is not a measure of the speed controller, if it is not. */
  private spoiled(r: Run): string | null {
    const hit = [...r.flags];
    if (r.collisions0 !== null && r.collisions > r.collisions0) hit.push("a wall or a box, the simulator says");
    if (hit.length) {
      return (
        `Not a tuning result: the cart hit something during the run (${hit.join(", ")}), so the wheels ` +
        "could not follow the target. Give it 0.5 m of room ahead and run it again."
      );
    }
    if (r.t.length < MIN_SAMPLES) {
      return `Not a tuning result: only ${count(r.t.length, "telemetry frame")} arrived during the run. Check telemetry_hz and run it again.`;
    }
    return null;
  }

  /** Ends the run: its plot, and its verdict; `note` instead of a result (an interruption, a
   * refused command), unless the run hit something, which is said first. */
  private finish(note = "", error = false): void {
    const r = this.run;
    this.run = null;
    this.button.disabled = false;
    this.root.dataset["step"] = "done";
    if (!r) return;
    this.draw(r);
    this.root.dataset["samples"] = String(r.t.length);
    const mean2 = (k: number): number => ((r.left[k] ?? 0) + (r.right[k] ?? 0)) / 2;
    const peak = Math.max(0, ...r.left, ...r.right);
    this.root.dataset["peak"] = peak.toFixed(4);
    const spoiled = this.spoiled(r);
    this.root.dataset["verdict"] = spoiled || note ? "none" : "result";
    if (spoiled && (error || !note)) {
      say(this.msg, spoiled, true);
      return;
    }
    if (note) {
      say(this.msg, note, error);
      return;
    }
    // over the last half second of driving: the mean speed and its error
    const steady = r.t.map((t, k) => [t, mean2(k)] as const).filter(([t]) => t >= STEP_S - 0.5 && t <= STEP_S);
    const mean = steady.reduce((a, [, v]) => a + v, 0) / Math.max(1, steady.length);
    const rise = r.t.find((_, k) => mean2(k) >= 0.9 * STEP_V);
    const overshoot = peak > STEP_V ? `${(((peak - STEP_V) / STEP_V) * 100).toFixed(0)} % overshoot` : "no overshoot";
    say(
      this.msg,
      `${r.t.length} samples: ` +
        `90 % of ${STEP_V} m/s ${rise === undefined ? "never reached" : `after ${rise.toFixed(2)} s`}, ` +
        `peak ${peak.toFixed(3)} m/s (${overshoot}), ` +
        `steady ${mean.toFixed(3)} m/s (error ${(((mean - STEP_V) / STEP_V) * 100).toFixed(1)} %).`,
    );
  }

  private draw(r: Run): void {
    const host = this.root.querySelector<HTMLElement>("#step-plot");
    if (!host) return;
    const data: uPlot.AlignedData = [r.t, r.left, r.right, r.target];
    if (this.plot) {
      this.plot.setData(data);
      return;
    }
    const css = getComputedStyle(document.documentElement);
    const axis = axisStyle(css);
    const styles = [
      { label: "left", stroke: cssVar("--plot-a", "#1d4ed8", css), target: false },
      { label: "right", stroke: cssVar("--plot-b", "#e76f51", css), target: false },
      { label: "target", stroke: cssVar("--fg-muted", "#667", css), target: true },
    ];
    const legend = new PlotLegend(styles);
    this.plot = new uPlot(
      {
        title: "step response: wheel speed (m/s)",
        width: Math.max(240, host.clientWidth),
        height: 200,
        scales: { x: { time: false } },
        axes: [{ ...axis, label: "s (firmware time)" }, { ...axis }],
        legend: { show: false },
        hooks: { setCursor: [(u) => legend.cursor(u)] },
        series: [{ label: "t (s)" }, ...styles.map(seriesOptions)],
      },
      data,
      host,
    );
    host.append(legend.root);
    new ResizeObserver(() => this.plot?.setSize({ width: Math.max(240, host.clientWidth), height: 200 })).observe(host);
  }
}
